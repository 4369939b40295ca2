//! [`resolve_gpu`]: the generalized winding number's cap term on the GPU (`passes::gwn`), over a grid that
//! holds the winding rule of the capped mesh M ∪ C: the same voxels and the same answers as
//! `voxel::gwn::resolve_cpu`.
//!
//! Invariants: one submission a level of stage 1 and three more, each waited for: the box pass over the
//! coarsest boxes, then over the children of the boxes listed (each count read back sizes the next dispatch), the cap-term pass (the list read back, sorted, so the
//! order of the GPU's atomic appends never shows; crossing voxels answered on the host from the closed
//! mesh's crossing count, as the CPU method answers them), the direct pass (chunk sums read back and added
//! in chunk order on the CPU, as the CPU method adds them). Every buffer releases itself on every path. `Ok(None)` means "not on this device" (no
//! shaderFloat64, a loop or a binding past the pass's limits): the caller runs the CPU stages instead.
use super::GpuTriangles;
use crate::error::Result;
use crate::gpu::{Context, MemoryLocation};
use crate::passes::gwn::{GwnPasses, MAX_LOOP};
use crate::voxel::grid::VoxelGrid;
use crate::voxel::gwn::{
    apply_direct, check_budget, direct_chunks, direct_inside, level_dims, level_edge,
    resolve_crossings, winding_from_chunks, Cap, CapTerm, GwnStats, Listed, BRICK_LEVEL, CELL,
    LEVELS, LISTED_VOXEL_BYTES,
};
use crate::voxel::mesh::TriMesh;
use ash::vk;

