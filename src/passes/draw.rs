//! Draw helpers shared by the passes that draw surfaces (`surface_draw`, `shadow_map`, `patch_pull`,
//! `lines`): the frame's targets, beginning dynamic rendering into them, and one indexed (or per-patch
//! indirect) surface draw. Its own module so those passes depend on it and not on each other.
use crate::gpu::{Buffer, Context};
use ash::vk;

/// A frame's targets.
#[derive(Clone, Copy)]
pub struct DrawTarget {
    pub color: vk::ImageView,
    pub depth: vk::ImageView,
    pub extent: vk::Extent2D,
    /// With a multisampled `color`: the single-sample image every rendering into it resolves to (in
    /// `COLOR_ATTACHMENT_OPTIMAL`, like `color`).
    pub resolve: Option<vk::ImageView>,
}

/// What a pass draws into: the colour format and the sample count of the colour and depth targets.
/// A plain format converts to one sample, so `SurfaceDrawPass::new(ctx, format, depth)` keeps its meaning.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ColorTarget {
    pub format: vk::Format,
    pub samples: vk::SampleCountFlags,
}

impl From<vk::Format> for ColorTarget {
    fn from(format: vk::Format) -> Self {
        ColorTarget {
            format,
            samples: vk::SampleCountFlags::TYPE_1,
        }
    }
}

/// Sets the colour attachment's resolve into `resolve`, if any (averaging the samples).
pub fn with_resolve(
    att: vk::RenderingAttachmentInfo<'_>,
    resolve: Option<vk::ImageView>,
) -> vk::RenderingAttachmentInfo<'_> {
    match resolve {
        Some(view) => att
            .resolve_mode(vk::ResolveModeFlags::AVERAGE)
            .resolve_image_view(view)
            .resolve_image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL),
        None => att,
    }
}

/// One indexed surface draw of the lit path.
#[derive(Clone, Copy)]
pub struct LitDraw<'a> {
    /// Stride-32 `SurfaceVertex` buffer.
    pub vertices: &'a Buffer,
    /// (H, K) per vertex (stride 8), or `None` when the draw has no curvature: then the vertex buffer is
    /// bound again in its place (a valid stream the shader reads but the non-curvature modes ignore), so one
    /// pipeline serves both.
    pub curvature: Option<&'a Buffer>,
    /// UVs per vertex (stride 32, u and v the first two f32: a UV surface's vertex buffer), or `None`: the
    /// vertex buffer is bound in its place and the checker shading uses the patch parameters.
    pub uvs: Option<&'a Buffer>,
    /// u32 triangle-list indices.
    pub indices: &'a Buffer,
    pub index_count: u32,
    /// Per-patch indexed-indirect commands instead of `index_count` (adaptive tessellation).
    pub indirect: Option<IndirectDraw<'a>>,
}

/// One `VkDrawIndexedIndirectCommand` per patch, written on the GPU (adaptive tessellation: each patch draws
/// its own level's grid from one index buffer holding every level's grid, at its own vertex slot).
#[derive(Clone, Copy, Debug)]
pub struct IndirectDraw<'a> {
    pub commands: &'a Buffer,
    pub count: u32,
}

/// Draws from the bound vertex and index buffers: `index_count` indices, or every command of `indirect`.
/// One draw per command, so it works without the `multiDrawIndirect` feature.
pub fn draw_indexed(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    index_count: u32,
    indirect: Option<IndirectDraw<'_>>,
) {
    const STRIDE: u32 = std::mem::size_of::<vk::DrawIndexedIndirectCommand>() as u32;
    // SAFETY: inside a render pass with a graphics pipeline, vertex and index buffers bound; the command
    // buffer (if any) has INDIRECT usage and `count` commands, made visible to DRAW_INDIRECT by its writer.
    unsafe {
        match indirect {
            None => ctx.device.cmd_draw_indexed(cmd, index_count, 1, 0, 0, 0),
            Some(d) => {
                for p in 0..d.count as u64 {
                    ctx.device.cmd_draw_indexed_indirect(
                        cmd,
                        d.commands.raw(),
                        p * STRIDE as u64,
                        1,
                        STRIDE,
                    );
                }
            }
        }
    }
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
    let color = [with_resolve(
        vk::RenderingAttachmentInfo::default()
            .image_view(target.color)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(load)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                color: vk::ClearColorValue {
                    float32: clear.unwrap_or([0.0; 4]),
                },
            }),
        target.resolve,
    )];
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
