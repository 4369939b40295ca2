//! `ShadowMap`: hard shadows for the demo's lit surface path. A depth-only pass from the light
//! (glsl/shadow_depth.vert, no fragment shader) draws the same device-local surface vertex buffers as the colour
//! pass into the map's depth image; the colour pass reads it through a depth-compare sampler
//! (`sampler2DShadow`, glsl/shadowed_surface.frag) together with a small uniform buffer holding the light's
//! matrix.
//!
//! Invariants:
//! - The map owns its depth image, pipeline, sampler and light uniform buffer; vertex buffers are the caller's.
//! - One image serves all frames in flight: `record` starts with a barrier from the previous frame's sampled
//!   reads (fragment shader) to this frame's depth writes, and ends with the image in
//!   `SHADER_READ_ONLY_OPTIMAL` and visible to fragment-shader sampling. The uniform buffer is updated in the
//!   command buffer (`vkCmdUpdateBuffer`) for the same reason.
//! - `record` must be called outside a render pass, before the colour pass that samples the map.
//! - The light matrix is orthographic (directional light) and maps depth to 0…1.
use crate::error::Result;
use crate::gpu::pipeline::{Binding, GraphicsDesc, GraphicsPipeline};
use crate::gpu::resources::{image_barrier, memory_barrier};
use crate::gpu::Owned;
use crate::gpu::{shaders, Buffer, Context, Image, ImageDesc, MemoryLocation};
use crate::passes::draw::{draw_indexed, LitDraw};
use ash::vk;
use glam::{Mat4, Vec3};

/// The shadow map's depth format (sampled with compare, so it needs SAMPLED_IMAGE and DEPTH_STENCIL_ATTACHMENT
/// features: D32_SFLOAT is mandatory for both).
pub const SHADOW_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// The light's uniform block (`Light` in glsl/shadowed_surface.frag).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LightUniform {
    pub light_view_proj: [[f32; 4]; 4],
    /// x: constant depth bias in light depth units.
    pub params: [f32; 4],
}

/// Push constants of the depth pass (`ShadowPush` in glsl/shadow_depth.vert).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct ShadowPush {
    /// The light's view-projection matrix (mat4, column-major).
    light_view_proj: [f32; 16],
}

/// An orthographic light looking along `-dir` (dir points towards the light) at a sphere (`centre`,
/// `radius`): everything inside the sphere lands inside the map, depth 0 on the sphere's light side; depth
/// runs on to 1 at 2·radius beyond the centre, so a ground plane under the sphere still receives shadow.
///
/// ```
/// use gregvox::passes::shadow_map::light_view_proj;
/// use glam::Vec3;
/// let m = light_view_proj(Vec3::Z, Vec3::ZERO, 2.0);
/// let top = m.project_point3(Vec3::new(0.0, 0.0, 2.0));
/// let below = m.project_point3(Vec3::new(1.0, -1.0, -4.0));
/// assert!(top.z.abs() < 1e-6 && (below.z - 1.0).abs() < 1e-6);
/// assert!(below.x.abs() <= 1.0 && below.y.abs() <= 1.0);
/// ```
pub fn light_view_proj(dir: Vec3, centre: Vec3, radius: f32) -> Mat4 {
    let dir = dir.normalize_or(Vec3::Z);
    let radius = radius.max(1e-3);
    let eye = centre + dir * radius;
    // Any up vector not parallel to the light direction.
    let up = if dir.z.abs() > 0.99 { Vec3::Y } else { Vec3::Z };
    let view = Mat4::look_at_rh(eye, centre, up);
    let proj = Mat4::orthographic_rh(-radius, radius, -radius, radius, 0.0, 3.0 * radius);
    proj * view
}

/// The shadow map pass. See the module invariants.
pub struct ShadowMap {
    pipeline: GraphicsPipeline,
    image: Image,
    sampler: Owned<vk::Sampler>,
    uniform: Buffer,
    /// Side of the square map in texels.
    pub size: u32,
}

