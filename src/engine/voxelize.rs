//! GPU solid voxelization, per axis, and the 2-of-3 vote over three axes for open meshes:
//! - [`PeelVoxelizer`] (Harada–Koshizuka depth peeling): count pre-pass → L peeling passes → fill;
//! - [`AbufferVoxelizer`] (§6 of the notes): count pre-pass → prefix sum → one scatter pass → per-column sort
//!   and fill. Two geometry passes whatever L, and no equal-depth fragment is ever lost.
//!
//! Progress: both report coarse stages (count, peel/scatter, fill) to an optional `indicatif` bar the caller
//! owns (hidden when stderr is not a terminal); the engine never draws on its own.
//!
//! Invariants:
//! - Every resource created here is destroyed before returning, on success and on error.
//! - Image layouts: the two D32 depth images alternate between `DEPTH_ATTACHMENT_OPTIMAL` (current pass) and
//!   `DEPTH_READ_ONLY_OPTIMAL` (read by the next pass); the "previous" image of pass 0 is cleared to 0.0 so one
//!   pipeline serves every pass. The layer array is a color attachment during peeling and
//!   `SHADER_READ_ONLY_OPTIMAL` for the fill.
//! - No storage binding exceeds `maxStorageBufferRange`: the output is filled and read back in slabs of
//!   columns.
//! - [`ResidentVoxelizer`] (the demo's live voxels) reads nothing back: its grid frame and peeling depth are
//!   fixed when it is built, its images and grid buffer live as long as it does, and `record` only records
//!   commands; the grid stays on the device for the next pass (ray casting).
use crate::error::{Error, Result};
use crate::gpu::resources::{image_barrier, memory_barrier};
use crate::gpu::Owned;
use crate::gpu::{Buffer, Context, Image, ImageDesc, MemoryLocation, Profiler};
use crate::passes::abuffer::{scan_words, AbufferFillJob, AbufferPass};
use crate::passes::peel::{PeelGeometry, PeelPass, PeelPush};
use crate::passes::voxel_fill::{FillJob, VoxelFillPass};
use crate::voxel::cpu::FillRule;
use crate::voxel::grid::{Axis, GridFrame, VoxelGrid};
use crate::voxel::mesh::TriMesh;
use ash::vk;

/// Per-axis figures of a GPU voxelization.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AxisStats {
    pub axis: Axis,
    /// Peeling passes run (the deepest column's crossing count from the count pre-pass).
    pub layers: u32,
    pub solid: u64,
}

/// Upper bound on peeling passes unless the caller raises it.
pub const DEFAULT_MAX_LAYERS: u32 = 256;

/// A mesh uploaded for peeling (positions as 3×f32, u32 indices).
pub struct GpuTriangles {
    pub vertices: Buffer,
    pub indices: Buffer,
    pub index_count: u32,
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
        })
    }

    /// The geometry view the peel pass draws.
    pub fn geometry(&self) -> PeelGeometry<'_> {
        PeelGeometry {
            vertices: &self.vertices,
            indices: &self.indices,
            index_count: self.index_count,
        }
    }
}

/// The depth-peeling voxelizer: its passes, built once and reused across grids.
pub struct PeelVoxelizer {
    peel: PeelPass,
    fill: VoxelFillPass,
    /// Refuse meshes needing more peeling passes than this.
    pub max_layers: u32,
    /// Largest output slab in bytes (default and upper bound: `maxStorageBufferRange`); tests lower it to
    /// exercise the slab path.
    pub slab_limit: Option<u64>,
    /// Called once per finished stage (count, peel, fill) of each axis: three calls per axis.
    pub progress: Option<ProgressFn>,
}

/// A progress callback: called with a short description each time a stage of a voxelization finishes
/// (three stages per axis). The CLI draws a bar from it; a library user may log, or ignore it.
pub type ProgressFn = std::sync::Arc<dyn Fn(&str) + Send + Sync>;

fn tick(progress: &Option<ProgressFn>, msg: &str) {
    if let Some(p) = progress {
        p(msg);
    }
}

/// Refuses axis lists other than 1 or 3 axes before any GPU work.
fn check_axes(axes: &[Axis]) -> Result<()> {
    match axes.len() {
        1 | 3 => Ok(()),
        n => Err(Error::Invalid(format!(
            "voxelize along 1 or 3 axes, not {n}"
        ))),
    }
}

