//! `SurfaceDrawPass`: draws a surface vertex buffer (`SurfaceVertex`, stride 32) with the lecture's shading
//! model into a color + depth target with dynamic rendering, on one of two paths:
//! - plain (`record`, glsl/surface.{vert,frag}): no descriptors; Phong, normals, zebra, wireframe;
//! - lit (`record_lit`, glsl/shadowed_surface.{vert,frag}): every [`ShadingMode`], with hard shadows from a
//!   [`ShadowMap`] and the curvature modes read from a second vertex stream of (H, K) per vertex
//!   ([`crate::passes::surface_curvature`]); also draws the ground plane (push flag).
//!
//! Invariants: the pass owns its two pipelines; vertex, index, curvature, shadow and target resources are the
//! caller's. The color target is in `COLOR_ATTACHMENT_OPTIMAL` and the depth target in
//! `DEPTH_ATTACHMENT_OPTIMAL` on entry and exit. `clear = Some(colour)` clears both; otherwise both are loaded
//! (several draws into one frame). The shadow map must have been recorded earlier in the command buffer.
use crate::error::Result;
use crate::gpu::pipeline::{DescriptorSetLayoutBuilder, GraphicsDesc, GraphicsPipeline};
use crate::gpu::{shaders, Buffer, Context};
use crate::passes::draw::ColorTarget;
pub use crate::passes::draw::{begin_color_depth, draw_indexed, DrawTarget, IndirectDraw, LitDraw};
use crate::passes::shadow_map::ShadowMap;
use ash::vk;

/// The shading modes (`mode.x` of the surface shaders).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum ShadingMode {
    /// Lambert + ambient + Phong (the lecture model), with shadows on the lit path.
    Phong = 0,
    /// Unit normals as colours.
    Normals = 1,
    /// Zebra stripes of the reflected view direction (G1 across patch edges).
    Zebra = 2,
    /// Phong with the patch boundaries drawn as lines.
    #[cfg_attr(feature = "cli", value(alias = "grid"))]
    Wireframe = 3,
    /// Mean curvature H, diverging colours (lit path only; Phong on the plain path).
    Mean = 4,
    /// Gaussian curvature K, diverging colours (lit path only; Phong on the plain path).
    Gaussian = 5,
    /// A checker texture over the cage's UVs (OpenSubdiv's face-varying surface; the patch parameters
    /// where the cage has none, or on the plain path), shaded.
    Checker = 6,
}

impl ShadingMode {
    /// Every mode, in the order the S key cycles through them.
    pub const ALL: [ShadingMode; 7] = [
        ShadingMode::Phong,
        ShadingMode::Normals,
        ShadingMode::Zebra,
        ShadingMode::Wireframe,
        ShadingMode::Mean,
        ShadingMode::Gaussian,
        ShadingMode::Checker,
    ];

    /// The next mode (wrapping).
    ///
    /// ```
    /// use gregvox::passes::surface_draw::ShadingMode;
    /// assert_eq!(ShadingMode::Checker.next(), ShadingMode::Phong);
    /// ```
    pub fn next(self) -> ShadingMode {
        Self::ALL[(self as usize + 1) % Self::ALL.len()]
    }

    /// Whether the mode reads the curvature stream.
    pub fn needs_curvature(self) -> bool {
        matches!(self, ShadingMode::Mean | ShadingMode::Gaussian)
    }

    /// Whether the mode needs every patch's grid at the uniform level (the curvature stream is written per
    /// uniform grid vertex; the wireframe, and the checker without the cage's UVs, find the patch
    /// parameters from the vertex index and the level). `uvs`: the draw has the cage's UV stream.
    pub fn needs_uniform_grid(self, uvs: bool) -> bool {
        self.needs_curvature()
            || self == ShadingMode::Wireframe
            || (self == ShadingMode::Checker && !uvs)
    }
}

/// `mode.w` flag: the draw is the ground plane (always shadowed Phong, no patch grid).
pub const FLAG_GROUND: u32 = 1;
/// `mode.w` flag: sample the shadow map.
pub const FLAG_SHADOWS: u32 = 2;
/// `mode.w` flag: the UV stream (binding 2) holds the cage's UVs (else the checker uses patch parameters).
pub const FLAG_UVS: u32 = 4;

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

/// The surface draw pass.
pub struct SurfaceDrawPass {
    pipeline: GraphicsPipeline,
    lit: GraphicsPipeline,
    pub color_format: vk::Format,
    pub depth_format: vk::Format,
}

