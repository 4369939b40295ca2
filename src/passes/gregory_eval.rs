//! `GregoryEvalPass`: evaluates every Gregory patch on its (L+1)² grid into a device-local vertex buffer
//! (glsl/gregory_eval.comp, glsl/include/gregory.glsl).
//!
//! Invariants: the pass owns only its pipeline. Inputs are the caller's: `points` (vec4 control points, e.g.
//! written by [`crate::passes::spmv::SpmvPass`]), `patch_points` (20 u32 point indices per patch, GREGORY_BASIS
//! order; optionally with residuals, [`ControlPoints`]) and `patch_flags` (bit e: edge e runs against its canonical direction). The output buffer holds
//! [`SurfaceVertex`] values (stride 32) and must have STORAGE and VERTEX usage; on exit its writes are visible
//! to vertex input, vertex-shader storage reads, later compute passes and transfers. The adaptive variant
//! (same kernel compiled with GREGORY_ADAPTIVE) also reads per-patch and per-edge levels and writes each
//! patch's own grid at the start of its fixed slot; vertices past a patch's grid in its slot are not written.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::{compute_writes_to_readers, storage_chunks, BufferRange};
use crate::gpu::{shaders, Buffer, Context};
use ash::vk;

/// One output vertex: position (w = 1) and unit normal (w = 0).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SurfaceVertex {
    pub position: [f32; 4],
    pub normal: [f32; 4],
}

impl SurfaceVertex {
    /// The position's x, y, z.
    pub fn xyz(&self) -> [f32; 3] {
        [self.position[0], self.position[1], self.position[2]]
    }

    /// The position's x and y: the UV of a UV surface's vertex (its points are (u, v, 0)).
    pub fn uv(&self) -> [f32; 2] {
        [self.position[0], self.position[1]]
    }

    /// The normal's x, y, z.
    pub fn normal_xyz(&self) -> [f32; 3] {
        [self.normal[0], self.normal[1], self.normal[2]]
    }

    /// The position's bits, -0.0 read as 0.0 (adding 0.0 maps -0.0 to 0.0 and leaves every other value):
    /// equal keys are the same point, as shared patch edges are.
    pub fn position_key(&self) -> [u32; 3] {
        self.xyz().map(|x| (x + 0.0).to_bits())
    }
}

/// Invocations per workgroup (one workgroup per patch; glsl/include/gregory_eval_body.glsl). Each invocation
/// pays a per-patch set-up that llvmpipe makes expensive (measured ~1.5 µs: at L = 4 letting the 39 idle
/// invocations of 64 stop early halved the pass), so fewer invocations each evaluate more vertices: 8 is one
/// llvmpipe subgroup (spot at L = 32: 37.5 M vertices/s, against 22.9 with 16 and 13.6 with 64). Tuned for
/// lavapipe; a GPU with wide subgroups wants 32–64.
pub const GROUP_SIZE: u32 = 8;

/// Highest uniform tessellation level.
pub const MAX_LEVEL: u32 = 64;

/// Push constants of both variants (`Push` in glsl/include/gregory_eval_body.glsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    /// Patches in this dispatch.
    patch_count: u32,
    /// L (uniform) or L_max (adaptive: the slot size).
    level: u32,
    /// 1: canonical edge evaluation on.
    canonical: u32,
    /// > 0: point r's f32 residual is points[residual_rows + r].
    residual_rows: u32,
    /// This dispatch's first patch: the output is bound from its slot on ([`patch_batches`]).
    patch_base: u32,
    /// Patches each workgroup evaluates in turn ([`patches_per_group`]).
    patches_per_group: u32,
}

/// The Gregory evaluation compute pass: uniform ([`GregoryEvalPass::new`], [`GregoryEvalPass::record`]) or
/// adaptive ([`GregoryEvalPass::new_adaptive`], [`GregoryEvalPass::record_adaptive`]).
pub struct GregoryEvalPass {
    pipeline: ComputePipeline,
    adaptive: bool,
    /// Patches per workgroup, when set by the caller (else [`patches_per_group`] decides per level).
    patches_per_group: Option<u32>,
}

