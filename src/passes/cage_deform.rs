//! `CageDeformPass`: animates control-cage vertices on the GPU (glsl/cage_deform.comp): twist, bend or wave
//! of the rest positions at time `t`.
//!
//! Invariants: the pass owns only its pipeline; `rest` and `out` (vec4 per vertex) are the caller's. On exit
//! the writes are visible to later compute passes (the stencil SpMV) and transfers.
use crate::error::Result;
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::compute_writes_to_readers;
use crate::gpu::{shaders, Buffer, Context};
use ash::vk;

/// How the cage moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Deformation {
    /// The rest cage.
    None = 0,
    /// Twist about the vertical axis, growing with height.
    Twist = 1,
    /// Bend about the y axis.
    Bend = 2,
    /// A travelling wave along x.
    Wave = 3,
}

/// Parameters of one frame's deformation.
#[derive(Clone, Copy, Debug)]
pub struct DeformParams {
    pub mode: Deformation,
    pub t: f32,
    pub amplitude: f32,
    pub box_min: [f32; 3],
    pub box_size: [f32; 3],
}

/// Push constants of the kernel (`Push` in glsl/cage_deform.comp).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    box_min: [f32; 4],
    box_size: [f32; 4],
    count: u32,
    mode: u32,
    t: f32,
    amplitude: f32,
}

/// The cage deformation compute pass.
pub struct CageDeformPass {
    pipeline: ComputePipeline,
}

impl CageDeformPass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let layout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(1, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "cage deform set")?;
        let size = std::mem::size_of::<Push>() as u32;
        Ok(CageDeformPass {
            pipeline: ComputePipeline::new(
                ctx,
                "cage deform",
                shaders::CAGE_DEFORM_COMP,
                vec![layout],
                size,
                64,
            )?,
        })
    }

    /// Records `out[i] = deform(rest[i])` for `count` vertices.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        rest: &Buffer,
        out: &Buffer,
        count: u32,
        p: &DeformParams,
    ) -> Result<()> {
        let longest = p.box_size.iter().fold(0.0f32, |a, &b| a.max(b));
        let push = Push {
            box_min: [p.box_min[0], p.box_min[1], p.box_min[2], 0.0],
            box_size: [p.box_size[0], p.box_size[1], p.box_size[2], longest],
            count,
            mode: p.mode as u32,
            t: p.t,
            amplitude: p.amplitude,
        };
        self.pipeline.bind(
            ctx,
            cmd,
            &[
                (0, Binding::Storage(rest.raw())),
                (1, Binding::Storage(out.raw())),
            ],
            bytemuck::bytes_of(&push),
        );
        self.pipeline.dispatch_linear(ctx, cmd, count as u64)?;
        compute_writes_to_readers(ctx, cmd);
        Ok(())
    }
}
