//! `BeziexEvalPass`: the compute path for Beziex patches (glsl/beziex_eval.comp): every patch on its (L+1)²
//! grid into a `SurfaceVertex` buffer, in the same order and layout as `GregoryEvalPass`.
//!
//! Invariants: the pass owns only its pipeline; the nets (56 vec4 per patch, `BeziexPatch::to_gpu`) and the
//! output (STORAGE | VERTEX) are the caller's; on exit the output is visible to vertex input, shaders and copies.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::compute_writes_to_readers;
use crate::gpu::{shaders, Buffer, Context};
use crate::passes::gregory_eval::{vertex_count, MAX_LEVEL};
use ash::vk;

/// Push constants of the evaluation (`Push` in glsl/beziex_eval.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    patch_count: u32,
    /// Level L.
    level: u32,
}

/// The Beziex compute evaluation pass.
pub struct BeziexEvalPass {
    pipeline: ComputePipeline,
}

impl BeziexEvalPass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let layout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(1, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "beziex eval set")?;
        Ok(BeziexEvalPass {
            pipeline: ComputePipeline::new(
                ctx,
                "beziex eval",
                shaders::BEZIEX_EVAL_COMP,
                vec![layout],
                std::mem::size_of::<Push>() as u32,
                64,
            )?,
        })
    }

    /// Records the evaluation of `patch_count` patches at `level` into `out`.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        nets: &Buffer,
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
        if n * 32 > out.size() || patch_count as u64 * 56 * 16 > nets.size() {
            return Err(Error::Invalid("beziex eval: buffers too small".into()));
        }
        let push = Push { patch_count, level };
        self.pipeline.bind(
            ctx,
            cmd,
            &[
                (0, Binding::Storage(nets.raw())),
                (1, Binding::Storage(out.raw())),
            ],
            bytemuck::bytes_of(&push),
        );
        self.pipeline.dispatch_linear(ctx, cmd, n)?;
        compute_writes_to_readers(ctx, cmd);
        Ok(())
    }
}
