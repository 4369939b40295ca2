//! `PeelCheckPass`: the columns where depth peeling lost an equal-depth fragment (glsl/peel_check.comp).
//!
//! Peeling keeps, at each layer, the nearest fragment strictly behind the previous layer, so of fragments at
//! one depth only one survives (coincident triangles: caps that meet caps, duplicated faces). The count
//! pre-pass counted every fragment of each column; a column that peeled fewer layers lost some. This pass
//! sets one bit per such column so the host can recompute exactly those (`voxel::cpu::refill_columns`).
//!
//! Invariants: the pass owns its pipeline; the layer image (`SHADER_READ_ONLY_OPTIMAL`), the counts (written
//! by the count pre-pass earlier in submission order) and the `lost` bits (zeroed here) are the caller's. On
//! exit the bits are visible to transfers.
use crate::error::Result;
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::memory_barrier;
use crate::gpu::{shaders, Buffer, Context};
use ash::vk;

/// Push constants of the check (`Push` in glsl/peel_check.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    /// Columns per row (voxels along u).
    width: u32,
    /// Peeled layers.
    layer_count: u32,
    /// Columns in all (width × height).
    column_count: u32,
    pad: u32,
}

/// The lost-fragment check.
pub struct PeelCheckPass {
    pipeline: ComputePipeline,
}

impl PeelCheckPass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let layout = DescriptorSetLayoutBuilder::new()
            .sampled_image(0, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(1, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(2, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "peel check set")?;
        Ok(PeelCheckPass {
            pipeline: ComputePipeline::new(
                ctx,
                "peel check",
                shaders::PEEL_CHECK_COMP,
                vec![layout],
                std::mem::size_of::<Push>() as u32,
                64,
            )?,
        })
    }

    /// Records the check of `width × height` columns peeled into `layer_count` layers: `counts` as the
    /// count pre-pass left it, one bit per column into `lost` (at least ⌈columns / 32⌉ words).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        layers: vk::ImageView,
        sampler: vk::Sampler,
        counts: &Buffer,
        lost: &Buffer,
        width: u32,
        height: u32,
        layer_count: u32,
    ) -> Result<()> {
        let columns = width as u64 * height as u64;
        if columns.div_ceil(32) * 4 > lost.size() || (columns + 1) * 4 > counts.size() {
            return Err(crate::Error::Invalid(format!(
                "{width}×{height} columns do not fit buffers '{}' and '{}'",
                counts.name(),
                lost.name()
            )));
        }
        // SAFETY: recording; whole-buffer fill of a buffer this command buffer owns until it completes.
        unsafe {
            ctx.device
                .cmd_fill_buffer(cmd, lost.raw(), 0, vk::WHOLE_SIZE, 0)
        };
        // The zeroed bits, and the counts the count pre-pass wrote earlier in submission order.
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::ALL_TRANSFER | vk::PipelineStageFlags2::FRAGMENT_SHADER,
                vk::AccessFlags2::TRANSFER_WRITE | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        );
        let push = Push {
            width,
            layer_count,
            column_count: columns as u32,
            pad: 0,
        };
        let image = Binding::Sampled {
            view: layers,
            sampler,
            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        };
        self.pipeline.bind(
            ctx,
            cmd,
            &[
                (0, image),
                (1, Binding::Storage(counts.raw())),
                (2, Binding::Storage(lost.raw())),
            ],
            bytemuck::bytes_of(&push),
        );
        self.pipeline.dispatch_linear(ctx, cmd, columns)?;
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::TRANSFER_READ,
            ),
        );
        Ok(())
    }
}
