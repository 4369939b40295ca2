//! The generalized winding number's three compute passes (`glsl/gwn_bricks.comp`, `glsl/gwn_cap_term.comp`,
//! `glsl/gwn_direct.comp`), the GPU side of `voxel::gwn`'s stages 1–3 (the crossing count of stage 3 is the
//! CPU scanline's, on the host), operation for operation the CPU's.
//!
//! Invariants: each pass owns its pipeline; every buffer is the caller's (`engine::voxelize::resolve_gpu`).
//! The list buffers start with their u32 count, which `record` zeroes; counts are exact even past a list's
//! capacity (writes past it are dropped), so the caller detects an overflow. Loops in a shader run over the
//! cap triangles (at most [`MAX_LOOP`]) or one chunk of the mesh: lavapipe silently cuts loops
//! past 65,535 iterations. The shaders compute in f64: [`GwnPasses::new`] refuses a device without
//! `shaderFloat64`. On exit of each `record` the outputs are visible to transfers and later compute.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::memory_barrier;
use crate::gpu::{shaders, Buffer, Context};
use crate::voxel::grid::GridFrame;
use crate::voxel::gwn::{
    level_dims, level_edge, CELL, DIRECT_CHUNK, LEVELS, LISTED_VOXEL_BYTES, SPLIT,
};
use ash::vk;

/// The longest loop a shader runs over cap triangles.
pub const MAX_LOOP: usize = 16384;

/// Push constants of the brick and cap-term passes (`Push` in glsl/gwn_bricks.comp, gwn_cap_term.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct CapPush {
    /// xyz: voxel size, w: the near distance.
    voxel_size: [f64; 4],
    /// xyz: voxels per axis, w: cap triangles.
    dims: [u32; 4],
    /// xyz: boxes per axis (bricks pass: of its level; cap-term pass: cells), w: invocations (bricks pass) or
    /// the list's capacity (cap-term pass).
    bdims: [u32; 4],
    /// x: the bricks pass's level (0: the coarsest boxes), y: its box edge in voxels.
    level: [u32; 4],
}

/// Push constants of the direct pass (`Push` in glsl/gwn_direct.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct DirectPush {
    origin: [f64; 4],
    voxel_size: [f64; 4],
    voxels: u32,
    chunks: u32,
    triangles: u32,
    chunk_size: u32,
}

/// The three pipelines.
pub struct GwnPasses {
    bricks: ComputePipeline,
    cap_term: ComputePipeline,
    direct: ComputePipeline,
}

fn compute_to_compute_and_copy(ctx: &Context, cmd: vk::CommandBuffer) {
    memory_barrier(
        ctx,
        cmd,
        (
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
        ),
        (
            vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::COPY,
            vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::TRANSFER_READ,
        ),
    );
}

fn zero_count(ctx: &Context, cmd: vk::CommandBuffer, list: &Buffer) {
    // SAFETY: recording; the first 4 bytes lie inside the buffer (every list holds its count).
    unsafe { ctx.device.cmd_fill_buffer(cmd, list.raw(), 0, 4, 0) };
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
}

impl GwnPasses {
    /// Builds the pipelines; refuses a device without `shaderFloat64`.
    pub fn new(ctx: &Context) -> Result<Self> {
        if !ctx.info.features.shader_float64 {
            return Err(Error::Limit {
                what: "the generalized winding number on the GPU".into(),
                detail: "the device lacks shaderFloat64 (the cap term runs in f64)".into(),
            });
        }
        let layout = |n: u32, name: &str| {
            let mut b = DescriptorSetLayoutBuilder::new();
            for i in 0..n {
                b = b.storage_buffer(i, vk::ShaderStageFlags::COMPUTE);
            }
            b.build(ctx, name)
        };
        let cap_push = std::mem::size_of::<CapPush>() as u32;
        Ok(GwnPasses {
            bricks: ComputePipeline::new(
                ctx,
                "gwn bricks",
                shaders::GWN_BRICKS_COMP,
                vec![layout(3, "gwn bricks set")?],
                cap_push,
                64,
            )?,
            cap_term: ComputePipeline::new(
                ctx,
                "gwn cap term",
                shaders::GWN_CAP_TERM_COMP,
                vec![layout(3, "gwn cap term set")?],
                cap_push,
                64,
            )?,
            direct: ComputePipeline::new(
                ctx,
                "gwn direct",
                shaders::GWN_DIRECT_COMP,
                vec![layout(4, "gwn direct set")?],
                std::mem::size_of::<DirectPush>() as u32,
                64,
            )?,
        })
    }

