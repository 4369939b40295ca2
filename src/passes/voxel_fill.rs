//! `VoxelFillPass`: peeled layers → bit-packed solid columns (glsl/voxel_fill.comp).
//!
//! Invariants: the pass owns its pipeline; the layer image (R32_SFLOAT array in `SHADER_READ_ONLY_OPTIMAL`)
//! and the output buffer are the caller's. One invocation per column writes all `ceil(depth/32)` words of its
//! column (zeros included), so the output needs no clearing; a slab of columns `[first, first + count)` is
//! written from word 0 of `out`, which keeps every binding under `maxStorageBufferRange`. On exit the writes
//! are visible to transfers.
use crate::error::Result;
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::memory_barrier;
use crate::gpu::{shaders, Buffer, Context};
use crate::voxel::cpu::FillRule;
use ash::vk;

/// Push constants of the fill (`Push` in glsl/voxel_fill.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    /// Columns per row (voxels along u).
    width: u32,
    /// Peeled layers.
    layer_count: u32,
    /// ceil(depth/32).
    words: u32,
    /// 0: winding, 1: parity.
    rule: u32,
    /// First column (v·width + u) of this slab.
    first_column: u32,
    /// Columns in this slab.
    column_count: u32,
    /// Voxels along the peel axis.
    depth: u32,
    /// Depth range start and length (grid units), as the peel shaders map it.
    depth_lo: f32,
    depth_span: f32,
}

/// The fill compute pass.
pub struct VoxelFillPass {
    pipeline: ComputePipeline,
}

/// What to fill.
#[derive(Clone, Copy, Debug)]
pub struct FillJob {
    pub columns: crate::passes::peel::ColumnFrame,
    pub layer_count: u32,
    pub rule: FillRule,
    pub first_column: u32,
    pub column_count: u32,
}

impl VoxelFillPass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let layout = DescriptorSetLayoutBuilder::new()
            .sampled_image(0, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(1, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "voxel fill set")?;
        Ok(VoxelFillPass {
            pipeline: ComputePipeline::new(
                ctx,
                "voxel fill",
                shaders::VOXEL_FILL_COMP,
                vec![layout],
                std::mem::size_of::<Push>() as u32,
                64,
            )?,
        })
    }

    /// Records the fill of `job`'s columns from `layers` into `out`.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        layers: vk::ImageView,
        sampler: vk::Sampler,
        out: &Buffer,
        job: &FillJob,
    ) -> Result<()> {
        let words = job.columns.words();
        if job.column_count as u64 * words as u64 * 4 > out.size() {
            return Err(crate::Error::Invalid(format!(
                "voxel slab does not fit buffer '{}'",
                out.name()
            )));
        }
        let push = Push {
            width: job.columns.width,
            layer_count: job.layer_count,
            words,
            rule: match job.rule {
                FillRule::Winding | FillRule::Gwn => 0,
                FillRule::Parity => 1,
                FillRule::Positive | FillRule::GwnPositive => 2,
            },
            first_column: job.first_column,
            column_count: job.column_count,
            depth: job.columns.depth,
            depth_lo: job.columns.depth_lo,
            depth_span: job.columns.depth_span,
        };
        let image = Binding::Sampled {
            view: layers,
            sampler,
            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        };
        self.pipeline.bind(
            ctx,
            cmd,
            &[(0, image), (1, Binding::Storage(out.raw()))],
            bytemuck::bytes_of(&push),
        );
        self.pipeline
            .dispatch_linear(ctx, cmd, job.column_count as u64)?;
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
