//! `BoundsPass`: the axis-aligned bounding box of a vertex buffer on the GPU (glsl/bounds.comp), so a grid
//! frame can be placed around a surface that never leaves the device (only six numbers come back).
//!
//! Invariants: the pass owns its pipeline; the vertex buffer (positions as the first three floats of each
//! `stride`-byte vertex, any size: bound in chunks of at most `maxStorageBufferRange`) and the 24-byte bounds
//! buffer are the caller's. `record` initialises the bounds itself
//! and leaves them visible to transfers.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::{compute_to_compute, memory_barrier, storage_chunks};
use crate::gpu::{shaders, Buffer, Context};
use ash::vk;

/// Push constants of the reduction (`Push` in glsl/bounds.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    /// Vertices in this dispatch.
    count: u32,
    /// Vertex stride in floats.
    stride_floats: u32,
}

/// The bounds compute pass.
pub struct BoundsPass {
    pipeline: ComputePipeline,
}

/// Decodes the shader's order-preserving uint encoding of a float.
///
/// ```
/// use gregvox::passes::bounds::decode;
/// let enc = |f: f32| { let u = f.to_bits(); if u >> 31 == 1 { !u } else { u | 0x8000_0000 } };
/// for f in [-3.5f32, -0.0, 0.0, 1e-20, 7.25] { assert_eq!(decode(enc(f)), f); }
/// assert!(enc(-1.0) < enc(0.5));
/// ```
pub fn decode(u: u32) -> f32 {
    f32::from_bits(if u >> 31 == 1 { u & 0x7fff_ffff } else { !u })
}

impl BoundsPass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let layout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(1, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "bounds set")?;
        Ok(BoundsPass {
            pipeline: ComputePipeline::new(
                ctx,
                "bounds",
                shaders::BOUNDS_COMP,
                vec![layout],
                std::mem::size_of::<Push>() as u32,
                64,
            )?,
        })
    }

    /// Records the bounds of `count` vertices of `stride` bytes into `bounds` (6 u32, TRANSFER_DST usage).
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        vertices: &Buffer,
        count: u32,
        stride: u32,
        bounds: &Buffer,
    ) -> Result<()> {
        if stride % 4 != 0
            || stride < 12
            || count as u64 * stride as u64 > vertices.size()
            || bounds.size() < 24
        {
            return Err(Error::Invalid("bounds: bad stride or buffer sizes".into()));
        }
        let init: [u32; 6] = [u32::MAX, u32::MAX, u32::MAX, 0, 0, 0];
        // SAFETY: recording; 24 bytes inside the bounds buffer.
        unsafe {
            ctx.device
                .cmd_update_buffer(cmd, bounds.raw(), 0, bytemuck::cast_slice(&init))
        };
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
        // Vertex buffers past one storage binding (e.g. a level-64 Gregory grid) are reduced in chunks: the
        // atomics accumulate across dispatches, each bound at an aligned offset.
        let chunks = storage_chunks(
            count as u64,
            stride as u64,
            ctx.limits.max_storage_buffer_range as u64,
            ctx.limits.min_storage_buffer_offset_alignment,
        );
        for (first, n) in chunks {
            if first > 0 {
                compute_to_compute(ctx, cmd);
            }
            let push = Push {
                count: n as u32,
                stride_floats: stride / 4,
            };
            self.pipeline.bind(
                ctx,
                cmd,
                &[
                    (
                        0,
                        Binding::StorageRange {
                            buffer: vertices.raw(),
                            offset: first * stride as u64,
                            range: n * stride as u64,
                        },
                    ),
                    (1, Binding::Storage(bounds.raw())),
                ],
                bytemuck::bytes_of(&push),
            );
            self.pipeline.dispatch_linear(ctx, cmd, n)?;
        }
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