    /// Stage 1, one level (boxes of [`level_edge`]³ voxels). Level 0 lists into `outs`
    /// ({count, index…}) the boxes (linear index) of `frame` that the `triangle_count` cap triangles' bound
    /// does not clear; the next levels list those among the children of the `in_count` boxes of the level
    /// above listed in `ins`. `outs` has room for every box of its level.
    #[allow(clippy::too_many_arguments)]
    pub fn record_bricks(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        frame: &GridFrame,
        near: f64,
        triangles: &Buffer,
        triangle_count: u32,
        level: u32,
        ins: &Buffer,
        in_count: u32,
        outs: &Buffer,
    ) -> Result<()> {
        let bd = level_dims(frame, level);
        let room = bd.iter().map(|&b| b as u64).product::<u64>();
        let invocations = if level == 0 {
            room
        } else {
            in_count as u64 * (SPLIT * SPLIT * SPLIT) as u64
        };
        if level >= LEVELS
            || triangle_count as usize > MAX_LOOP
            || invocations > u32::MAX as u64
            || (room + 1) * 4 > outs.size()
        {
            return Err(Error::Invalid(format!(
                "gwn boxes: level {level}, {triangle_count} cap triangles or {invocations} boxes pass the \
                 pass's limits"
            )));
        }
        zero_count(ctx, cmd, outs);
        let h = frame.voxel_size;
        let push = CapPush {
            voxel_size: [h[0], h[1], h[2], near],
            dims: [frame.dims[0], frame.dims[1], frame.dims[2], triangle_count],
            bdims: [bd[0], bd[1], bd[2], invocations as u32],
            level: [level, level_edge(level), 0, 0],
        };
        self.bricks.bind(
            ctx,
            cmd,
            &[
                (0, Binding::Storage(triangles.raw())),
                (1, Binding::Storage(ins.raw())),
                (2, Binding::Storage(outs.raw())),
            ],
            bytemuck::bytes_of(&push),
        );
        self.bricks.dispatch_linear(ctx, cmd, invocations)?;
        compute_to_compute_and_copy(ctx, cmd);
        Ok(())
    }

    /// Stage 2: the cap term at every voxel of the `cell_count` cells listed in `cells`; crossing and direct voxels
    /// appended to `listed` ({count, pad, `Listed`…: uvec4 voxel + dvec2 w_C, 32 bytes}, room for
    /// `capacity`).
    #[allow(clippy::too_many_arguments)]
    pub fn record_cap_term(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        frame: &GridFrame,
        near: f64,
        triangles: &Buffer,
        triangle_count: u32,
        cells: &Buffer,
        cell_count: u32,
        listed: &Buffer,
        capacity: u32,
    ) -> Result<()> {
        let invocations = cell_count as u64 * (CELL * CELL * CELL) as u64;
        if triangle_count as usize > MAX_LOOP
            || invocations > u32::MAX as u64
            || 16 + capacity as u64 * LISTED_VOXEL_BYTES > listed.size()
        {
            return Err(Error::Invalid(format!(
                "gwn cap term: {triangle_count} cap triangles, {cell_count} cells or a list of \
                 {capacity} pass the pass's limits"
            )));
        }
        zero_count(ctx, cmd, listed);
        let bd = level_dims(frame, LEVELS - 1);
        let h = frame.voxel_size;
        let push = CapPush {
            voxel_size: [h[0], h[1], h[2], near],
            dims: [frame.dims[0], frame.dims[1], frame.dims[2], triangle_count],
            bdims: [bd[0], bd[1], bd[2], capacity],
            level: [0; 4],
        };
        self.cap_term.bind(
            ctx,
            cmd,
            &[
                (0, Binding::Storage(triangles.raw())),
                (1, Binding::Storage(cells.raw())),
                (2, Binding::Storage(listed.raw())),
            ],
            bytemuck::bytes_of(&push),
        );
        self.cap_term.dispatch_linear(ctx, cmd, invocations)?;
        compute_to_compute_and_copy(ctx, cmd);
        Ok(())
    }

    /// Stage 3: per (chunk, voxel) the chunk's sum of solid angles of the mesh's first `triangles`
    /// triangles at the `voxels` voxels of `direct` (uvec4 each), into `partial` (f64, chunk-major).
    #[allow(clippy::too_many_arguments)]
    pub fn record_direct(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        frame: &GridFrame,
        vertices: &Buffer,
        indices: &Buffer,
        triangles: u32,
        direct: &Buffer,
        voxels: u32,
        partial: &Buffer,
    ) -> Result<()> {
        let chunks = triangles.div_ceil(DIRECT_CHUNK);
        let invocations = voxels as u64 * chunks as u64;
        if invocations > u32::MAX as u64 || invocations * 8 > partial.size() {
            return Err(Error::Invalid(format!(
                "gwn direct: {voxels} voxels × {chunks} chunks pass the pass's limits"
            )));
        }
        let (o, h) = (frame.origin, frame.voxel_size);
        let push = DirectPush {
            origin: [o[0], o[1], o[2], 0.0],
            voxel_size: [h[0], h[1], h[2], 0.0],
            voxels,
            chunks,
            triangles,
            chunk_size: DIRECT_CHUNK,
        };
        self.direct.bind(
            ctx,
            cmd,
            &[
                (0, Binding::Storage(vertices.raw())),
                (1, Binding::Storage(indices.raw())),
                (2, Binding::Storage(direct.raw())),
                (3, Binding::Storage(partial.raw())),
            ],
            bytemuck::bytes_of(&push),
        );
        self.direct.dispatch_linear(ctx, cmd, invocations)?;
        compute_to_compute_and_copy(ctx, cmd);
        Ok(())
    }
}
