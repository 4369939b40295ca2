//! GPU solid voxelization, one module per method, and what they share (the per-axis loop with the 2-of-3
//! vote, the slab-by-slab fill and readback, the mesh upload, progress):
//! - `peel`: [`PeelVoxelizer`] (Harada–Koshizuka depth peeling): count pre-pass → L peeling passes → fill;
//! - `abuffer`: [`AbufferVoxelizer`] (A-buffer): count pre-pass → prefix sum → one scatter pass → per-column
//!   sort and fill. Two geometry passes whatever L, and no equal-depth fragment is ever lost;
//! - `resident`: [`ResidentVoxelizer`] (the demo's live voxels) reads nothing back: its grid frame and peeling
//!   depth are fixed when it is built, its images and grid buffer live as long as it does, and `record` only
//!   records commands; the grid stays on the device for the next pass (ray casting);
//! - `gregory`: [`voxelize_gregory_surface`], a Gregory surface voxelized from its vertex buffer;
//! - [`voxelize_surface_gpu`]: the voxels the triangles touch (`--fill surface|both`), bit for bit the CPU's.
//!
//! Progress: the one-shot voxelizers report coarse stages (count, peel/scatter, fill) to an optional
//! [`ProgressFn`] the caller owns; the engine never draws on its own.
//!
//! Invariants:
//! - Every resource created here releases itself (`gpu::lifetime`), on success and on error.
//! - No storage binding exceeds `maxStorageBufferRange`: the output is filled and read back in slabs of
//!   columns (`fill_in_slabs`).
mod abuffer;
mod gregory;
mod peel;
mod resident;

pub use abuffer::AbufferVoxelizer;
pub use gregory::voxelize_gregory_surface;
pub use peel::PeelVoxelizer;
pub use resident::ResidentVoxelizer;

use crate::error::{Error, Result};
use crate::gpu::{Buffer, Context, MemoryLocation, Profiler};
use crate::passes::peel::{PeelGeometry, PeelPush};
use crate::passes::voxel_surface::{SurfaceTriangles, SurfaceWork, VoxelSurfacePass};
use crate::voxel::cpu::FillRule;
use crate::voxel::grid::{Axis, Bounds, GridFrame, VoxelGrid};
use crate::voxel::mesh::TriMesh;
use ash::vk;

/// Per-axis figures of a GPU voxelization.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AxisStats {
    pub axis: Axis,
    /// Peeling passes run (the deepest column's crossing count from the count pre-pass).
    pub layers: u32,
    pub solid: u64,
    /// Columns where depth peeling lost an equal-depth fragment and the CPU recomputed them (0 for the
    /// A-buffer, which keeps every fragment).
    pub repaired_columns: u64,
}

/// Upper bound on peeling passes unless the caller raises it.
pub const DEFAULT_MAX_LAYERS: u32 = 256;

/// A mesh uploaded for peeling (positions as 3×f32, u32 indices).
pub struct GpuTriangles {
    pub vertices: Buffer,
    pub indices: Buffer,
    pub index_count: u32,
    /// The box of every uploaded vertex (the depth range of the peel passes covers it).
    pub bounds: Option<Bounds>,
}

impl GpuTriangles {
    /// Uploads `mesh` to device-local buffers.
    pub fn upload(ctx: &Context, mesh: &TriMesh) -> Result<Self> {
        if mesh.triangles.is_empty() {
            return Err(Error::Invalid(
                "the mesh has no triangles to voxelize".into(),
            ));
        }
        let vertices = ctx.upload_buffer(
            "voxelize vertices",
            bytemuck::cast_slice(&mesh.positions),
            vk::BufferUsageFlags::VERTEX_BUFFER | vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let indices = ctx.upload_buffer(
            "voxelize indices",
            bytemuck::cast_slice(&mesh.triangles),
            vk::BufferUsageFlags::INDEX_BUFFER | vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        Ok(GpuTriangles {
            vertices,
            indices,
            index_count: mesh.triangles.len() as u32 * 3,
            bounds: Bounds::of_points(mesh.positions.iter().copied()).ok(),
        })
    }

    /// The geometry view the peel pass draws.
    pub fn geometry(&self) -> PeelGeometry<'_> {
        PeelGeometry {
            vertices: &self.vertices,
            indices: &self.indices,
            index_count: self.index_count,
            bounds: self.bounds,
            mesh: None,
        }
    }
}

/// A progress callback: called with a short description each time a stage of a voxelization finishes
/// (three stages per axis). The CLI draws a bar from it; a library user may log, or ignore it.
pub type ProgressFn = std::sync::Arc<dyn Fn(&str) + Send + Sync>;

/// A time limit on one voxelization, checked between its stages (a GPU submission, once made, runs to its
/// end: Vulkan cannot cancel one).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Deadline {
    pub at: std::time::Instant,
    /// The limit as given, for the message.
    pub seconds: f64,
}