/// One grid from the grids of 1 axis, or the 2-of-3 vote of 3.
fn vote(mut grids: Vec<VoxelGrid>) -> Result<VoxelGrid> {
    match grids.len() {
        1 => Ok(grids.pop().unwrap()),
        3 => Ok(VoxelGrid::majority([&grids[0], &grids[1], &grids[2]])),
        n => Err(Error::Invalid(format!(
            "voxelize along 1 or 3 axes, not {n}"
        ))),
    }
}

/// Resources of one axis run, destroyed together.
struct AxisResources {
    counts: Option<Buffer>,
    depth: Vec<Image>,
    layers: Option<Image>,
    layer_views: Vec<Owned<vk::ImageView>>,
    out: Option<Buffer>,
}

impl AxisResources {}

fn peel_push(frame: &GridFrame, axis: Axis) -> PeelPush {
    let (ua, va) = axis.uv();
    PeelPush {
        origin_inv_pitch: [
            frame.origin[0] as f32,
            frame.origin[1] as f32,
            frame.origin[2] as f32,
            (1.0 / frame.pitch()) as f32,
        ],
        axes_res: [ua as u32, va as u32, axis.index() as u32, frame.res],
    }
}

/// Bytes of device memory one axis of a voxelization needs at most: layers, two depth images, counts, one
/// output slab.
pub fn memory_estimate(ctx: &Context, res: u32, layers: u32) -> u64 {
    let r2 = res as u64 * res as u64;
    let out = VoxelGrid::bytes_for(&GridFrame {
        res,
        origin: [0.0; 3],
        side: 1.0,
    });
    r2 * 4 * layers as u64
        + 2 * r2 * 4
        + (r2 + 1) * 4
        + out.min(ctx.limits.max_storage_buffer_range as u64)
}

impl PeelVoxelizer {
    /// Builds the passes (vertices of `stride` bytes, positions first).
    pub fn new(ctx: &Context, stride: u32) -> Result<Self> {
        if !ctx.info.features.fragment_stores_and_atomics {
            return Err(Error::Limit {
                what: "depth-peeling voxelization".into(),
                detail:
                    "the device lacks fragmentStoresAndAtomics (needed by the layer-count pre-pass)"
                        .into(),
            });
        }
        let peel = PeelPass::new(ctx, stride)?;
        let fill = VoxelFillPass::new(ctx)?;
        Ok(PeelVoxelizer {
            peel,
            fill,
            max_layers: DEFAULT_MAX_LAYERS,
            slab_limit: None,
            progress: None,
        })
    }

