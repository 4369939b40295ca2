//! [`PeelVoxelizer`]: Harada–Koshizuka depth peeling, per axis: count pre-pass → L peeling passes → fill →
//! (with the host's triangles at hand) the check for columns that lost an equal-depth fragment, which the
//! CPU scanline recomputes, so peeling gives the CPU's grid even where triangles coincide. The check costs one
//! dispatch and a readback of a bit per column; the repair costs the scanline of the lost columns' rows, at
//! worst (every column lost: a mesh with every face duplicated) what `--method cpu` costs for the grid.
//!
//! Invariants: the two D32 depth images alternate between `DEPTH_ATTACHMENT_OPTIMAL` (current pass) and
//! `DEPTH_READ_ONLY_OPTIMAL` (read by the next pass); the "previous" image of pass 0 is cleared to 0.0 so one
//! pipeline serves every pass. The layer array is a color attachment during peeling and
//! `SHADER_READ_ONLY_OPTIMAL` for the fill.
use super::*;
use crate::gpu::resources::{image_barrier, memory_barrier};
use crate::gpu::{Image, ImageDesc, Owned};
use crate::passes::peel::PeelPass;
use crate::passes::peel_check::PeelCheckPass;
use crate::passes::voxel_fill::{FillJob, VoxelFillPass};
use crate::voxel::cpu::FillRule;

/// The depth-peeling voxelizer: its passes, built once and reused across grids.
pub struct PeelVoxelizer {
    pub(super) peel: PeelPass,
    pub(super) fill: VoxelFillPass,
    check: PeelCheckPass,
    /// Refuse meshes needing more peeling passes than this.
    pub max_layers: u32,
    /// Largest output slab in bytes (default and upper bound: `maxStorageBufferRange`); tests lower it to
    /// exercise the slab path.
    pub slab_limit: Option<u64>,
    /// Called once per finished stage (count, peel, fill) of each axis: three calls per axis.
    pub progress: Option<ProgressFn>,
    /// Checked after the count pass and after the fill (`Error::Timeout`).
    pub deadline: Option<Deadline>,
}

/// The images of `layers` peeling passes at width×height: two D32 depth images that alternate, the R32 layer array
/// and a view per layer (the one-shot and the resident voxelizer make them alike).
pub(super) struct PeelImages {
    pub(super) depth: Vec<Image>,
    pub(super) layers: Image,
    pub(super) layer_views: Vec<Owned<vk::ImageView>>,
}