/// The control points the pass reads: vec4 points (xyz, any w) and, when `residual_rows` > 0, each point's
/// f32 residual at `residual_rows + row` (the hi + lo layout of [`crate::passes::spmv::SpmvPass::new_affine_split`]),
/// which the evaluation adds in patch-local coordinates.
#[derive(Clone, Copy)]
pub struct ControlPoints<'a> {
    pub buffer: &'a Buffer,
    /// Rows before the residuals (0: no residuals).
    pub residual_rows: u32,
}

impl<'a> ControlPoints<'a> {
    /// Plain f32 points, no residuals.
    pub fn plain(buffer: &'a Buffer) -> Self {
        ControlPoints {
            buffer,
            residual_rows: 0,
        }
    }
}

/// The per-patch and per-edge levels the adaptive variant reads (see
/// [`crate::passes::adaptive_levels`]).
pub struct AdaptiveInputs<'a> {
    /// u32 level per patch.
    pub levels: &'a Buffer,
    /// u32 edge id per patch edge (4·patch + e).
    pub edge_ids: &'a Buffer,
    /// u32 level per edge.
    pub edge_levels: &'a Buffer,
}

/// Batches (first patch, count) of `patch_count` patches with `slot_bytes` of output each, every batch's output
/// range one storage binding ([`storage_chunks`]): a level-64 grid of a few thousand patches needs several
/// hundred MiB, which a vertex buffer may hold but one storage descriptor may not. A limit error when one
/// patch's slot alone exceeds a binding.
pub fn patch_batches(ctx: &Context, patch_count: u32, slot_bytes: u64) -> Result<Vec<(u32, u32)>> {
    let max = ctx.limits.max_storage_buffer_range as u64;
    if slot_bytes > max {
        return Err(Error::Limit {
            what: format!("one patch's output of {slot_bytes} B"),
            detail: format!("one storage binding holds at most {max} B"),
        });
    }
    Ok(storage_chunks(
        patch_count as u64,
        slot_bytes,
        max,
        ctx.limits.min_storage_buffer_offset_alignment,
    )
    .into_iter()
    .map(|(first, count)| (first as u32, count as u32))
    .collect())
}

/// The output range of patches `first..first + count` with `slot_bytes` each.
pub fn output_range(out: BufferRange, first: u32, count: u32, slot_bytes: u64) -> Binding {
    Binding::StorageRange {
        buffer: out.buffer,
        offset: out.offset + first as u64 * slot_bytes,
        range: count as u64 * slot_bytes,
    }
}

/// Checks that `out` holds `n` surface vertices and starts where a storage binding may.
fn check_output(ctx: &Context, out: BufferRange, n: u64) -> Result<()> {
    if n * std::mem::size_of::<SurfaceVertex>() as u64 > out.size {
        return Err(Error::Invalid(format!(
            "{n} vertices do not fit buffer '{}' ({} bytes)",
            out.name, out.size
        )));
    }
    let align = ctx.limits.min_storage_buffer_offset_alignment.max(1);
    if out.offset % align != 0 {
        return Err(Error::Invalid(format!(
            "buffer '{}' is written from byte {}, which is not a multiple of the device's \
             minStorageBufferOffsetAlignment ({align})",
            out.name, out.offset
        )));
    }
    Ok(())
}

/// Patches each workgroup of the uniform pass evaluates in turn at `level`: on a CPU device up to 8, so that
/// a workgroup has about 1,024 vertices to evaluate (lavapipe pays a fixed cost per workgroup: at level 4
/// on spot, 8 patches per workgroup took 2.9 ms against 3.3 ms with one); one on a GPU, where many
/// workgroups in flight matter more. `GREGVOX_EVAL_PATCHES_PER_GROUP=N` overrides it for a pass built by
/// [`GregoryEvalPass::new`] (read once, when the pass is built; the bench compares).
pub fn patches_per_group(ctx: &Context, level: u32) -> u32 {
    if ctx.info.device_type != "CPU" {
        return 1;
    }
    (1024 / (level + 1).pow(2)).clamp(1, 8)
}

/// Vertices of `patches` patches at `level`.
pub fn vertex_count(patches: u32, level: u32) -> u64 {
    patches as u64 * (level as u64 + 1).pow(2)
}

