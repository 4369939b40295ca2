//! `GregoryEvalPass`: evaluates every Gregory patch on its (L+1)² grid into a device-local vertex buffer
//! (glsl/gregory_eval.comp, glsl/include/gregory.glsl).
//!
//! Invariants: the pass owns only its pipeline. Inputs are the caller's: `points` (vec4 control points, e.g.
//! written by [`crate::passes::spmv::SpmvPass`]), `patch_points` (20 u32 point indices per patch, GREGORY_BASIS
//! order) and `patch_flags` (bit e: edge e runs against its canonical direction). The output buffer holds
//! [`SurfaceVertex`] values (stride 32) and must have STORAGE and VERTEX usage; on exit its writes are visible
//! to vertex input, vertex-shader storage reads, later compute passes and transfers.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::compute_writes_to_readers;
use crate::gpu::{shaders, Buffer, Context};
use ash::vk;

/// One output vertex: position (w = 1) and unit normal (w = 0).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SurfaceVertex {
    pub position: [f32; 4],
    pub normal: [f32; 4],
}

/// Highest uniform tessellation level.
pub const MAX_LEVEL: u32 = 64;

/// The Gregory evaluation compute pass.
pub struct GregoryEvalPass {
    pipeline: ComputePipeline,
}

/// Vertices of `patches` patches at `level`.
pub fn vertex_count(patches: u32, level: u32) -> u64 {
    patches as u64 * (level as u64 + 1).pow(2)
}

impl GregoryEvalPass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let mut b = DescriptorSetLayoutBuilder::new();
        for i in 0..4 {
            b = b.storage_buffer(i, vk::ShaderStageFlags::COMPUTE);
        }
        let layout = b.build(ctx, "gregory eval set")?;
        Ok(GregoryEvalPass {
            pipeline: ComputePipeline::new(
                ctx,
                "gregory eval",
                shaders::GREGORY_EVAL_COMP,
                vec![layout],
                16,
                64,
            )?,
        })
    }

    /// Records the evaluation of `patch_count` patches at `level` (1…64) into `out`.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        points: &Buffer,
        patch_points: &Buffer,
        patch_flags: &Buffer,
        patch_count: u32,
        level: u32,
        canonical_edges: bool,
        out: &Buffer,
    ) -> Result<()> {
        if !(1..=MAX_LEVEL).contains(&level) {
            return Err(Error::Invalid(format!(
                "tessellation level {level} is outside 1…{MAX_LEVEL}"
            )));
        }
        let n = vertex_count(patch_count, level);
        if n * 32 > out.size {
            return Err(Error::Invalid(format!(
                "{n} vertices do not fit buffer '{}'",
                out.name
            )));
        }
        let push: [u32; 4] = [patch_count, level, canonical_edges as u32, 0];
        let bindings = [
            (0, Binding::Storage(points.raw)),
            (1, Binding::Storage(patch_points.raw)),
            (2, Binding::Storage(patch_flags.raw)),
            (3, Binding::Storage(out.raw)),
        ];
        self.pipeline
            .bind(ctx, cmd, &bindings, bytemuck::cast_slice(&push));
        // One workgroup of 64 per patch (see the shader).
        self.pipeline
            .dispatch_linear(ctx, cmd, patch_count as u64 * 64)?;
        compute_writes_to_readers(ctx, cmd);
        Ok(())
    }

    /// Destroys the pipeline.
    pub fn destroy(self, ctx: &Context) {
        self.pipeline.destroy(ctx);
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
