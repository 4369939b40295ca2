//! [`AbufferVoxelizer`]: the peel pass's count pre-pass, a prefix sum, one scatter pass and a per-column
//! sort + fill, per axis. Two geometry passes whatever the depth complexity; no equal-depth fragment is lost.
use super::*;
use crate::gpu::resources::memory_barrier;
use crate::passes::abuffer::{scan_words, AbufferFillJob, AbufferPass};
use crate::voxel::cpu::FillRule;

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
    /// Checked after the count pass and after the fill (`Error::Timeout`).
    pub deadline: Option<Deadline>,
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
            deadline: None,
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
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC;
        // 1. Count pre-pass, then the prefix sum of the column counts plus one trailing zero: the last slot = Φ.
        let counts = &ctx.create_buffer(
            "abuffer counts",
            (r2 + 1) * 4,
            storage,
            MemoryLocation::GpuOnly,
        )?;
        let scan = &ctx.create_buffer(
            "abuffer scan",
            scan_words(r2 + 1) * 4,
            storage,
            MemoryLocation::GpuOnly,
        )?;
        ctx.one_shot(|cmd| {
            self.counter
                .record_count(ctx, cmd, geom, &push, counts, profiler);
            let s = profiler
                .as_deref_mut()
                .map(|p| p.begin(ctx, cmd, 0, "abuffer prefix sum"));
            // SAFETY: recording; regions inside both buffers (counts word 1.. = the column counters).
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
        checkpoint(&self.deadline, &format!("{}: counted", axis.name()))?;
        let mut grid = VoxelGrid::empty(*frame, axis);
        if total == 0 {
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
        let cursor =
            &ctx.create_buffer("abuffer cursor", r2 * 4, storage, MemoryLocation::GpuOnly)?;
        let frags = &ctx.create_buffer(
            "abuffer fragments",
            total * 4,
            storage,
            MemoryLocation::GpuOnly,
        )?;
        let max_range = max_range.min(self.slab_limit.unwrap_or(u64::MAX));
        fill_in_slabs(
            ctx,
            max_range,
            &mut grid,
            profiler,
            |cmd, out, first, count, profiler| {
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
                        columns: push.columns(),
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
            || tick(&self.progress, &format!("{}: scattered", axis.name())),
        )?;
        tick(&self.progress, &format!("{}: filled", axis.name()));
        checkpoint(&self.deadline, &format!("{}: filled", axis.name()))?;
        let solid = grid.count();
        Ok((
            grid,
            AxisStats {
                axis,
                layers,
                solid,
                repaired_columns: 0,
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
