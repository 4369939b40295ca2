//! `OverlayPass`: flat-coloured triangles in window pixels drawn over a finished frame, alpha-blended, with
//! no depth test (glsl/lines.{vert,frag}: position and colour per vertex, the colour passed through). The
//! demo's on-screen overlay (`demo::hud`) is rectangles: a translucent panel and the glyphs' pixel runs.
//!
//! Invariants: the pass owns its pipeline; targets as in `SurfaceDrawPass` (colour in
//! `COLOR_ATTACHMENT_OPTIMAL`, depth in `DEPTH_ATTACHMENT_OPTIMAL`, both loaded, kept and unchanged on
//! exit; the depth is neither tested nor written). Vertices are window pixels (x right, y down, the origin
//! at the top-left corner); a rectangle with integer corners covers exactly the pixels inside it
//! (Vulkan's top-left rasterization rule), so text is pixel-exact at every size.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{GraphicsDesc, GraphicsPipeline};
use crate::gpu::{shaders, Buffer, Context};
use crate::passes::draw::ColorTarget;
use crate::passes::draw::{begin_color_depth, DrawTarget};
use crate::passes::lines::LineVertex;
use ash::vk;

/// Push constants of glsl/lines.vert (`Push`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    view_proj: [f32; 16],
}

/// Window pixels → Vulkan clip space (x, y in −1…1, y down) for a `width`×`height` target.
pub fn pixels_to_clip(width: u32, height: u32) -> glam::Mat4 {
    let (w, h) = (width.max(1) as f32, height.max(1) as f32);
    glam::Mat4::from_translation(glam::Vec3::new(-1.0, -1.0, 0.0))
        * glam::Mat4::from_scale(glam::Vec3::new(2.0 / w, 2.0 / h, 1.0))
}

/// The overlay pipeline.
pub struct OverlayPass {
    pipeline: GraphicsPipeline,
}

impl OverlayPass {
    /// Builds the pipeline for `color`/`depth` targets.
    pub fn new(ctx: &Context, color: impl Into<ColorTarget>, depth: vk::Format) -> Result<Self> {
        let color: ColorTarget = color.into();
        let mut desc = GraphicsDesc::new(
            shaders::LINES_VERT,
            shaders::LINES_FRAG,
            color.format,
            depth,
        );
        desc.depth_test = false;
        desc.depth_write = false;
        desc.blend = true;
        (desc.vertex_bindings, desc.vertex_attributes) = LineVertex::vertex_input();
        desc.push_constant_bytes = std::mem::size_of::<Push>() as u32;
        desc.push_constant_stages = vk::ShaderStageFlags::VERTEX;
        desc.samples = color.samples;
        Ok(OverlayPass {
            pipeline: GraphicsPipeline::new(ctx, "overlay", desc)?,
        })
    }

    /// Draws the first `vertex_count` vertices of `vertices` (window pixels, a triangle list) over the
    /// target, blending by their alpha.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        target: &DrawTarget,
        vertices: &Buffer,
        vertex_count: u32,
    ) -> Result<()> {
        if vertex_count as u64 * std::mem::size_of::<LineVertex>() as u64 > vertices.size() {
            return Err(Error::Invalid(format!(
                "overlay: {vertex_count} vertices do not fit buffer '{}'",
                vertices.name()
            )));
        }
        begin_color_depth(ctx, cmd, target, None);
        let push = Push {
            view_proj: pixels_to_clip(target.extent.width, target.extent.height).to_cols_array(),
        };
        self.pipeline
            .bind(ctx, cmd, &[], bytemuck::bytes_of(&push), target.extent);
        let triangles = vertex_count - vertex_count % 3;
        if triangles > 0 {
            // SAFETY: inside the render pass with the pipeline bound; the buffer holds vertex_count vertices.
            unsafe {
                ctx.device
                    .cmd_bind_vertex_buffers(cmd, 0, &[vertices.raw()], &[0]);
                ctx.device.cmd_draw(cmd, triangles, 1, 0, 0);
            }
        }
        ctx.cmd_end_rendering(cmd);
        Ok(())
    }
}
