//! `IotaPass`: writes `data[i] = i·scale + offset` into a storage buffer (glsl/iota.comp). The smallest
//! complete compute pass: pipeline, push descriptors, 2D-split dispatch for any count.
//!
//! Invariants: the pass owns its pipeline and layouts; the buffer is the caller's; `record` may be called
//! any number of times in one command buffer. On exit
//! of `record` the buffer's writes are made visible to transfers and later shader reads.
use crate::error::Result;
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::compute_writes_to_readers;
use crate::gpu::{shaders, Buffer, Context};
use ash::vk;

/// Push constants of the fill (`Push` in glsl/iota.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    count: u32,
    scale: u32,
    offset: u32,
}

/// The iota compute pass.
pub struct IotaPass {
    pipeline: ComputePipeline,
}

impl IotaPass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let layout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "iota set")?;
        let pipeline = ComputePipeline::new(
            ctx,
            "iota",
            shaders::IOTA_COMP,
            vec![layout],
            std::mem::size_of::<Push>() as u32,
            64,
        )?;
        Ok(IotaPass { pipeline })
    }

    /// Records the fill of the first `count` u32 of `buffer`.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        buffer: &Buffer,
        count: u32,
        scale: u32,
        offset: u32,
    ) -> Result<()> {
        if count as u64 * 4 > buffer.size() {
            return Err(crate::Error::Invalid(format!(
                "iota of {count} values does not fit buffer '{}' ({} bytes)",
                buffer.name(),
                buffer.size()
            )));
        }
        let push = Push {
            count,
            scale,
            offset,
        };
        self.pipeline.bind(
            ctx,
            cmd,
            &[(0, Binding::Storage(buffer.raw()))],
            bytemuck::bytes_of(&push),
        );
        self.pipeline.dispatch_linear(ctx, cmd, count as u64)?;
        compute_writes_to_readers(ctx, cmd);
        Ok(())
    }
}
