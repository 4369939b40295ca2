//! `LinesPass`: draws coloured 3D line segments (glsl/lines.{vert,frag}; `LINE_LIST`, depth-tested) from a
//! vertex buffer the CPU writes every frame, and [`LineRing`], the per-frame-slot host-visible buffers those
//! vertices live in.
//!
//! Invariants: the pass owns its pipeline; targets as in `SurfaceDrawPass` (colour in
//! `COLOR_ATTACHMENT_OPTIMAL`, depth in `DEPTH_ATTACHMENT_OPTIMAL`, unchanged on exit). A ring buffer is written
//! by the host only for the slot being recorded, whose previous frame has completed (the renderer waited on
//! its fence), so no frame in flight ever reads a buffer being rewritten; a buffer too small is replaced at
//! that same point. Host writes before `vkQueueSubmit` are visible to the device (coherent memory, submission
//! order), so no barrier is needed.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{GraphicsDesc, GraphicsPipeline};
use crate::gpu::{shaders, Buffer, Context, MemoryLocation};
use crate::passes::draw::ColorTarget;
use crate::passes::draw::{begin_color_depth, DrawTarget};
use ash::vk;

/// One line vertex (stride 32).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LineVertex {
    pub position: [f32; 4],
    pub color: [f32; 4],
}

impl LineVertex {
    /// The vertex input of glsl/lines.vert: binding 0, position at location 0, colour at location 1.
    pub fn vertex_input() -> (
        Vec<vk::VertexInputBindingDescription>,
        Vec<vk::VertexInputAttributeDescription>,
    ) {
        let attribute = |location, offset| vk::VertexInputAttributeDescription {
            location,
            binding: 0,
            format: vk::Format::R32G32B32A32_SFLOAT,
            offset,
        };
        (
            vec![vk::VertexInputBindingDescription {
                binding: 0,
                stride: std::mem::size_of::<LineVertex>() as u32,
                input_rate: vk::VertexInputRate::VERTEX,
            }],
            vec![attribute(0, 0), attribute(1, 16)],
        )
    }

    /// A vertex at `p` of colour `c` (opaque).
    pub fn new(p: [f32; 3], c: [f32; 3]) -> Self {
        LineVertex {
            position: [p[0], p[1], p[2], 1.0],
            color: [c[0], c[1], c[2], 1.0],
        }
    }
}

/// Push constants of the vertex shader (`Push` in glsl/lines.vert).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    /// mat4, column-major.
    view_proj: [f32; 16],
}

/// The line pass.
pub struct LinesPass {
    pipeline: GraphicsPipeline,
}

impl LinesPass {
    /// Builds the pipeline for `color`/`depth` targets.
    pub fn new(ctx: &Context, color: impl Into<ColorTarget>, depth: vk::Format) -> Result<Self> {
        let color: ColorTarget = color.into();
        let mut desc = GraphicsDesc::new(
            shaders::LINES_VERT,
            shaders::LINES_FRAG,
            color.format,
            depth,
        );
        desc.topology = vk::PrimitiveTopology::LINE_LIST;
        // Lines drawn later over earlier ones at equal depth (a construction over its curve) stay visible.
        desc.depth_compare = vk::CompareOp::LESS_OR_EQUAL;
        (desc.vertex_bindings, desc.vertex_attributes) = LineVertex::vertex_input();
        desc.push_constant_bytes = std::mem::size_of::<Push>() as u32;
        desc.push_constant_stages = vk::ShaderStageFlags::VERTEX;
        desc.samples = color.samples;
        Ok(LinesPass {
            pipeline: GraphicsPipeline::new(ctx, "lines", desc)?,
        })
    }

    /// Draws the first `vertex_count` vertices of `vertices` as segments (pairs), clearing the target first
    /// when `clear` is given.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        target: &DrawTarget,
        clear: Option<[f32; 4]>,
        vertices: &Buffer,
        vertex_count: u32,
        view_proj: &glam::Mat4,
    ) -> Result<()> {
        if vertex_count as u64 * std::mem::size_of::<LineVertex>() as u64 > vertices.size() {
            return Err(Error::Invalid(format!(
                "lines: {vertex_count} vertices do not fit buffer '{}'",
                vertices.name()
            )));
        }
        begin_color_depth(ctx, cmd, target, clear);
        self.pipeline.bind(
            ctx,
            cmd,
            &[],
            bytemuck::bytes_of(&Push {
                view_proj: view_proj.to_cols_array(),
            }),
            target.extent,
        );
        if vertex_count >= 2 {
            // SAFETY: inside the render pass with the pipeline bound; the buffer holds vertex_count vertices.
            unsafe {
                ctx.device
                    .cmd_bind_vertex_buffers(cmd, 0, &[vertices.raw()], &[0]);
                ctx.device.cmd_draw(cmd, vertex_count & !1, 1, 0, 0);
            }
        }
        ctx.cmd_end_rendering(cmd);
        Ok(())
    }
}

/// Host-visible vertex buffers, one per frame slot.
pub struct LineRing {
    buffers: Vec<Option<Buffer>>,
}

impl LineRing {
    /// An empty ring of `slots` buffers (created on first upload).
    pub fn new(slots: usize) -> Self {
        LineRing {
            buffers: (0..slots).map(|_| None).collect(),
        }
    }

    /// Writes `vertices` into `slot`'s buffer (growing it to the next power of two when too small) and
    /// returns it. The caller guarantees the slot's previous frame has completed.
    pub fn upload(
        &mut self,
        ctx: &Context,
        slot: usize,
        vertices: &[LineVertex],
    ) -> Result<&Buffer> {
        let bytes: &[u8] = bytemuck::cast_slice(vertices);
        let need = (bytes.len() as u64).max(64);
        if self.buffers[slot].as_ref().is_some_and(|b| b.size() < need) {
            self.buffers[slot] = None;
        }
        if self.buffers[slot].is_none() {
            self.buffers[slot] = Some(ctx.create_buffer(
                &format!("line vertices {slot}"),
                need.next_power_of_two(),
                vk::BufferUsageFlags::VERTEX_BUFFER,
                MemoryLocation::CpuToGpu,
            )?);
        }
        let buf = self.buffers[slot].as_mut().unwrap();
        buf.mapped_mut()?[..bytes.len()].copy_from_slice(bytes);
        Ok(buf)
    }
}