impl Deadline {
    /// A limit of `seconds` from now.
    pub fn after(seconds: f64) -> Deadline {
        Deadline {
            at: std::time::Instant::now() + std::time::Duration::from_secs_f64(seconds.max(0.0)),
            seconds,
        }
    }
}

/// `Err(Error::Timeout)` once `deadline` has passed; `stage` says where it was found.
pub(crate) fn checkpoint(deadline: &Option<Deadline>, stage: &str) -> crate::error::Result<()> {
    match deadline {
        Some(d) if std::time::Instant::now() >= d.at => Err(crate::error::Error::Timeout {
            seconds: d.seconds,
            stage: stage.into(),
        }),
        _ => Ok(()),
    }
}

pub(crate) fn tick(progress: &Option<ProgressFn>, msg: &str) {
    if let Some(p) = progress {
        p(msg);
    }
}

/// Refuses axis lists other than 1 or 3 axes before any GPU work.
pub(crate) fn check_axes(axes: &[Axis]) -> Result<()> {
    match axes.len() {
        1 | 3 => Ok(()),
        n => Err(Error::Invalid(format!(
            "voxelize along 1 or 3 axes, not {n}"
        ))),
    }
}

/// One grid from the grids of 1 axis, or the 2-of-3 vote of 3.
pub(crate) fn vote(mut grids: Vec<VoxelGrid>) -> Result<VoxelGrid> {
    match grids.len() {
        1 => Ok(grids.pop().unwrap()),
        3 => Ok(VoxelGrid::majority([&grids[0], &grids[1], &grids[2]])),
        n => Err(Error::Invalid(format!(
            "voxelize along 1 or 3 axes, not {n}"
        ))),
    }
}

/// The peel push constants of `frame` along `axis`. The depth range is the grid's extent along the axis,
/// widened to `bounds` (a box around the geometry) where the geometry sticks out, so no crossing is clipped.
pub(crate) fn peel_push(frame: &GridFrame, axis: Axis, bounds: Option<Bounds>) -> PeelPush {
    let (ua, va) = axis.uv();
    let da = axis.index();
    let inv = frame.voxel_size.map(|h| 1.0 / h);
    let depth = frame.dims[da] as f64;
    let (mut lo, mut hi) = (0.0f64, depth);
    if let Some(b) = bounds {
        let g = |x: f64| (x - frame.origin[da]) * inv[da];
        lo = lo.min(g(b.min[da]).floor());
        hi = hi.max(g(b.max[da]).ceil());
    }
    PeelPush {
        origin_depth_lo: [
            frame.origin[0] as f32,
            frame.origin[1] as f32,
            frame.origin[2] as f32,
            lo as f32,
        ],
        inv_size_depth_span: [
            inv[0] as f32,
            inv[1] as f32,
            inv[2] as f32,
            (hi - lo) as f32,
        ],
        axes: [ua as u32, va as u32, da as u32, 0],
        extent: [frame.dims[ua], frame.dims[va], frame.dims[da], 0],
    }
}

/// Refuses a peel framebuffer past the device's image limit, before any GPU work.
pub(crate) fn check_framebuffer(ctx: &Context, frame: &GridFrame, axis: Axis) -> Result<()> {
    let (ua, va) = axis.uv();
    let max2d = ctx.limits.max_image_dimension2_d;
    let (w, h) = (frame.dims[ua], frame.dims[va]);
    if w > max2d || h > max2d {
        return Err(Error::Limit {
            what: format!(
                "a {w}×{h} peel framebuffer (voxelizing along {})",
                axis.name()
            ),
            detail: format!("maxImageDimension2D is {max2d}"),
        });
    }
    Ok(())
}

/// Bytes of device memory one axis of a voxelization needs at most: layers, two depth images, counts, one
/// output slab (the largest framebuffer over the three axes).
pub fn memory_estimate(ctx: &Context, frame: &GridFrame, layers: u32) -> u64 {
    Axis::ALL
        .iter()
        .map(|&a| {
            let cols = frame.columns(a);
            let out = VoxelGrid::bytes_for(frame, a);
            cols * 4 * layers as u64
                + 2 * cols * 4
                + (cols + 1) * 4
                + out.min(ctx.limits.max_storage_buffer_range as u64)
        })
        .max()
        .unwrap_or(0)
}