    /// Runs only the count pre-pass along `axis`: (layers needed, columns covered).
    pub fn count_layers(
        &self,
        ctx: &Context,
        geom: &PeelGeometry,
        frame: &GridFrame,
        axis: Axis,
    ) -> Result<(u32, u64)> {
        let push = peel_push(frame, axis);
        let r2 = frame.res as u64 * frame.res as u64;
        let counts = ctx.create_buffer(
            "peel counts",
            (r2 + 1) * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let result = ctx
            .one_shot(|cmd| {
                self.record_count(ctx, cmd, geom, &push, &counts, &mut None);
                Ok(())
            })
            .and_then(|()| ctx.read_buffer(&counts));
        let words: Vec<u32> = result?
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        Ok((
            words[0],
            words[1..].iter().filter(|&&c| c > 0).count() as u64,
        ))
    }

    fn record_count(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        geom: &PeelGeometry,
        push: &PeelPush,
        counts: &Buffer,
        profiler: &mut Option<&mut Profiler>,
    ) {
        // SAFETY: recording; whole-buffer fill.
        unsafe {
            ctx.device
                .cmd_fill_buffer(cmd, counts.raw(), 0, vk::WHOLE_SIZE, 0)
        };
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::ALL_TRANSFER,
                vk::AccessFlags2::TRANSFER_WRITE,
            ),
            (
                vk::PipelineStageFlags2::FRAGMENT_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        );
        let s = profiler
            .as_deref_mut()
            .map(|p| p.begin(ctx, cmd, 0, "peel count pre-pass"));
        self.peel.record_count(ctx, cmd, geom, push, counts);
        if let (Some(p), Some(s)) = (profiler.as_deref_mut(), s) {
            p.end(ctx, cmd, s);
        }
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::FRAGMENT_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                vk::PipelineStageFlags2::ALL_TRANSFER,
                vk::AccessFlags2::TRANSFER_READ,
            ),
        );
    }

    /// Voxelizes `geom` in `frame` with columns along `axis`.
    pub fn voxelize_axis(
        &self,
        ctx: &Context,
        geom: &PeelGeometry,
        frame: &GridFrame,
        axis: Axis,
        rule: FillRule,
        mut profiler: Option<&mut Profiler>,
    ) -> Result<(VoxelGrid, AxisStats)> {
        let res = frame.res;
        let max2d = ctx.limits.max_image_dimension2_d;
        if res > max2d {
            return Err(Error::Limit {
                what: format!("resolution {res}"),
                detail: format!("the peel framebuffer is R×R and maxImageDimension2D is {max2d}"),
            });
        }
        let mut res_ = AxisResources {
            counts: None,
            depth: Vec::new(),
            layers: None,
            layer_views: Vec::new(),
            out: None,
        };
        let result = self.run_axis(ctx, geom, frame, axis, rule, &mut res_, &mut profiler);
        result
    }

    #[allow(clippy::too_many_arguments)]
    fn run_axis(
        &self,
        ctx: &Context,
        geom: &PeelGeometry,
        frame: &GridFrame,
        axis: Axis,
        rule: FillRule,
        r: &mut AxisResources,
        profiler: &mut Option<&mut Profiler>,
    ) -> Result<(VoxelGrid, AxisStats)> {
        let res = frame.res;
        let (ua, va) = axis.uv();
        let inv_pitch = (1.0 / frame.pitch()) as f32;
        let push = PeelPush {
            origin_inv_pitch: [
                frame.origin[0] as f32,
                frame.origin[1] as f32,
                frame.origin[2] as f32,
                inv_pitch,
            ],
            axes_res: [ua as u32, va as u32, axis.index() as u32, res],
        };
        let r2 = res as u64 * res as u64;

        // 1. Count pre-pass: the exact number of layers.
        let counts = ctx.create_buffer(
            "peel counts",
            (r2 + 1) * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let counts = r.counts.insert(counts);
        ctx.one_shot(|cmd| {
            self.record_count(ctx, cmd, geom, &push, counts, profiler);
            Ok(())
        })?;
        if let Some(p) = profiler.as_deref_mut() {
            p.collect(ctx, 0)?;
        }
        let max_bytes = ctx.read_buffer_range(counts, 0, 4)?;
        let layers = u32::from_le_bytes(max_bytes[..4].try_into().unwrap());
        tick(
            &self.progress,
            &format!("{}: counted {layers} layers", axis.name()),
        );
        let mut grid = VoxelGrid::empty(*frame, axis);
        if layers == 0 {
            return Ok((
                grid,
                AxisStats {
                    axis,
                    layers,
                    solid: 0,
                },
            ));
        }
        if layers > self.max_layers || layers > ctx.limits.max_image_array_layers {
            return Err(Error::Limit {
                what: format!("{layers} depth layers along {}", axis.name()),
                detail: format!(
                    "at most {} peeling passes are allowed (maxImageArrayLayers {})",
                    self.max_layers, ctx.limits.max_image_array_layers
                ),
            });
        }

        // 2. Peel every layer.
        for i in 0..2 {
            let d = ImageDesc::d2(
                res,
                res,
                vk::Format::D32_SFLOAT,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
            );
            r.depth
                .push(ctx.create_image(&format!("peel depth {i}"), &d)?);
        }
        let ldesc = ImageDesc::d2_array(
            res,
            res,
            layers,
            vk::Format::R32_SFLOAT,
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
        );
        let layer_image = r.layers.insert(ctx.create_image("peel layers", &ldesc)?);
        for l in 0..layers {
            r.layer_views.push(ctx.create_layer_view(layer_image, l)?);
        }
        let words = frame.words_per_column() as u64;
        let max_range =
            (ctx.limits.max_storage_buffer_range as u64).min(self.slab_limit.unwrap_or(u64::MAX));
        let slab_columns = (max_range / (words * 4)).min(r2).max(1);
        let slab_bytes = slab_columns * words * 4;
        let out = r.out.insert(ctx.create_buffer(
            "voxel slab",
            slab_bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?);
        let depth = &r.depth;
        let views = &r.layer_views;
        let mut first = 0u64;
        while first < r2 {
            let count = slab_columns.min(r2 - first);
            ctx.one_shot(|cmd| {
                if first == 0 {
                    self.record_peeling(
                        ctx,
                        cmd,
                        geom,
                        &push,
                        depth,
                        layer_image,
                        views,
                        layers,
                        profiler,
                    )?;
                }
                let s = profiler
                    .as_deref_mut()
                    .map(|p| p.begin(ctx, cmd, 0, "voxel fill"));
                self.fill.record(
                    ctx,
                    cmd,
                    layer_image.view(),
                    self.peel.sampler(),
                    out,
                    &FillJob {
                        res,
                        layer_count: layers,
                        rule,
                        first_column: first as u32,
                        column_count: count as u32,
                    },
                )?;
                if let (Some(p), Some(s)) = (profiler.as_deref_mut(), s) {
                    p.end(ctx, cmd, s);
                }
                Ok(())
            })?;
            if let Some(p) = profiler.as_deref_mut() {
                p.collect(ctx, 0)?;
            }
            let bytes = ctx.read_buffer_range(out, 0, count * words * 4)?;
            let start = (first * words) as usize;
            grid.words[start..start + (count * words) as usize]
                .copy_from_slice(bytemuck::cast_slice(&bytes));
            if first == 0 {
                tick(
                    &self.progress,
                    &format!("{}: peeled {layers} layers", axis.name()),
                );
            }
            first += count;
        }
        tick(&self.progress, &format!("{}: filled", axis.name()));
        let solid = grid.count();
        Ok((
            grid,
            AxisStats {
                axis,
                layers,
                solid,
            },
        ))
    }

    #[allow(clippy::too_many_arguments)]
    fn record_peeling(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        geom: &PeelGeometry,
        push: &PeelPush,
        depth: &[Image],
        layer_image: &Image,
        views: &[Owned<vk::ImageView>],
        layers: u32,
        profiler: &mut Option<&mut Profiler>,
    ) -> Result<()> {
        let depth_range = depth[0].range();
        let frag_read = (
            vk::PipelineStageFlags2::FRAGMENT_SHADER,
            vk::AccessFlags2::SHADER_SAMPLED_READ,
        );
        let depth_write = (
            vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
                | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
            vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ
                | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
        );
        // depth[1] plays "previous" for pass 0: cleared to 0.0 so every fragment is behind it.
        for (i, img) in depth.iter().enumerate() {
            image_barrier(
                ctx,
                cmd,
                img.raw(),
                depth_range,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                // ALL_COMMANDS, not NONE: a resident voxelizer peels into the same images every frame,
                // so the transition must wait for the previous frame's peel and fill.
                (
                    vk::PipelineStageFlags2::ALL_COMMANDS,
                    vk::AccessFlags2::NONE,
                ),
                depth_write,
            );
            if i == 1 {
                let att = vk::RenderingAttachmentInfo::default()
                    .image_view(img.view())
                    .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                    .load_op(vk::AttachmentLoadOp::CLEAR)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .clear_value(vk::ClearValue {
                        depth_stencil: vk::ClearDepthStencilValue {
                            depth: 0.0,
                            stencil: 0,
                        },
                    });
                let extent = img.extent2d();
                let info = vk::RenderingInfo::default()
                    .render_area(vk::Rect2D {
                        offset: vk::Offset2D::default(),
                        extent,
                    })
                    .layer_count(1)
                    .depth_attachment(&att);
                ctx.cmd_begin_rendering(cmd, &info);
                ctx.cmd_end_rendering(cmd);
                image_barrier(
                    ctx,
                    cmd,
                    img.raw(),
                    depth_range,
                    vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                    vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL,
                    depth_write,
                    frag_read,
                );
            }
        }
        image_barrier(
            ctx,
            cmd,
            layer_image.raw(),
            layer_image.range(),
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
            (
                vk::PipelineStageFlags2::ALL_COMMANDS,
                vk::AccessFlags2::NONE,
            ),
            (
                vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
            ),
        );
        for l in 0..layers as usize {
            let (cur, prev) = (&depth[l % 2], &depth[(l + 1) % 2]);
            if l > 0 {
                // The previous pass's target becomes this pass's "previous"; this pass's target was read by the
                // previous pass and is now overwritten.
                image_barrier(
                    ctx,
                    cmd,
                    prev.raw(),
                    depth_range,
                    vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                    vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL,
                    depth_write,
                    frag_read,
                );
                image_barrier(
                    ctx,
                    cmd,
                    cur.raw(),
                    depth_range,
                    vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL,
                    vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                    frag_read,
                    depth_write,
                );
            }
            let s = profiler
                .as_deref_mut()
                .map(|p| p.begin(ctx, cmd, 0, "peel layer"));
            self.peel
                .record_layer(ctx, cmd, geom, push, prev, cur, views[l].raw());
            if let (Some(p), Some(s)) = (profiler.as_deref_mut(), s) {
                p.end(ctx, cmd, s);
            }
        }
        image_barrier(
            ctx,
            cmd,
            layer_image.raw(),
            layer_image.range(),
            vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            (
                vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_SAMPLED_READ,
            ),
        );
        Ok(())
    }

    /// Voxelizes along each of `axes` and, for three axes, takes the 2-of-3 vote.
    pub fn voxelize(
        &self,
        ctx: &Context,
        geom: &PeelGeometry,
        frame: &GridFrame,
        axes: &[Axis],
        rule: FillRule,
        mut profiler: Option<&mut Profiler>,
    ) -> Result<(VoxelGrid, Vec<AxisStats>)> {
        over_axes(axes, |a| {
            self.voxelize_axis(ctx, geom, frame, a, rule, profiler.as_deref_mut())
        })
    }
}

/// Runs `one` along each of `axes` (1 or 3, checked) and takes the 2-of-3 vote for three.
fn over_axes(
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

/// Buffers of one A-buffer axis run, destroyed together.
#[derive(Default)]
struct AbufferResources {
    counts: Option<Buffer>,
    scan: Option<Buffer>,
    cursor: Option<Buffer>,
    frags: Option<Buffer>,
    out: Option<Buffer>,
}

impl AbufferResources {}

/// The A-buffer voxelizer (`--method abuffer`): the peel pass's count pre-pass, a prefix sum, one scatter
/// pass and a per-column sort + fill. Device memory per axis: 4·(2R² + Φ) bytes + one output slab, with Φ the
/// fragment count (≈ 1.24·R² on the stanford bunny).
pub struct AbufferVoxelizer {
    counter: PeelVoxelizer,
    pass: AbufferPass,
    /// Largest output slab in bytes (as [`PeelVoxelizer::slab_limit`]).
    pub slab_limit: Option<u64>,
    /// Advanced by one per stage (count, scatter, fill) of each axis.
    /// Called once per finished stage (count, scatter, fill) of each axis: three calls per axis.
    pub progress: Option<ProgressFn>,
}

impl AbufferVoxelizer {
    /// Builds the passes (vertices of `stride` bytes, positions first).
    pub fn new(ctx: &Context, stride: u32) -> Result<Self> {
        let counter = PeelVoxelizer::new(ctx, stride)?;
        let pass = AbufferPass::new(ctx, stride)?;
        Ok(AbufferVoxelizer {
            counter,
            pass,
            slab_limit: None,
            progress: None,
        })
    }

    /// The count pre-pass only: (deepest column's crossings, columns covered).
    pub fn count_layers(
        &self,
        ctx: &Context,
        geom: &PeelGeometry,
        frame: &GridFrame,
        axis: Axis,
    ) -> Result<(u32, u64)> {
        self.counter.count_layers(ctx, geom, frame, axis)
    }

    /// Voxelizes `geom` in `frame` with columns along `axis`; `AxisStats::layers` is the deepest column's
    /// fragment count.
    pub fn voxelize_axis(
        &self,
        ctx: &Context,
        geom: &PeelGeometry,
        frame: &GridFrame,
        axis: Axis,
        rule: FillRule,
        mut profiler: Option<&mut Profiler>,
    ) -> Result<(VoxelGrid, AxisStats)> {
        let max2d = ctx.limits.max_image_dimension2_d;
        if frame.res > max2d {
            return Err(Error::Limit {
                what: format!("resolution {}", frame.res),
                detail: format!(
                    "the scatter framebuffer is R×R and maxImageDimension2D is {max2d}"
                ),
            });
        }
        let mut r = AbufferResources::default();
        let result = self.run_axis(ctx, geom, frame, axis, rule, &mut r, &mut profiler);
        result
    }

    #[allow(clippy::too_many_arguments)]
    fn run_axis(
        &self,
        ctx: &Context,
        geom: &PeelGeometry,
        frame: &GridFrame,
        axis: Axis,
        rule: FillRule,
        r: &mut AbufferResources,
        profiler: &mut Option<&mut Profiler>,
    ) -> Result<(VoxelGrid, AxisStats)> {
        let res = frame.res;
        let push = peel_push(frame, axis);
        let r2 = res as u64 * res as u64;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC;
        // 1. Count pre-pass, then the prefix sum of the R² counts plus one trailing zero: slot R² = Φ.
        let counts = &*r.counts.insert(ctx.create_buffer(
            "abuffer counts",
            (r2 + 1) * 4,
            storage,
            MemoryLocation::GpuOnly,
        )?);
        let scan = &*r.scan.insert(ctx.create_buffer(
            "abuffer scan",
            scan_words(r2 + 1) * 4,
            storage,
            MemoryLocation::GpuOnly,
        )?);
        ctx.one_shot(|cmd| {
            self.counter
                .record_count(ctx, cmd, geom, &push, counts, profiler);
            let s = profiler
                .as_deref_mut()
                .map(|p| p.begin(ctx, cmd, 0, "abuffer prefix sum"));
            // SAFETY: recording; regions inside both buffers (counts word 1.. = the R² counters).
            unsafe {
                ctx.device.cmd_copy_buffer(
                    cmd,
                    counts.raw(),
                    scan.raw(),
                    &[vk::BufferCopy {
                        src_offset: 4,
                        dst_offset: 0,
                        size: r2 * 4,
                    }],
                );
                ctx.device.cmd_fill_buffer(cmd, scan.raw(), r2 * 4, 4, 0);
            }
            memory_barrier(
                ctx,
                cmd,
                (
                    vk::PipelineStageFlags2::ALL_TRANSFER,
                    vk::AccessFlags2::TRANSFER_WRITE,
                ),
                (
                    vk::PipelineStageFlags2::COMPUTE_SHADER,
                    vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
                ),
            );
            self.pass.record_scan(ctx, cmd, scan, r2 + 1)?;
            if let (Some(p), Some(s)) = (profiler.as_deref_mut(), s) {
                p.end(ctx, cmd, s);
            }
            Ok(())
        })?;
        if let Some(p) = profiler.as_deref_mut() {
            p.collect(ctx, 0)?;
        }
        let word = |b: Vec<u8>| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        let layers = word(ctx.read_buffer_range(counts, 0, 4)?);
        let total = word(ctx.read_buffer_range(scan, r2 * 4, 4)?) as u64;
        tick(
            &self.progress,
            &format!(
                "{}: {total} fragments, at most {layers} per column",
                axis.name()
            ),
        );
        let mut grid = VoxelGrid::empty(*frame, axis);
        if total == 0 {
            return Ok((
                grid,
                AxisStats {
                    axis,
                    layers,
                    solid: 0,
                },
            ));
        }
        let max_range = ctx.limits.max_storage_buffer_range as u64;
        if total * 4 > max_range {
            return Err(Error::Limit {
                what: format!("{total} fragments along {}", axis.name()),
                detail: format!(
                    "the A-buffer needs {} bytes in one binding; maxStorageBufferRange is {max_range}",
                    total * 4
                ),
            });
        }
        // 2. Scatter, then sort + fill slab by slab.
        let cursor = &*r.cursor.insert(ctx.create_buffer(
            "abuffer cursor",
            r2 * 4,
            storage,
            MemoryLocation::GpuOnly,
        )?);
        let frags = &*r.frags.insert(ctx.create_buffer(
            "abuffer fragments",
            total * 4,
            storage,
            MemoryLocation::GpuOnly,
        )?);
        let words = frame.words_per_column() as u64;
        let max_range = max_range.min(self.slab_limit.unwrap_or(u64::MAX));
        let slab_columns = (max_range / (words * 4)).min(r2).max(1);
        let out = &*r.out.insert(ctx.create_buffer(
            "voxel slab",
            slab_columns * words * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?);
        let mut first = 0u64;
        while first < r2 {
            let count = slab_columns.min(r2 - first);
            ctx.one_shot(|cmd| {
                if first == 0 {
                    // SAFETY: recording; whole-buffer fill.
                    unsafe {
                        ctx.device
                            .cmd_fill_buffer(cmd, cursor.raw(), 0, vk::WHOLE_SIZE, 0)
                    };
                    memory_barrier(
                        ctx,
                        cmd,
                        (
                            vk::PipelineStageFlags2::ALL_TRANSFER,
                            vk::AccessFlags2::TRANSFER_WRITE,
                        ),
                        (
                            vk::PipelineStageFlags2::FRAGMENT_SHADER,
                            vk::AccessFlags2::SHADER_STORAGE_READ
                                | vk::AccessFlags2::SHADER_STORAGE_WRITE,
                        ),
                    );
                    let s = profiler
                        .as_deref_mut()
                        .map(|p| p.begin(ctx, cmd, 0, "abuffer scatter"));
                    self.pass
                        .record_scatter(ctx, cmd, geom, &push, scan, cursor, frags);
                    if let (Some(p), Some(s)) = (profiler.as_deref_mut(), s) {
                        p.end(ctx, cmd, s);
                    }
                }
                let s = profiler
                    .as_deref_mut()
                    .map(|p| p.begin(ctx, cmd, 0, "abuffer sort + fill"));
                self.pass.record_fill(
                    ctx,
                    cmd,
                    scan,
                    frags,
                    out,
                    &AbufferFillJob {
                        res,
                        rule,
                        first_column: first as u32,
                        column_count: count as u32,
                    },
                )?;
                if let (Some(p), Some(s)) = (profiler.as_deref_mut(), s) {
                    p.end(ctx, cmd, s);
                }
                Ok(())
            })?;
            if let Some(p) = profiler.as_deref_mut() {
                p.collect(ctx, 0)?;
            }
            let bytes = ctx.read_buffer_range(out, 0, count * words * 4)?;
            let start = (first * words) as usize;
            grid.words[start..start + (count * words) as usize]
                .copy_from_slice(bytemuck::cast_slice(&bytes));
            if first == 0 {
                tick(&self.progress, &format!("{}: scattered", axis.name()));
            }
            first += count;
        }
        tick(&self.progress, &format!("{}: filled", axis.name()));
        let solid = grid.count();
        Ok((
            grid,
            AxisStats {
                axis,
                layers,
                solid,
            },
        ))
    }

    /// Voxelizes along each of `axes` and, for three axes, takes the 2-of-3 vote.
    pub fn voxelize(
        &self,
        ctx: &Context,
        geom: &PeelGeometry,
        frame: &GridFrame,
        axes: &[Axis],
        rule: FillRule,
        mut profiler: Option<&mut Profiler>,
    ) -> Result<(VoxelGrid, Vec<AxisStats>)> {
        over_axes(axes, |a| {
            self.voxelize_axis(ctx, geom, frame, a, rule, profiler.as_deref_mut())
        })
    }
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

/// Voxelizes a Gregory surface straight from its device-local vertex buffer: the grid frame comes from a GPU
/// bounds reduction (six numbers read back), and the peel pass draws the evaluation pass's vertex and index
/// buffers as they are. The surface must have been recorded (evaluated) before.
pub fn voxelize_gregory_surface(
    ctx: &Context,
    surface: &crate::engine::gregory::GregorySurface,
    res: u32,
    axes: &[Axis],
    rule: FillRule,
    max_layers: u32,
    profiler: Option<&mut Profiler>,
) -> Result<(VoxelGrid, Vec<AxisStats>)> {
    use crate::passes::bounds::{decode, BoundsPass};
    use crate::passes::gregory_eval::vertex_count;
    let count = vertex_count(surface.patch_count(), surface.level()) as u32;
    let bounds = BoundsPass::new(ctx)?;
    let buf = ctx.create_buffer(
        "surface bounds",
        24,
        vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )?;
    let words = ctx
        .one_shot(|cmd| bounds.record(ctx, cmd, surface.vertices(), count, 32, &buf))
        .and_then(|()| ctx.read_pod::<u32>(&buf));
    let w = words?;
    let lo = [decode(w[0]), decode(w[1]), decode(w[2])];
    let hi = [decode(w[3]), decode(w[4]), decode(w[5])];
    let frame = GridFrame::from_points(&[lo, hi], res)?;
    let mut v = PeelVoxelizer::new(ctx, 32)?;
    v.max_layers = max_layers;
    let geom = PeelGeometry {
        vertices: surface.vertices(),
        indices: surface.indices(),
        index_count: surface.index_count(),
    };
    let r = v.voxelize(ctx, &geom, &frame, axes, rule, profiler);
    r
}

/// A depth-peeling voxelizer whose output never leaves the GPU: built once for a fixed grid frame, peel axis z
/// and a fixed number of peeling passes, it records peel + fill into the caller's command buffer (every
/// frame, say) and leaves the bit grid (bit axis z) in a device-local buffer.
///
/// Why a fixed layer count: the one-shot voxelizers read the deepest column's crossing count back before
/// peeling; a per-frame path cannot wait for that. Layers past a column's last crossing are cleared to 0 and
/// the fill stops at the first 0, so peeling more layers than needed gives the same grid bit for bit; peeling
/// fewer would drop crossings, so the caller chooses `layers` from counts measured up front
/// ([`PeelVoxelizer::count_layers`]).
pub struct ResidentVoxelizer {
    peel: PeelVoxelizer,
    pub frame: GridFrame,
    pub layers: u32,
    pub rule: FillRule,
    depth: Vec<Image>,
    layer_image: Image,
    layer_views: Vec<Owned<vk::ImageView>>,
    grid: Buffer,
}

impl ResidentVoxelizer {
    /// Builds the passes (vertices of `stride` bytes, positions first) and the resources for `frame`.
    pub fn new(
        ctx: &Context,
        stride: u32,
        frame: GridFrame,
        layers: u32,
        rule: FillRule,
    ) -> Result<Self> {
        let res = frame.res;
        let max2d = ctx.limits.max_image_dimension2_d;
        if res == 0 || res > max2d {
            return Err(Error::Limit {
                what: format!("resolution {res}"),
                detail: format!("the peel framebuffer is R×R and maxImageDimension2D is {max2d}"),
            });
        }
        let bytes = VoxelGrid::bytes_for(&frame);
        if bytes > ctx.limits.max_storage_buffer_range as u64 {
            return Err(Error::Limit {
                what: format!("a resident {res}³ grid ({bytes} bytes)"),
                detail: format!(
                    "one storage binding holds at most {} bytes",
                    ctx.limits.max_storage_buffer_range
                ),
            });
        }
        if layers == 0 || layers > ctx.limits.max_image_array_layers {
            return Err(Error::Limit {
                what: format!("{layers} peeling passes"),
                detail: format!(
                    "between 1 and maxImageArrayLayers ({})",
                    ctx.limits.max_image_array_layers
                ),
            });
        }
        let peel = PeelVoxelizer::new(ctx, stride)?;
        let mut r = AxisResources {
            counts: None,
            depth: Vec::new(),
            layers: None,
            layer_views: Vec::new(),
            out: None,
        };
        match Self::create(ctx, &frame, layers, &mut r) {
            Ok(()) => Ok(ResidentVoxelizer {
                peel,
                frame,
                layers,
                rule,
                depth: std::mem::take(&mut r.depth),
                layer_image: r.layers.take().unwrap(),
                layer_views: std::mem::take(&mut r.layer_views),
                grid: r.out.take().unwrap(),
            }),
            Err(e) => Err(e),
        }
    }

    fn create(ctx: &Context, frame: &GridFrame, layers: u32, r: &mut AxisResources) -> Result<()> {
        let res = frame.res;
        for i in 0..2 {
            let d = ImageDesc::d2(
                res,
                res,
                vk::Format::D32_SFLOAT,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
            );
            r.depth
                .push(ctx.create_image(&format!("resident peel depth {i}"), &d)?);
        }
        let ldesc = ImageDesc::d2_array(
            res,
            res,
            layers,
            vk::Format::R32_SFLOAT,
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
        );
        let layer_image = r
            .layers
            .insert(ctx.create_image("resident peel layers", &ldesc)?);
        for l in 0..layers {
            r.layer_views.push(ctx.create_layer_view(layer_image, l)?);
        }
        r.out = Some(ctx.create_buffer(
            "resident voxel grid",
            VoxelGrid::bytes_for(frame),
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?);
        Ok(())
    }

    /// The device-local bit grid (bit axis z, `VoxelGrid` layout).
    pub fn grid(&self) -> &Buffer {
        &self.grid
    }

    /// Records the voxelization of `geom`: every earlier command has finished with the images and the grid
    /// before they are rewritten, and on exit the grid is visible to compute shaders and transfers.
    pub fn record(&self, ctx: &Context, cmd: vk::CommandBuffer, geom: &PeelGeometry) -> Result<()> {
        let push = peel_push(&self.frame, Axis::Z);
        self.peel.record_peeling(
            ctx,
            cmd,
            geom,
            &push,
            &self.depth,
            &self.layer_image,
            &self.layer_views,
            self.layers,
            &mut None,
        )?;
        // Earlier readers of the grid (last frame's ray cast, copies) before the fill overwrites it.
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::ALL_TRANSFER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        );
        let res = self.frame.res;
        self.peel.fill.record(
            ctx,
            cmd,
            self.layer_image.view(),
            self.peel.peel.sampler(),
            &self.grid,
            &FillJob {
                res,
                layer_count: self.layers,
                rule: self.rule,
                first_column: 0,
                column_count: res * res,
            },
        )?;
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::ALL_TRANSFER,
                vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::SHADER_STORAGE_WRITE
                    | vk::AccessFlags2::TRANSFER_READ,
            ),
        );
        Ok(())
    }

    /// Reads the grid back (tests; the demo never does).
    pub fn read_grid(&self, ctx: &Context) -> Result<VoxelGrid> {
        let words = ctx.read_pod::<u32>(&self.grid)?;
        let mut g = VoxelGrid::empty(self.frame, Axis::Z);
        g.words.copy_from_slice(&words);
        Ok(g)
    }
}
