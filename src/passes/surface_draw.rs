//! `SurfaceDrawPass`: draws a surface vertex buffer (`SurfaceVertex`, stride 32) with the lecture's shading
//! model (glsl/surface.{vert,frag}) into a color + depth target with dynamic rendering.
//!
//! Invariants: the pass owns its pipeline; vertex, index and target resources are the caller's. The color
//! target is in `COLOR_ATTACHMENT_OPTIMAL` and the depth target in `DEPTH_ATTACHMENT_OPTIMAL` on entry and
//! exit. `clear = true` clears both; otherwise both are loaded (several draws into one frame).
use crate::error::Result;
use crate::gpu::pipeline::{GraphicsDesc, GraphicsPipeline};
use crate::gpu::{shaders, Buffer, Context};
use ash::vk;

/// The shading modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ShadingMode {
    Phong = 0,
    Normals = 1,
    Zebra = 2,
    Grid = 3,
}

/// Push constants of the surface shaders (`SurfacePush` in glsl/include/surface_common.glsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SurfacePush {
    pub view_proj: [[f32; 4]; 4],
    pub eye: [f32; 4],
    pub light: [f32; 4],
    pub color: [f32; 4],
    pub mode: [u32; 4],
}

/// Begins dynamic rendering into `target`'s color and depth views, clearing both (`clear` = Some(color)) or
/// loading them; shared by every pass that draws a surface.
pub fn begin_color_depth(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    target: &DrawTarget,
    clear: Option<[f32; 4]>,
) {
    let load = if clear.is_some() {
        vk::AttachmentLoadOp::CLEAR
    } else {
        vk::AttachmentLoadOp::LOAD
    };
    let color = [vk::RenderingAttachmentInfo::default()
        .image_view(target.color)
        .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
        .load_op(load)
        .store_op(vk::AttachmentStoreOp::STORE)
        .clear_value(vk::ClearValue {
            color: vk::ClearColorValue {
                float32: clear.unwrap_or([0.0; 4]),
            },
        })];
    let depth = vk::RenderingAttachmentInfo::default()
        .image_view(target.depth)
        .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
        .load_op(load)
        .store_op(vk::AttachmentStoreOp::STORE)
        .clear_value(vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth: 1.0,
                stencil: 0,
            },
        });
    let info = vk::RenderingInfo::default()
        .render_area(vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent: target.extent,
        })
        .layer_count(1)
        .color_attachments(&color)
        .depth_attachment(&depth);
    ctx.cmd_begin_rendering(cmd, &info);
}

/// The surface draw pass.
pub struct SurfaceDrawPass {
    pipeline: GraphicsPipeline,
    pub color_format: vk::Format,
    pub depth_format: vk::Format,
}

/// A frame's targets.
#[derive(Clone, Copy)]
pub struct DrawTarget {
    pub color: vk::ImageView,
    pub depth: vk::ImageView,
    pub extent: vk::Extent2D,
}

impl SurfaceDrawPass {
    /// Builds the pipeline for `color` targets with a `depth` buffer.
    pub fn new(ctx: &Context, color: vk::Format, depth: vk::Format) -> Result<Self> {
        let mut desc =
            GraphicsDesc::new(shaders::SURFACE_VERT, shaders::SURFACE_FRAG, color, depth);
        desc.vertex_bindings = vec![vk::VertexInputBindingDescription {
            binding: 0,
            stride: 32,
            input_rate: vk::VertexInputRate::VERTEX,
        }];
        desc.vertex_attributes = vec![
            vk::VertexInputAttributeDescription {
                location: 0,
                binding: 0,
                format: vk::Format::R32G32B32A32_SFLOAT,
                offset: 0,
            },
            vk::VertexInputAttributeDescription {
                location: 1,
                binding: 0,
                format: vk::Format::R32G32B32A32_SFLOAT,
                offset: 16,
            },
        ];
        desc.push_constant_bytes = std::mem::size_of::<SurfacePush>() as u32;
        desc.push_constant_stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        Ok(SurfaceDrawPass {
            pipeline: GraphicsPipeline::new(ctx, "surface draw", desc)?,
            color_format: color,
            depth_format: depth,
        })
    }

    /// Records the draw of `index_count` indices of `vertices`/`indices`.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        target: &DrawTarget,
        clear: Option<[f32; 4]>,
        vertices: &Buffer,
        indices: &Buffer,
        index_count: u32,
        push: &SurfacePush,
    ) {
        begin_color_depth(ctx, cmd, target, clear);
        self.pipeline
            .bind(ctx, cmd, &[], bytemuck::bytes_of(push), target.extent);
        // SAFETY: inside the render pass with the pipeline bound; buffers have VERTEX/INDEX usage.
        unsafe {
            ctx.device
                .cmd_bind_vertex_buffers(cmd, 0, &[vertices.raw], &[0]);
            ctx.device
                .cmd_bind_index_buffer(cmd, indices.raw, 0, vk::IndexType::UINT32);
            ctx.device.cmd_draw_indexed(cmd, index_count, 1, 0, 0, 0);
        }
        ctx.cmd_end_rendering(cmd);
    }

    /// Destroys the pipeline.
    pub fn destroy(self, ctx: &Context) {
        self.pipeline.destroy(ctx);
    }
}