/// Runs `one` along each of `axes` (1 or 3, checked) and takes the 2-of-3 vote for three.
pub(crate) fn over_axes(
    axes: &[Axis],
    mut one: impl FnMut(Axis) -> Result<(VoxelGrid, AxisStats)>,
) -> Result<(VoxelGrid, Vec<AxisStats>)> {
    check_axes(axes)?;
    let mut grids = Vec::new();
    let mut stats = Vec::new();
    for &a in axes {
        let (g, s) = one(a)?;
        grids.push(g);
        stats.push(s);
    }
    Ok((vote(grids)?, stats))
}

/// Fills `grid` slab by slab, so no storage binding passes `max_range` bytes: one slab buffer; per slab one
/// one-shot submission in which `record(cmd, slab, first_column, column_count, profiler)` records the work
/// (the first slab also records the geometry passes), then the slab is read back into `grid`;
/// `after_first` runs once the first slab is done (a progress tick).
fn fill_in_slabs(
    ctx: &Context,
    max_range: u64,
    grid: &mut VoxelGrid,
    profiler: &mut Option<&mut Profiler>,
    mut record: impl FnMut(
        vk::CommandBuffer,
        &Buffer,
        u64,
        u64,
        &mut Option<&mut Profiler>,
    ) -> Result<()>,
    mut after_first: impl FnMut(),
) -> Result<()> {
    let (frame, axis) = (grid.frame, grid.bit_axis);
    let r2 = frame.columns(axis);
    let words = frame.words_per_column(axis) as u64;
    let slab_columns = (max_range / (words * 4)).min(r2).max(1);
    let slab = ctx.create_buffer(
        "voxel slab",
        slab_columns * words * 4,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )?;
    let mut first = 0u64;
    while first < r2 {
        let count = slab_columns.min(r2 - first);
        ctx.one_shot(|cmd| record(cmd, &slab, first, count, profiler))?;
        if let Some(p) = profiler.as_deref_mut() {
            p.collect(ctx, 0)?;
        }
        let bytes = ctx.read_buffer_range(&slab, 0, count * words * 4)?;
        let start = (first * words) as usize;
        grid.words[start..start + (count * words) as usize]
            .copy_from_slice(bytemuck::cast_slice(&bytes));
        if first == 0 {
            after_first();
        }
        first += count;
    }
    Ok(())
}

/// The work list of the GPU surface pass: per triangle with work, its walk axis (the largest component of its
/// normal in grid units, so the plane spans at most a few voxels along it over any column) and the box of
/// columns across that axis its extent touches. `None` when the invocations would pass u32.
pub fn surface_work(mesh: &TriMesh, frame: &GridFrame) -> Option<(Vec<SurfaceWork>, u32)> {
    let inv = frame.voxel_size.map(|h| 1.0 / h);
    let mut work = Vec::new();
    let mut first = 0u64;
    for (n, t) in mesh.triangles.iter().enumerate() {
        // The shader's grid_point, operation for operation.
        let g: [[f64; 3]; 3] = t.map(|v| {
            let p = mesh.positions[v as usize];
            std::array::from_fn(|a| (p[a] as f64 - frame.origin[a]) * inv[a])
        });
        let range = |a: usize| {
            let lo = g[0][a].min(g[1][a]).min(g[2][a]);
            let hi = g[0][a].max(g[1][a]).max(g[2][a]);
            let i0 = (lo - 1.0).ceil().max(0.0);
            let i1 = hi.floor().min(frame.dims[a] as f64 - 1.0);
            (i0 <= i1).then_some((i0 as u32, i1 as u32))
        };
        let e1: [f64; 3] = std::array::from_fn(|a| g[1][a] - g[0][a]);
        let e2: [f64; 3] = std::array::from_fn(|a| g[2][a] - g[0][a]);
        let normal = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let full = normal == [0.0; 3];
        // Ties go to the later axis (z first), deterministically.
        let d = if full {
            2
        } else {
            (0..3)
                .rev()
                .max_by(|&x, &y| normal[x].abs().total_cmp(&normal[y].abs()))
                .expect("three axes")
        };
        let (a, b) = Axis::from_index(d).uv();
        let (Some(ra), Some(rb), Some(_)) = (range(a), range(b), range(d)) else {
            continue;
        };
        let (na, nb) = (ra.1 - ra.0 + 1, rb.1 - rb.0 + 1);
        work.push(SurfaceWork {
            first: first as u32,
            tri: n as u32,
            axis: d as u32,
            a0: ra.0,
            b0: rb.0,
            na,
            full: full as u32,
            pad: 0,
        });
        first += na as u64 * nb as u64;
        if first > u32::MAX as u64 {
            return None;
        }
    }
    Some((work, first as u32))
}

