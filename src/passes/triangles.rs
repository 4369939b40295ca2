//! `TrianglesPass`: draws triangles whose clip-space vertices come from a storage buffer
//! (glsl/flat_triangles.{vert,frag}) with dynamic rendering into one color target. Used by the smoke tests
//! and the minimal demo scene.
//!
//! Invariants: the pass owns its pipeline and layouts; the vertex buffer and the target
//! image are the caller's. The target must be in `COLOR_ATTACHMENT_OPTIMAL` on entry and stays so on exit.
use crate::error::Result;
use crate::gpu::pipeline::{Binding, DescriptorSetLayoutBuilder, GraphicsDesc, GraphicsPipeline};
use crate::gpu::{shaders, Buffer, Context};
use crate::passes::draw::{with_resolve, ColorTarget};
use ash::vk;

/// Push constants of the fragment shader (`Push` in glsl/flat_triangles.frag).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    /// rgb: the solid colour, a: 1 (solid) or 0 (per-vertex palette).
    solid: [f32; 4],
}

/// The flat triangles pass.
pub struct TrianglesPass {
    pipeline: GraphicsPipeline,
}

impl TrianglesPass {
    /// Builds the pipeline for color targets of `format`.
    pub fn new(ctx: &Context, format: impl Into<ColorTarget>) -> Result<Self> {
        let format: ColorTarget = format.into();
        let layout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, vk::ShaderStageFlags::VERTEX)
            .build(ctx, "triangles set")?;
        let mut desc = GraphicsDesc::new(
            shaders::FLAT_TRIANGLES_VERT,
            shaders::FLAT_TRIANGLES_FRAG,
            format.format,
            vk::Format::UNDEFINED,
        );
        desc.set_layouts = vec![layout];
        desc.push_constant_bytes = std::mem::size_of::<Push>() as u32;
        desc.push_constant_stages = vk::ShaderStageFlags::FRAGMENT;
        desc.samples = format.samples;
        Ok(TrianglesPass {
            pipeline: GraphicsPipeline::new(ctx, "triangles", desc)?,
        })
    }

    /// Clears `target` (resolving into `resolve` when multisampled) to `clear` and draws `vertices` (a multiple of 3) from `positions` (vec4 each).
    /// `solid` = Some(rgb) paints every triangle in that colour, else a per-vertex palette.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        target: vk::ImageView,
        resolve: Option<vk::ImageView>,
        extent: vk::Extent2D,
        clear: [f32; 4],
        positions: &Buffer,
        vertices: u32,
        solid: Option<[f32; 3]>,
    ) {
        let color = [with_resolve(
            vk::RenderingAttachmentInfo::default()
                .image_view(target)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue {
                    color: vk::ClearColorValue { float32: clear },
                }),
            resolve,
        )];
        let info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D {
                offset: vk::Offset2D::default(),
                extent,
            })
            .layer_count(1)
            .color_attachments(&color);
        ctx.cmd_begin_rendering(cmd, &info);
        let push = Push {
            solid: match solid {
                Some([r, g, b]) => [r, g, b, 1.0],
                None => [0.0; 4],
            },
        };
        self.pipeline.bind(
            ctx,
            cmd,
            &[(0, Binding::Storage(positions.raw()))],
            bytemuck::bytes_of(&push),
            extent,
        );
        // SAFETY: inside the render pass with the pipeline bound.
        unsafe { ctx.device.cmd_draw(cmd, vertices, 1, 0, 0) };
        ctx.cmd_end_rendering(cmd);
    }
}
