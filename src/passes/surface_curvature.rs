//! `SurfaceCurvaturePass`: mean and Gaussian curvature (H, K) of every Gregory patch on its (L+1)² grid, from
//! the control points (glsl/surface_curvature.comp), for the demo's curvature shading modes.
//!
//! Invariants: the pass owns only its pipeline. Inputs are the caller's and are those of
//! [`crate::passes::gregory_eval::GregoryEvalPass`] (vec4 control points, 20 point indices per patch); the
//! output holds one `[f32; 2]` = (H, K) per vertex in the evaluation pass's vertex order, so it is drawn as a
//! second vertex stream (STORAGE | VERTEX usage). H is signed with respect to S_u × S_v, as in
//! [`crate::geom::curvature::gaussian_mean_curvature`], the CPU reference; singular points get (0, 0). On exit
//! the writes are visible to vertex input, shaders and transfers.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::compute_writes_to_readers;
use crate::gpu::{shaders, Buffer, Context};
use crate::passes::gregory_eval::{output_range, patch_batches, vertex_count, MAX_LEVEL};
use ash::vk;

/// Bytes per vertex of the curvature buffer: (H, K) as two f32.
pub const CURVATURE_STRIDE: u64 = 8;

/// Push constants of the curvature kernel (`Push` in glsl/surface_curvature.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    /// Patches in this dispatch.
    patch_count: u32,
    /// Level L.
    level: u32,
    /// This dispatch's first patch: the output is bound from its slot on.
    patch_base: u32,
    pad1: u32,
}

/// The curvature compute pass.
pub struct SurfaceCurvaturePass {
    pipeline: ComputePipeline,
}

impl SurfaceCurvaturePass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let mut b = DescriptorSetLayoutBuilder::new();
        for i in 0..3 {
            b = b.storage_buffer(i, vk::ShaderStageFlags::COMPUTE);
        }
        let layout = b.build(ctx, "surface curvature set")?;
        Ok(SurfaceCurvaturePass {
            pipeline: ComputePipeline::new(
                ctx,
                "surface curvature",
                shaders::SURFACE_CURVATURE_COMP,
                vec![layout],
                std::mem::size_of::<Push>() as u32,
                64,
            )?,
        })
    }

    /// Records the curvature of `patch_count` patches at `level` into `out`.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        points: &Buffer,
        patch_points: &Buffer,
        patch_count: u32,
        level: u32,
        out: &Buffer,
    ) -> Result<()> {
        if !(1..=MAX_LEVEL).contains(&level) {
            return Err(Error::Invalid(format!(
                "tessellation level {level} is outside 1…{MAX_LEVEL}"
            )));
        }
        let n = vertex_count(patch_count, level);
        if n * CURVATURE_STRIDE > out.size() {
            return Err(Error::Invalid(format!(
                "curvature of {n} vertices does not fit buffer '{}'",
                out.name()
            )));
        }
        let slot = (level as u64 + 1).pow(2) * CURVATURE_STRIDE;
        for (first, count) in patch_batches(ctx, patch_count, slot)? {
            let push = Push {
                patch_count: count,
                level,
                patch_base: first,
                pad1: 0,
            };
            let bindings = [
                (0, Binding::Storage(points.raw())),
                (1, Binding::Storage(patch_points.raw())),
                (2, output_range(out.into(), first, count, slot)),
            ];
            self.pipeline
                .bind(ctx, cmd, &bindings, bytemuck::bytes_of(&push));
            // One workgroup of 64 per patch, as in the evaluation pass.
            self.pipeline.dispatch_linear(ctx, cmd, count as u64 * 64)?;
        }
        compute_writes_to_readers(ctx, cmd);
        Ok(())
    }
}