/// Stages 1–3 on the GPU over `grid` (the winding rule of `closed` = M ∪ C). `tris` holds M ∪ C as uploaded
/// (M's positions and triangles first), `mesh` is M, `budget` bounds the listed voxels' bytes.
pub fn resolve_gpu(
    ctx: &Context,
    grid: &mut VoxelGrid,
    tris: &GpuTriangles,
    mesh: &TriMesh,
    closed: &TriMesh,
    cap: &Cap,
    budget: u64,
) -> Result<Option<GwnStats>> {
    let frame = grid.frame;
    let mut stats = GwnStats::of(cap);
    if cap.triangles.is_empty() {
        return Ok(Some(stats));
    }
    let term = CapTerm::new(cap, mesh, &frame);
    let boxes = |level: u32| {
        level_dims(&frame, level)
            .iter()
            .map(|&b| b as u64)
            .product::<u64>()
    };
    let max_range = ctx.limits.max_storage_buffer_range as u64;
    if !ctx.info.features.shader_float64
        || term.triangles.len() > MAX_LOOP
        || (boxes(LEVELS - 1) + 1) * 4 > max_range
        || boxes(LEVELS - 1) * 8 > u32::MAX as u64
    {
        return Ok(None);
    }
    let passes = GwnPasses::new(ctx)?;
    let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
    let cap_tris = ctx.upload_buffer(
        "gwn cap triangles",
        bytemuck::cast_slice(&term.triangles),
        storage,
    )?;
    let list_usage =
        storage | vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST;
    let lists = (0..LEVELS)
        .map(|level| {
            let name = format!("gwn boxes of {}³", level_edge(level));
            let n = boxes(level);
            ctx.create_buffer(&name, (n + 1) * 4, list_usage, MemoryLocation::GpuOnly)
        })
        .collect::<Result<Vec<_>>>()?;
    let tri_count = term.triangles.len() as u32;
    let mut count = 0u32;
    for level in 0..LEVELS {
        let l = level as usize;
        // Level 0 reads no list: any buffer will do.
        let ins = &lists[l.saturating_sub(1)];
        ctx.one_shot(|cmd| {
            passes.record_bricks(
                ctx, cmd, &frame, term.near, &cap_tris, tri_count, level, ins, count, &lists[l],
            )
        })?;
        count = read_u32(ctx, &lists[l])?;
        if level == BRICK_LEVEL {
            stats.bricks_evaluated = count as u64;
        }
        if count == 0 {
            return Ok(Some(stats));
        }
    }
    let cell_count = count;
    let cells = &lists[LEVELS as usize - 1];
    let cd = level_dims(&frame, LEVELS - 1);
    let listed_cells: Vec<u32> =
        bytemuck::pod_collect_to_vec(&ctx.read_buffer_range(cells, 4, cell_count as u64 * 4)?);
    stats.cap_term_voxels = listed_cells
        .iter()
        .map(|&b| {
            let c = [b % cd[0], (b / cd[0]) % cd[1], b / (cd[0] * cd[1])];
            (0..3)
                .map(|a| ((c[a] * CELL + CELL).min(frame.dims[a]) - c[a] * CELL) as u64)
                .product::<u64>()
        })
        .sum();
    let chunks = direct_chunks(mesh.triangles.len());
    // Room for every voxel of the listed bricks, within the budget and one binding.
    let capacity = (cell_count as u64 * (CELL * CELL * CELL) as u64)
        .min(budget / LISTED_VOXEL_BYTES)
        .min((max_range - 16) / LISTED_VOXEL_BYTES)
        .min(u32::MAX as u64) as u32;
    let listed_buf = ctx.create_buffer(
        "gwn listed voxels",
        16 + capacity.max(1) as u64 * LISTED_VOXEL_BYTES,
        list_usage,
        MemoryLocation::GpuOnly,
    )?;
    ctx.one_shot(|cmd| {
        passes.record_cap_term(
            ctx,
            cmd,
            &frame,
            term.near,
            &cap_tris,
            tri_count,
            cells,
            cell_count,
            &listed_buf,
            capacity,
        )
    })?;
    let count = read_u32(ctx, &listed_buf)? as u64;
    if count > capacity as u64 {
        // Past the budget (refused below with the direct count unknown: at least the list's) or one binding.
        check_budget(count, 0, chunks, budget)?;
        return Ok(None);
    }
    let raw = ctx.read_buffer_range(&listed_buf, 16, count * LISTED_VOXEL_BYTES)?;
    let mut listed: Vec<Listed> = raw
        .chunks_exact(LISTED_VOXEL_BYTES as usize)
        .map(|e| {
            let u = |i: usize| u32::from_le_bytes(e[4 * i..4 * i + 4].try_into().expect("4 bytes"));
            Listed {
                voxel: [u(0), u(1), u(2)],
                direct: u(3) != 0,
                w_cap: f64::from_le_bytes(e[16..24].try_into().expect("8 bytes")),
            }
        })
        .collect();
    // The order of the GPU's atomic appends never shows.
    listed.sort_unstable_by_key(|l| [l.voxel[2], l.voxel[1], l.voxel[0]]);
    let voxels: Vec<[u32; 3]> = listed
        .iter()
        .filter(|l| l.direct)
        .map(|l| l.voxel)
        .collect();
    stats.direct_voxels = voxels.len() as u64;
    check_budget(count, stats.direct_voxels, chunks, budget)?;
    let (crossing, crossing_inside) = resolve_crossings(grid, closed, &listed, &mut stats);
    stats.flipped = apply_direct(grid, &crossing, &crossing_inside);
    let n = voxels.len() as u64;
    if n == 0 {
        return Ok(Some(stats));
    }
    if n * chunks as u64 * 8 > max_range {
        // Within the budget but past one binding: the CPU's direct sum, the same chunks in the same order.
        let inside = direct_inside(mesh, &frame, &voxels);
        stats.flipped += apply_direct(grid, &voxels, &inside);
        return Ok(Some(stats));
    }
    let sorted: Vec<[u32; 4]> = voxels.iter().map(|v| [v[0], v[1], v[2], 0]).collect();
    let sorted_buf =
        ctx.upload_buffer("gwn direct voxels", bytemuck::cast_slice(&sorted), storage)?;
    let partial = ctx.create_buffer(
        "gwn partial sums",
        n * chunks as u64 * 8,
        storage | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )?;
    ctx.one_shot(|cmd| {
        passes.record_direct(
            ctx,
            cmd,
            &frame,
            &tris.vertices,
            &tris.indices,
            mesh.triangles.len() as u32,
            &sorted_buf,
            n as u32,
            &partial,
        )
    })?;
    let sums: Vec<f64> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&partial)?);
    let n = n as usize;
    let inside: Vec<bool> = (0..n)
        .map(|v| winding_from_chunks((0..chunks as usize).map(|c| sums[c * n + v])).abs() >= 0.5)
        .collect();
    stats.flipped += apply_direct(grid, &voxels, &inside);
    Ok(Some(stats))
}

fn read_u32(ctx: &Context, buf: &crate::gpu::Buffer) -> Result<u32> {
    let b = ctx.read_buffer_range(buf, 0, 4)?;
    Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}
