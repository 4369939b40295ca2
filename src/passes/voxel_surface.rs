//! `VoxelSurfacePass`: every voxel a triangle touches, on the GPU (glsl/voxel_surface.comp), the same bits as
//! the CPU's `voxel::surface::voxelize_surface`.
//!
//! Invariants: the pass owns its pipeline; vertices (three f32 per vertex, tightly packed), indices, the work
//! list ([`SurfaceWork`], built on the CPU by `engine::voxelize`) and the output slab are the caller's. The shader ORs bits into the slab, so the caller zeroes it first (`record`
//! does, with a fill); a slab holds whole rows j of the bit-axis-z layout, `[row0, row0 + rows)`, so no
//! binding passes `maxStorageBufferRange`. The shader computes in f64: the device must have
//! `shaderFloat64` ([`VoxelSurfacePass::new`] refuses otherwise). On exit the bits are visible to transfers.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::memory_barrier;
use crate::gpu::{shaders, Buffer, Context};
use crate::voxel::grid::{Axis, GridFrame};
use ash::vk;

/// Push constants (`Push` in glsl/voxel_surface.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    /// xyz: grid origin.
    origin: [f64; 4],
    /// xyz: 1 / voxel size.
    inv_size: [f64; 4],
    /// xyz: voxels per axis, w: words per column.
    dims: [u32; 4],
    work_count: u32,
    invocations: u32,
    row0: u32,
    rows: u32,
}

/// One triangle's work (`Work` in glsl/voxel_surface.comp): the columns across its walk axis that its extent
/// touches, one invocation each, numbered from `first`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SurfaceWork {
    pub first: u32,
    pub tri: u32,
    /// The walk axis d (0, 1, 2): the largest component of the normal.
    pub axis: u32,
    /// First column along axis (d+1)%3 and along (d+2)%3.
    pub a0: u32,
    pub b0: u32,
    /// Columns along (d+1)%3 (the count along (d+2)%3 follows from the next entry's `first`).
    pub na: u32,
    /// 1: walk the whole extent along d (a normal that vanishes in grid units).
    pub full: u32,
    pub pad: u32,
}

/// The surface-voxel compute pass.
pub struct VoxelSurfacePass {
    pipeline: ComputePipeline,
}

/// The triangles to mark: vertex and index buffers as `engine::voxelize::GpuTriangles` holds them, and the work
/// list (`work_count` entries, `invocations` in all).
#[derive(Clone, Copy)]
pub struct SurfaceTriangles<'a> {
    pub vertices: &'a Buffer,
    pub indices: &'a Buffer,
    pub work: &'a Buffer,
    pub work_count: u32,
    pub invocations: u32,
}

impl VoxelSurfacePass {
    /// Builds the pipeline; refuses a device without `shaderFloat64`.
    pub fn new(ctx: &Context) -> Result<Self> {
        if !ctx.info.features.shader_float64 {
            return Err(Error::Limit {
                what: "surface voxels on the GPU".into(),
                detail: "the device lacks shaderFloat64 (the exact test runs in f64)".into(),
            });
        }
        let layout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(1, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(2, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(3, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "voxel surface set")?;
        Ok(VoxelSurfacePass {
            pipeline: ComputePipeline::new(
                ctx,
                "voxel surface",
                shaders::VOXEL_SURFACE_COMP,
                vec![layout],
                std::mem::size_of::<Push>() as u32,
                64,
            )?,
        })
    }

    /// Records the marking of the rows `rows` (j values) of `frame` (bits along z) into `out`, zeroed first.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        tris: &SurfaceTriangles,
        frame: &GridFrame,
        rows: std::ops::Range<u32>,
        out: &Buffer,
    ) -> Result<()> {
        let (row0, rows) = (rows.start, rows.len() as u32);
        let words = frame.words_per_column(Axis::Z);
        let bytes = rows as u64 * frame.dims[0] as u64 * words as u64 * 4;
        if bytes > out.size() {
            return Err(Error::Invalid(format!(
                "voxel surface: {rows} rows need {bytes} bytes, buffer '{}' holds {}",
                out.name(),
                out.size()
            )));
        }
        // SAFETY: recording; the fill covers the slab inside the buffer.
        unsafe {
            ctx.device
                .cmd_fill_buffer(cmd, out.raw(), 0, bytes.max(4), 0)
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
        let o = frame.origin;
        let inv = frame.voxel_size.map(|h| 1.0 / h);
        let push = Push {
            origin: [o[0], o[1], o[2], 0.0],
            inv_size: [inv[0], inv[1], inv[2], 0.0],
            dims: [frame.dims[0], frame.dims[1], frame.dims[2], words],
            work_count: tris.work_count,
            invocations: tris.invocations,
            row0,
            rows,
        };
        self.pipeline.bind(
            ctx,
            cmd,
            &[
                (0, Binding::Storage(tris.vertices.raw())),
                (1, Binding::Storage(tris.indices.raw())),
                (2, Binding::Storage(out.raw())),
                (3, Binding::Storage(tris.work.raw())),
            ],
            bytemuck::bytes_of(&push),
        );
        if tris.work_count > 0 {
            self.pipeline
                .dispatch_linear(ctx, cmd, tris.invocations as u64)?;
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