impl GregoryEvalPass {
    /// Builds the uniform-level pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        Self::build(ctx, false, None)
    }

    /// The uniform pipeline with its tuning fixed by the caller (tests compare the variants bit for bit):
    /// `subgroup_barrier` picks the subgroup-barrier variant (only valid where a subgroup holds
    /// [`GROUP_SIZE`] invocations) or the workgroup barrier; `patches_per_group` as in [`patches_per_group`].
    pub fn with_tuning(
        ctx: &Context,
        subgroup_barrier: bool,
        patches_per_group: u32,
    ) -> Result<Self> {
        if subgroup_barrier && ctx.info.subgroup_size < GROUP_SIZE {
            return Err(Error::Invalid(format!(
                "the subgroup-barrier evaluation needs subgroups of at least {GROUP_SIZE} invocations; \
                 this device's hold {}",
                ctx.info.subgroup_size
            )));
        }
        let mut pass = Self::build(ctx, false, Some(subgroup_barrier))?;
        pass.patches_per_group = Some(patches_per_group.clamp(1, 64));
        Ok(pass)
    }

    /// Builds the adaptive pipeline: per-patch levels, edges snapped to the shared edge level.
    pub fn new_adaptive(ctx: &Context) -> Result<Self> {
        Self::build(ctx, true, None)
    }

    fn build(ctx: &Context, adaptive: bool, subgroup_barrier: Option<bool>) -> Result<Self> {
        let mut b = DescriptorSetLayoutBuilder::new();
        for i in 0..if adaptive { 7 } else { 4 } {
            b = b.storage_buffer(i, vk::ShaderStageFlags::COMPUTE);
        }
        let layout = b.build(ctx, "gregory eval set")?;
        // Where a subgroup holds the whole workgroup, its barrier is enough (and far cheaper on llvmpipe).
        // `GREGVOX_EVAL_BARRIER=workgroup` keeps the workgroup barrier (the bench compares).
        let one_subgroup = subgroup_barrier.unwrap_or(
            ctx.info.subgroup_size >= GROUP_SIZE
                && std::env::var("GREGVOX_EVAL_BARRIER").as_deref() != Ok("workgroup"),
        );
        let (name, spirv) = match (adaptive, one_subgroup) {
            (true, _) => ("gregory eval adaptive", shaders::GREGORY_EVAL_ADAPTIVE_COMP),
            (false, true) => ("gregory eval", shaders::GREGORY_EVAL_SUBGROUP_COMP),
            (false, false) => ("gregory eval", shaders::GREGORY_EVAL_COMP),
        };
        Ok(GregoryEvalPass {
            pipeline: ComputePipeline::new(
                ctx,
                name,
                spirv,
                vec![layout],
                std::mem::size_of::<Push>() as u32,
                GROUP_SIZE,
            )?,
            adaptive,
            patches_per_group: std::env::var("GREGVOX_EVAL_PATCHES_PER_GROUP")
                .ok()
                .and_then(|s| s.parse::<u32>().ok())
                .map(|n| n.clamp(1, 64))
                .filter(|_| !adaptive),
        })
    }

    /// Records the evaluation of `patch_count` patches at `level` (1…64) into `out`.
    #[allow(clippy::too_many_arguments)]
    pub fn record<'o>(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        points: ControlPoints,
        patch_points: &Buffer,
        patch_flags: &Buffer,
        patch_count: u32,
        level: u32,
        canonical_edges: bool,
        out: impl Into<BufferRange<'o>>,
    ) -> Result<()> {
        let out = out.into();
        if self.adaptive {
            return Err(Error::Invalid(
                "the adaptive evaluation pass records with record_adaptive".into(),
            ));
        }
        if !(1..=MAX_LEVEL).contains(&level) {
            return Err(Error::Invalid(format!(
                "tessellation level {level} is outside 1…{MAX_LEVEL}"
            )));
        }
        check_output(ctx, out, vertex_count(patch_count, level))?;
        let slot = (level as u64 + 1).pow(2) * std::mem::size_of::<SurfaceVertex>() as u64;
        for (first, count) in patch_batches(ctx, patch_count, slot)? {
            let ppw = self
                .patches_per_group
                .unwrap_or_else(|| patches_per_group(ctx, level));
            let push = Push {
                patch_count: count,
                level,
                canonical: canonical_edges as u32,
                residual_rows: points.residual_rows,
                patch_base: first,
                patches_per_group: ppw,
            };
            let bindings = [
                (0, Binding::Storage(points.buffer.raw())),
                (1, Binding::Storage(patch_points.raw())),
                (2, Binding::Storage(patch_flags.raw())),
                (3, output_range(out, first, count, slot)),
            ];
            self.pipeline
                .bind(ctx, cmd, &bindings, bytemuck::bytes_of(&push));
            // One workgroup per `ppw` patches (see the shader).
            self.pipeline.dispatch_linear(
                ctx,
                cmd,
                count.div_ceil(ppw) as u64 * GROUP_SIZE as u64,
            )?;
        }
        compute_writes_to_readers(ctx, cmd);
        Ok(())
    }

    /// Records the adaptive evaluation: patch p evaluates its own (L_p+1)² grid into the first vertices of its
    /// slot of (`l_max`+1)² (slot p starts at vertex p·(`l_max`+1)²), with its boundary rows snapped to the
    /// edge levels. `l_max` must be the maximum the levels were computed with.
    #[allow(clippy::too_many_arguments)]
    pub fn record_adaptive<'o>(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        points: ControlPoints,
        patch_points: &Buffer,
        patch_flags: &Buffer,
        patch_count: u32,
        l_max: u32,
        adaptive: &AdaptiveInputs,
        out: impl Into<BufferRange<'o>>,
    ) -> Result<()> {
        let out = out.into();
        if !self.adaptive {
            return Err(Error::Invalid(
                "the uniform evaluation pass cannot record adaptive levels (use new_adaptive)"
                    .into(),
            ));
        }
        if !(1..=MAX_LEVEL).contains(&l_max) {
            return Err(Error::Invalid(format!(
                "adaptive maximum level {l_max} is outside 1…{MAX_LEVEL}"
            )));
        }
        check_output(ctx, out, vertex_count(patch_count, l_max))?;
        let slot = (l_max as u64 + 1).pow(2) * std::mem::size_of::<SurfaceVertex>() as u64;
        for (first, count) in patch_batches(ctx, patch_count, slot)? {
            let push = Push {
                patch_count: count,
                level: l_max,
                canonical: 1,
                residual_rows: points.residual_rows,
                patch_base: first,
                patches_per_group: 1,
            };
            let bindings = [
                (0, Binding::Storage(points.buffer.raw())),
                (1, Binding::Storage(patch_points.raw())),
                (2, Binding::Storage(patch_flags.raw())),
                (3, output_range(out, first, count, slot)),
                (4, Binding::Storage(adaptive.levels.raw())),
                (5, Binding::Storage(adaptive.edge_ids.raw())),
                (6, Binding::Storage(adaptive.edge_levels.raw())),
            ];
            self.pipeline
                .bind(ctx, cmd, &bindings, bytemuck::bytes_of(&push));
            self.pipeline
                .dispatch_linear(ctx, cmd, count as u64 * GROUP_SIZE as u64)?;
        }
        compute_writes_to_readers(ctx, cmd);
        Ok(())
    }
}

/// Two counter-clockwise triangles per grid cell of every patch (the tessellation contract's vertex order).
///
/// ```
/// let idx = gregvox::passes::gregory_eval::grid_indices(1, 1);
/// assert_eq!(idx, [0, 1, 3, 0, 3, 2]);
/// ```
pub fn grid_indices(patches: u32, level: u32) -> Vec<u32> {
    let n = level + 1;
    let mut out = Vec::with_capacity(patches as usize * level as usize * level as usize * 6);
    for p in 0..patches {
        let base = p * n * n;
        for j in 0..level {
            for i in 0..level {
                let a = base + j * n + i;
                let (b, c, d) = (a + 1, a + n + 1, a + n);
                out.extend_from_slice(&[a, b, c, a, c, d]);
            }
        }
    }
    out
}