/// The voxels of `frame` whose boxes the triangles of `mesh` (uploaded as `tris`) touch (bits along z), on
/// the GPU: the same bits as `voxel::surface::voxelize_surface` (see `passes::voxel_surface`), one slab of
/// rows at a time (slabs of at most `slab_limit` bytes, `maxStorageBufferRange` by default; tests lower it).
/// `None` when the work list is too long for one dispatch (the caller uses the CPU).
pub fn voxelize_surface_gpu(
    ctx: &Context,
    tris: &GpuTriangles,
    mesh: &TriMesh,
    frame: &GridFrame,
    slab_limit: Option<u64>,
) -> Result<Option<VoxelGrid>> {
    let Some((work, invocations)) = surface_work(mesh, frame) else {
        return Ok(None);
    };
    let mut grid = VoxelGrid::empty(*frame, Axis::Z);
    if work.is_empty() {
        return Ok(Some(grid));
    }
    let pass = VoxelSurfacePass::new(ctx)?;
    let work_buf = ctx.upload_buffer(
        "voxel surface work",
        bytemuck::cast_slice(&work),
        vk::BufferUsageFlags::STORAGE_BUFFER,
    )?;
    let row_words = frame.dims[0] as u64 * frame.words_per_column(Axis::Z) as u64;
    let max_range =
        (ctx.limits.max_storage_buffer_range as u64).min(slab_limit.unwrap_or(u64::MAX));
    let rows_per_slab = (max_range / (row_words * 4)).clamp(1, frame.dims[1] as u64) as u32;
    let slab = ctx.create_buffer(
        "voxel surface slab",
        rows_per_slab as u64 * row_words * 4,
        vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_SRC
            | vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuOnly,
    )?;
    let view = SurfaceTriangles {
        vertices: &tris.vertices,
        indices: &tris.indices,
        work: &work_buf,
        work_count: work.len() as u32,
        invocations,
    };
    let mut row0 = 0;
    while row0 < frame.dims[1] {
        let rows = rows_per_slab.min(frame.dims[1] - row0);
        ctx.one_shot(|cmd| pass.record(ctx, cmd, &view, frame, row0..row0 + rows, &slab))?;
        let bytes = ctx.read_buffer_range(&slab, 0, rows as u64 * row_words * 4)?;
        let start = (row0 as u64 * row_words) as usize;
        grid.words[start..start + bytes.len() / 4].copy_from_slice(bytemuck::cast_slice(&bytes));
        row0 += rows;
    }
    Ok(Some(grid))
}

/// A GPU voxelizer of either method, for callers that choose at run time.
pub enum GpuVoxelizer {
    Peel(Box<PeelVoxelizer>),
    Abuffer(Box<AbufferVoxelizer>),
}

impl GpuVoxelizer {
    /// The count pre-pass only: (deepest column's crossings, columns covered).
    pub fn count_layers(
        &self,
        ctx: &Context,
        geom: &PeelGeometry,
        frame: &GridFrame,
        axis: Axis,
    ) -> Result<(u32, u64)> {
        match self {
            GpuVoxelizer::Peel(v) => v.count_layers(ctx, geom, frame, axis),
            GpuVoxelizer::Abuffer(v) => v.count_layers(ctx, geom, frame, axis),
        }
    }

    /// Voxelizes along `axes` (1, or 3 with the vote).
    pub fn voxelize(
        &self,
        ctx: &Context,
        geom: &PeelGeometry,
        frame: &GridFrame,
        axes: &[Axis],
        rule: FillRule,
        profiler: Option<&mut Profiler>,
    ) -> Result<(VoxelGrid, Vec<AxisStats>)> {
        match self {
            GpuVoxelizer::Peel(v) => v.voxelize(ctx, geom, frame, axes, rule, profiler),
            GpuVoxelizer::Abuffer(v) => v.voxelize(ctx, geom, frame, axes, rule, profiler),
        }
    }
}