impl SurfaceDrawPass {
    /// Builds the pipeline for `color` targets with a `depth` buffer.
    pub fn new(ctx: &Context, color: impl Into<ColorTarget>, depth: vk::Format) -> Result<Self> {
        let color: ColorTarget = color.into();
        let mut desc = GraphicsDesc::new(
            shaders::SURFACE_VERT,
            shaders::SURFACE_FRAG,
            color.format,
            depth,
        );
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
        let mut lit_desc = GraphicsDesc::new(
            shaders::SHADOWED_SURFACE_VERT,
            shaders::SHADOWED_SURFACE_FRAG,
            color.format,
            depth,
        );
        lit_desc.vertex_bindings = desc.vertex_bindings.clone();
        lit_desc
            .vertex_bindings
            .push(vk::VertexInputBindingDescription {
                binding: 1,
                stride: 8,
                input_rate: vk::VertexInputRate::VERTEX,
            });
        // Binding 2: the UV stream (a UV surface's vertices: u, v first; stride 32).
        lit_desc
            .vertex_bindings
            .push(vk::VertexInputBindingDescription {
                binding: 2,
                stride: 32,
                input_rate: vk::VertexInputRate::VERTEX,
            });
        lit_desc.vertex_attributes = desc.vertex_attributes.clone();
        lit_desc
            .vertex_attributes
            .push(vk::VertexInputAttributeDescription {
                location: 2,
                binding: 1,
                format: vk::Format::R32G32_SFLOAT,
                offset: 0,
            });
        lit_desc
            .vertex_attributes
            .push(vk::VertexInputAttributeDescription {
                location: 4,
                binding: 2,
                format: vk::Format::R32G32B32A32_SFLOAT,
                offset: 0,
            });
        lit_desc.push_constant_bytes = desc.push_constant_bytes;
        lit_desc.push_constant_stages = desc.push_constant_stages;
        desc.samples = color.samples;
        let pipeline = GraphicsPipeline::new(ctx, "surface draw", desc)?;
        lit_desc.set_layouts = vec![DescriptorSetLayoutBuilder::new()
            .uniform_buffer(0, vk::ShaderStageFlags::FRAGMENT)
            .sampled_image(1, vk::ShaderStageFlags::FRAGMENT)
            .build(ctx, "lit surface set")?];
        lit_desc.samples = color.samples;
        let lit = GraphicsPipeline::new(ctx, "lit surface draw", lit_desc)?;
        Ok(SurfaceDrawPass {
            pipeline,
            lit,
            color_format: color.format,
            depth_format: depth,
        })
    }

    /// Records `draws` on the lit path (shadows from `shadow`, curvature stream) in one render pass.
    pub fn record_lit(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        target: &DrawTarget,
        clear: Option<[f32; 4]>,
        shadow: &ShadowMap,
        draws: &[(LitDraw<'_>, SurfacePush)],
    ) {
        begin_color_depth(ctx, cmd, target, clear);
        let bindings = shadow.bindings();
        for (i, (d, push)) in draws.iter().enumerate() {
            if i == 0 {
                self.lit
                    .bind(ctx, cmd, &bindings, bytemuck::bytes_of(push), target.extent);
            } else {
                // SAFETY: recording with the lit pipeline bound; the range matches its layout.
                unsafe {
                    ctx.device.cmd_push_constants(
                        cmd,
                        self.lit.layout(),
                        self.lit.push_constant_stages(),
                        0,
                        bytemuck::bytes_of(push),
                    )
                };
            }
            let curvature = d.curvature.unwrap_or(d.vertices);
            let uvs = d.uvs.unwrap_or(d.vertices);
            // SAFETY: inside the render pass with the pipeline bound; buffers have VERTEX/INDEX usage.
            unsafe {
                ctx.device.cmd_bind_vertex_buffers(
                    cmd,
                    0,
                    &[d.vertices.raw(), curvature.raw(), uvs.raw()],
                    &[0, 0, 0],
                );
                ctx.device
                    .cmd_bind_index_buffer(cmd, d.indices.raw(), 0, vk::IndexType::UINT32);
            }
            draw_indexed(ctx, cmd, d.index_count, d.indirect);
        }
        ctx.cmd_end_rendering(cmd);
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
                .cmd_bind_vertex_buffers(cmd, 0, &[vertices.raw()], &[0]);
            ctx.device
                .cmd_bind_index_buffer(cmd, indices.raw(), 0, vk::IndexType::UINT32);
            ctx.device.cmd_draw_indexed(cmd, index_count, 1, 0, 0, 0);
        }
        ctx.cmd_end_rendering(cmd);
    }
}