impl ShadowMap {
    /// A `size`×`size` map.
    pub fn new(ctx: &Context, size: u32) -> Result<Self> {
        let mut desc = GraphicsDesc::new(
            shaders::SHADOW_DEPTH_VERT,
            &[],
            vk::Format::UNDEFINED,
            SHADOW_FORMAT,
        );
        desc.fragment = None;
        desc.vertex_bindings = vec![vk::VertexInputBindingDescription {
            binding: 0,
            stride: 32,
            input_rate: vk::VertexInputRate::VERTEX,
        }];
        desc.vertex_attributes = vec![vk::VertexInputAttributeDescription {
            location: 0,
            binding: 0,
            format: vk::Format::R32G32B32A32_SFLOAT,
            offset: 0,
        }];
        // Slope-scaled bias against acne on surfaces grazing the light (set in `record`).
        desc.depth_bias = true;
        desc.push_constant_bytes = std::mem::size_of::<ShadowPush>() as u32;
        desc.push_constant_stages = vk::ShaderStageFlags::VERTEX;
        let pipeline = GraphicsPipeline::new(ctx, "shadow map", desc)?;
        let image = ctx.create_image(
            "shadow map",
            &ImageDesc::d2(
                size,
                size,
                SHADOW_FORMAT,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
            ),
        )?;
        // Depth-compare sampler: texture() returns 1 where ref ≤ stored depth (lit). NEAREST: one tap, hard
        // edges, bit-reproducible frames for the golden tests.
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .compare_enable(true)
            .compare_op(vk::CompareOp::LESS_OR_EQUAL)
            .max_lod(0.0);
        let sampler = ctx.create_sampler(&info, "shadow map compare sampler")?;
        let uniform = ctx.create_buffer(
            "shadow light",
            std::mem::size_of::<LightUniform>() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        Ok(ShadowMap {
            pipeline,
            image,
            sampler,
            uniform,
            size,
        })
    }

    /// Records the depth pass of `draws` (vertex buffer of stride 32, u32 index buffer, index count) from
    /// the light `light_view_proj`, and the light uniform update.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        light_view_proj: Mat4,
        draws: &[LitDraw<'_>],
    ) {
        // Previous frames' uniform reads and map samples before this frame's writes.
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::FRAGMENT_SHADER,
                vk::AccessFlags2::NONE,
            ),
            (
                vk::PipelineStageFlags2::ALL_TRANSFER,
                vk::AccessFlags2::TRANSFER_WRITE,
            ),
        );
        let light = LightUniform {
            light_view_proj: light_view_proj.to_cols_array_2d(),
            // Two depth texels' worth of constant bias on top of the rasterizer's slope bias (see below).
            params: [2.0 / self.size as f32, 0.0, 0.0, 0.0],
        };
        // SAFETY: recording outside a render pass; 80 bytes ≤ 65536, multiple of 4.
        unsafe {
            ctx.device
                .cmd_update_buffer(cmd, self.uniform.raw(), 0, bytemuck::bytes_of(&light))
        };
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::ALL_TRANSFER,
                vk::AccessFlags2::TRANSFER_WRITE,
            ),
            (
                vk::PipelineStageFlags2::FRAGMENT_SHADER,
                vk::AccessFlags2::UNIFORM_READ,
            ),
        );
        let tests = vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
            | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS;
        // The old contents are not needed (cleared below): UNDEFINED discards them.
        image_barrier(
            ctx,
            cmd,
            self.image.raw(),
            self.image.range(),
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
            (
                vk::PipelineStageFlags2::FRAGMENT_SHADER,
                vk::AccessFlags2::NONE,
            ),
            (
                tests,
                vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ
                    | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
            ),
        );
        let extent = vk::Extent2D {
            width: self.size,
            height: self.size,
        };
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(self.image.view())
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
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
                extent,
            })
            .layer_count(1)
            .depth_attachment(&depth);
        ctx.cmd_begin_rendering(cmd, &info);
        let push = ShadowPush {
            light_view_proj: light_view_proj.to_cols_array(),
        };
        self.pipeline
            .bind(ctx, cmd, &[], bytemuck::bytes_of(&push), extent);
        // SAFETY: inside the render pass with the pipeline bound; buffers have VERTEX/INDEX usage.
        unsafe {
            // Slope-scaled bias: 1.5 × the depth slope keeps grazing surfaces from shadowing themselves.
            ctx.device.cmd_set_depth_bias(cmd, 0.0, 0.0, 1.5);
        }
        for d in draws {
            // SAFETY: as above.
            unsafe {
                ctx.device
                    .cmd_bind_vertex_buffers(cmd, 0, &[d.vertices.raw()], &[0]);
                ctx.device
                    .cmd_bind_index_buffer(cmd, d.indices.raw(), 0, vk::IndexType::UINT32);
            }
            draw_indexed(ctx, cmd, d.index_count, d.indirect);
        }
        ctx.cmd_end_rendering(cmd);
        image_barrier(
            ctx,
            cmd,
            self.image.raw(),
            self.image.range(),
            vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            (tests, vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE),
            (
                vk::PipelineStageFlags2::FRAGMENT_SHADER,
                vk::AccessFlags2::SHADER_SAMPLED_READ,
            ),
        );
    }

    /// The descriptors the lit surface path reads: binding 0 the light uniform, binding 1 the map.
    pub fn bindings(&self) -> [(u32, Binding); 2] {
        [
            (0, Binding::Uniform(self.uniform.raw())),
            (
                1,
                Binding::Sampled {
                    view: self.image.view(),
                    sampler: self.sampler.raw(),
                    layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                },
            ),
        ]
    }
}
