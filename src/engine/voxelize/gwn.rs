//! [`resolve_gpu`]: the generalized winding number's cap term on the GPU (`passes::gwn`), over a grid that
//! holds the winding rule of the capped mesh M ∪ C: the same voxels and the same answers as
//! `voxel::gwn::resolve_cpu`.
//!
//! Invariants: three submissions, each waited for: the bricks pass (its count read back sizes the direct
//! list), the cap-term pass (the list read back, sorted, so the order of the GPU's atomic appends never
//! shows), the direct pass (chunk sums read back and added in chunk order on the CPU, as the CPU method
//! adds them). Every buffer releases itself on every path. `Ok(None)` means "not on this device" (no
//! shaderFloat64, a loop or a binding past the pass's limits): the caller runs the CPU stages instead.
use super::GpuTriangles;
use crate::error::Result;
use crate::gpu::{Context, MemoryLocation};
use crate::passes::gwn::{GwnPasses, MAX_LOOP};
use crate::voxel::grid::VoxelGrid;
use crate::voxel::gwn::{
    apply_direct, brick_dims, check_budget, direct_chunks, winding_from_chunks, Cap, CapTerm,
    GwnStats, BRICK,
};
use crate::voxel::mesh::TriMesh;
use ash::vk;

/// Stages 1–3 on the GPU over `grid` (the winding rule of M ∪ C). `tris` holds M ∪ C as uploaded (M's
/// positions and triangles first), `mesh` is M, `budget` bounds the direct voxels' bytes.
pub fn resolve_gpu(
    ctx: &Context,
    grid: &mut VoxelGrid,
    tris: &GpuTriangles,
    mesh: &TriMesh,
    cap: &Cap,
    budget: u64,
) -> Result<Option<GwnStats>> {
    let frame = grid.frame;
    let mut stats = GwnStats {
        loops_capped: cap.loops.len(),
        boundary_edges: cap.boundary_edges,
        ..GwnStats::default()
    };
    if cap.triangles.is_empty() {
        return Ok(Some(stats));
    }
    let term = CapTerm::new(cap, mesh, &frame);
    let bd = brick_dims(&frame);
    let total_bricks = bd.iter().map(|&b| b as u64).product::<u64>();
    let max_range = ctx.limits.max_storage_buffer_range as u64;
    if !ctx.info.features.shader_float64
        || term.triangles.len() > MAX_LOOP
        || term.balls.len() > MAX_LOOP
        || (total_bricks + 1) * 4 > max_range
    {
        return Ok(None);
    }
    let passes = GwnPasses::new(ctx)?;
    let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
    let balls = ctx.upload_buffer("gwn balls", bytemuck::cast_slice(&term.balls), storage)?;
    let cap_tris = ctx.upload_buffer(
        "gwn cap triangles",
        bytemuck::cast_slice(&term.triangles),
        storage,
    )?;
    let list_usage =
        storage | vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST;
    let bricks = ctx.create_buffer(
        "gwn bricks",
        (total_bricks + 1) * 4,
        list_usage,
        MemoryLocation::GpuOnly,
    )?;
    ctx.one_shot(|cmd| {
        passes.record_bricks(
            ctx,
            cmd,
            &frame,
            term.near,
            &balls,
            term.balls.len() as u32,
            &bricks,
        )
    })?;
    let brick_count = read_u32(ctx, &bricks)?;
    stats.bricks_evaluated = brick_count as u64;
    if brick_count == 0 {
        return Ok(Some(stats));
    }
    let listed: Vec<u32> =
        bytemuck::pod_collect_to_vec(&ctx.read_buffer_range(&bricks, 4, brick_count as u64 * 4)?);
    stats.cap_term_voxels = listed
        .iter()
        .map(|&b| {
            let c = [b % bd[0], (b / bd[0]) % bd[1], b / (bd[0] * bd[1])];
            (0..3)
                .map(|a| ((c[a] * BRICK + BRICK).min(frame.dims[a]) - c[a] * BRICK) as u64)
                .product::<u64>()
        })
        .sum();
    let chunks = direct_chunks(mesh.triangles.len());
    // Room for every voxel of the listed bricks, within the budget and one binding.
    let per_voxel = 16 + 8 * chunks as u64;
    let capacity = (brick_count as u64 * 512)
        .min(budget / per_voxel.max(1))
        .min((max_range - 16) / 16)
        .min(u32::MAX as u64) as u32;
    if brick_count as u64 * 512 > u32::MAX as u64 {
        return Ok(None);
    }
    let direct = ctx.create_buffer(
        "gwn direct",
        16 + capacity.max(1) as u64 * 16,
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
            term.triangles.len() as u32,
            &bricks,
            brick_count,
            &direct,
            capacity,
        )
    })?;
    let count = read_u32(ctx, &direct)? as u64;
    check_budget(count, chunks, budget)?;
    stats.direct_voxels = count;
    if count == 0 {
        return Ok(Some(stats));
    }
    if count > capacity as u64 || count * chunks as u64 * 8 > max_range {
        // Within the budget but past one binding: the CPU stages.
        return Ok(None);
    }
    let raw: Vec<[u32; 4]> =
        bytemuck::pod_collect_to_vec(&ctx.read_buffer_range(&direct, 16, count * 16)?);
    let mut voxels: Vec<[u32; 3]> = raw.iter().map(|v| [v[0], v[1], v[2]]).collect();
    voxels.sort_unstable_by_key(|v| [v[2], v[1], v[0]]);
    let sorted: Vec<[u32; 4]> = voxels.iter().map(|v| [v[0], v[1], v[2], 0]).collect();
    let sorted_buf =
        ctx.upload_buffer("gwn direct voxels", bytemuck::cast_slice(&sorted), storage)?;
    let partial = ctx.create_buffer(
        "gwn partial sums",
        count * chunks as u64 * 8,
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
            count as u32,
            &partial,
        )
    })?;
    let sums: Vec<f64> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&partial)?);
    let n = count as usize;
    let inside: Vec<bool> = (0..n)
        .map(|v| winding_from_chunks((0..chunks as usize).map(|c| sums[c * n + v])).abs() >= 0.5)
        .collect();
    stats.flipped = apply_direct(grid, &voxels, &inside);
    Ok(Some(stats))
}

fn read_u32(ctx: &Context, buf: &crate::gpu::Buffer) -> Result<u32> {
    let b = ctx.read_buffer_range(buf, 0, 4)?;
    Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}
