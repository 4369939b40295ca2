//! `SpinnerPass`: a compute pass writing a ring of rotating triangles (glsl/spinner.comp) into a buffer that
//! the graphics pipeline then reads as vertices: the minimal demo scene and the smallest proof that compute
//! output feeds rendering with no copy.
//!
//! Invariants: the pass owns its pipeline; the output buffer is the caller's and holds `3·count` vec4. On
//! exit the writes are visible to vertex-shader storage reads.
use crate::error::Result;
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::compute_writes_to_readers;
use crate::gpu::{shaders, Buffer, Context};
use ash::vk;

/// Push constants of the generator (`Push` in glsl/spinner.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    /// Triangles.
    count: u32,
    /// Time.
    t: f32,
    /// Viewport width / height.
    aspect: f32,
}

/// The spinner compute pass.
pub struct SpinnerPass {
    pipeline: ComputePipeline,
}

impl SpinnerPass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let layout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "spinner set")?;
        Ok(SpinnerPass {
            pipeline: ComputePipeline::new(
                ctx,
                "spinner",
                shaders::SPINNER_COMP,
                vec![layout],
                std::mem::size_of::<Push>() as u32,
                64,
            )?,
        })
    }

    /// Records the generation of `count` triangles at time `t` into `out`.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        out: &Buffer,
        count: u32,
        t: f32,
        aspect: f32,
    ) -> Result<()> {
        if count as u64 * 48 > out.size() {
            return Err(crate::Error::Invalid(format!(
                "{count} triangles do not fit buffer '{}'",
                out.name()
            )));
        }
        let push = Push { count, t, aspect };
        self.pipeline.bind(
            ctx,
            cmd,
            &[(0, Binding::Storage(out.raw()))],
            bytemuck::bytes_of(&push),
        );
        self.pipeline.dispatch_linear(ctx, cmd, count as u64)?;
        compute_writes_to_readers(ctx, cmd);
        Ok(())
    }
}