impl PeelImages {
    pub(super) fn new(
        ctx: &Context,
        extent: vk::Extent2D,
        layers: u32,
        prefix: &str,
    ) -> Result<Self> {
        let depth_desc = ImageDesc::d2(
            extent.width,
            extent.height,
            vk::Format::D32_SFLOAT,
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
        );
        let depth = (0..2)
            .map(|i| ctx.create_image(&format!("{prefix} depth {i}"), &depth_desc))
            .collect::<Result<Vec<_>>>()?;
        let layer_desc = ImageDesc::d2_array(
            extent.width,
            extent.height,
            layers,
            vk::Format::R32_SFLOAT,
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
        );
        let layer_image = ctx.create_image(&format!("{prefix} layers"), &layer_desc)?;
        let layer_views = (0..layers)
            .map(|l| ctx.create_layer_view(&layer_image, l))
            .collect::<Result<Vec<_>>>()?;
        Ok(PeelImages {
            depth,
            layers: layer_image,
            layer_views,
        })
    }
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
        let check = PeelCheckPass::new(ctx)?;
        Ok(PeelVoxelizer {
            peel,
            fill,
            check,
            max_layers: DEFAULT_MAX_LAYERS,
            slab_limit: None,
            progress: None,
            deadline: None,
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
        check_framebuffer(ctx, frame, axis)?;
        let push = peel_push(frame, axis, geom.bounds);
        let r2 = frame.columns(axis);
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

    pub(super) fn record_count(
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
        check_framebuffer(ctx, frame, axis)?;
        self.run_axis(ctx, geom, frame, axis, rule, &mut profiler)
    }

    #[allow(clippy::too_many_arguments)]
    fn run_axis(
        &self,
        ctx: &Context,
        geom: &PeelGeometry,
        frame: &GridFrame,
        axis: Axis,
        rule: FillRule,
        profiler: &mut Option<&mut Profiler>,
    ) -> Result<(VoxelGrid, AxisStats)> {
        let push = peel_push(frame, axis, geom.bounds);
        let r2 = frame.columns(axis);

        // 1. Count pre-pass: the exact number of layers.
        let counts = ctx.create_buffer(
            "peel counts",
            (r2 + 1) * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        let counts = &counts;
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
        checkpoint(&self.deadline, &format!("{}: counted", axis.name()))?;
        let mut grid = VoxelGrid::empty(*frame, axis);
        if layers == 0 {
            return Ok((
                grid,
                AxisStats {
                    axis,
                    layers,
                    solid: 0,
                    repaired_columns: 0,
                },
            ));
        }
        // Name the limit that was hit: the user's --max-layers, or the device's.
        if layers > self.max_layers && self.max_layers <= ctx.limits.max_image_array_layers {
            return Err(Error::Invalid(format!(
                "{layers} depth layers along {} exceed --max-layers {} (raise it, up to the device's \
                 maxImageArrayLayers {}, or use --method cpu or abuffer)",
                axis.name(),
                self.max_layers,
                ctx.limits.max_image_array_layers
            )));
        }
        if layers > ctx.limits.max_image_array_layers {
            return Err(Error::Limit {
                what: format!("{layers} depth layers along {}", axis.name()),
                detail: format!(
                    "the device allows {} image layers (maxImageArrayLayers); use --method cpu or abuffer",
                    ctx.limits.max_image_array_layers
                ),
            });
        }

        // 2. Peel every layer.
        let images = PeelImages::new(ctx, push.framebuffer(), layers, "peel")?;
        let max_range =
            (ctx.limits.max_storage_buffer_range as u64).min(self.slab_limit.unwrap_or(u64::MAX));
        let depth = &images.depth;
        let views = &images.layer_views;
        let layer_image = &images.layers;
        fill_in_slabs(
            ctx,
            max_range,
            &mut grid,
            profiler,
            |cmd, out, first, count, profiler| {
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
                        columns: push.columns(),
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
            },
            || {
                tick(
                    &self.progress,
                    &format!("{}: peeled {layers} layers", axis.name()),
                )
            },
        )?;
        // 3. Columns that lost an equal-depth fragment, recomputed on the host when it has the triangles.
        let mut repaired_columns = 0;
        if let Some(mesh) = geom.mesh {
            let framebuffer = push.framebuffer();
            let lost = ctx.create_buffer(
                "peel lost columns",
                r2.div_ceil(32) * 4,
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )?;
            ctx.one_shot(|cmd| {
                self.check.record(
                    ctx,
                    cmd,
                    layer_image.view(),
                    self.peel.sampler(),
                    counts,
                    &lost,
                    framebuffer.width,
                    framebuffer.height,
                    layers,
                )
            })?;
            let bits = ctx.read_buffer(&lost)?;
            let columns: Vec<u32> = bits
                .chunks_exact(4)
                .enumerate()
                .flat_map(|(w, b)| {
                    let word = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                    (0..32)
                        .filter(move |k| word >> k & 1 == 1)
                        .map(move |k| w as u32 * 32 + k)
                })
                .collect();
            repaired_columns = columns.len() as u64;
            crate::voxel::cpu::refill_columns(mesh, &mut grid, rule, &columns);
        }
        tick(&self.progress, &format!("{}: filled", axis.name()));
        checkpoint(&self.deadline, &format!("{}: filled", axis.name()))?;
        let solid = grid.count();
        Ok((
            grid,
            AxisStats {
                axis,
                layers,
                solid,
                repaired_columns,
            },
        ))
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn record_peeling(
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
