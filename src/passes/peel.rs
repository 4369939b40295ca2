//! `PeelPass`: the raster half of solid voxelization (glsl/peel.vert, peel.frag, peel_count.frag).
//!
//! - `record_count` draws the mesh once with no attachments and counts fragments per column with atomics in
//!   `counts` (word 0 = the maximum, then width·height counters): the exact bound on the layers to peel.
//! - `record_layer` draws one peeling pass: depth attachment `depth` (cleared to 1.0, LESS, writes on, no
//!   culling), the previous pass's depth read through `prev_depth` (a D32 image in
//!   `DEPTH_STENCIL_READ_ONLY_OPTIMAL`), and the layer written as signed depth to `layer_view` (R32_SFLOAT,
//!   cleared to 0).
//!
//! Invariants: the pass owns its two pipelines and its sampler; geometry, images and buffers are the caller's.
//! On entry `depth` is in `DEPTH_ATTACHMENT_OPTIMAL` and `layer_view`'s image in `COLOR_ATTACHMENT_OPTIMAL`;
//! they stay so on exit (the caller places the barriers between passes). Vertex positions are three f32 at the
//! start of each `stride`-byte vertex, so the Gregory pass's vertex buffer is drawn as-is.
use crate::error::Result;
use crate::gpu::pipeline::{Binding, DescriptorSetLayoutBuilder, GraphicsDesc, GraphicsPipeline};
use crate::gpu::Owned;
use crate::gpu::{shaders, Buffer, Context, Image};
use ash::vk;

/// Push constants of the peel shaders (`PeelPush` in glsl/include/peel_common.glsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PeelPush {
    /// xyz: grid origin, w: start of the depth range (grid units along the peel axis).
    pub origin_depth_lo: [f32; 4],
    /// xyz: 1 / voxel size per axis, w: length of the depth range (grid units).
    pub inv_size_depth_span: [f32; 4],
    /// x: u axis, y: v axis, z: depth axis, w: 0.
    pub axes: [u32; 4],
    /// x: framebuffer width (voxels along u), y: height (along v), z: voxels along the depth axis, w: 0.
    pub extent: [u32; 4],
}

/// The columns of one peel axis as the fill shaders see them (from [`PeelPush::columns`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColumnFrame {
    /// Columns per row (voxels along u).
    pub width: u32,
    /// Voxels along the peel axis.
    pub depth: u32,
    /// Start of the depth range (grid units): the peel shaders' mapping, inverted by the fill.
    pub depth_lo: f32,
    /// Length of the depth range (grid units).
    pub depth_span: f32,
}

impl ColumnFrame {
    /// u32 words per column.
    pub fn words(&self) -> u32 {
        self.depth.div_ceil(32)
    }
}

impl PeelPush {
    /// What the fill passes need of this axis.
    pub fn columns(&self) -> ColumnFrame {
        ColumnFrame {
            width: self.extent[0],
            depth: self.extent[2],
            depth_lo: self.origin_depth_lo[3],
            depth_span: self.inv_size_depth_span[3],
        }
    }

    /// The framebuffer extent: one pixel per column.
    pub fn framebuffer(&self) -> vk::Extent2D {
        vk::Extent2D {
            width: self.extent[0],
            height: self.extent[1],
        }
    }
}

/// Triangles to peel: positions in a vertex buffer and u32 indices.
#[derive(Clone, Copy)]
pub struct PeelGeometry<'a> {
    pub vertices: &'a Buffer,
    pub indices: &'a Buffer,
    pub index_count: u32,
    /// A box holding every vertex (world units), when known: the depth range then covers the whole mesh,
    /// so parts outside the grid (a `--bbox` smaller than the mesh) still count as crossings. `None` when
    /// the geometry lies inside the grid's frame.
    pub bounds: Option<crate::voxel::grid::Bounds>,
    /// The same triangles on the host, when at hand: depth peeling then finds the columns where it lost an
    /// equal-depth fragment (`passes::peel_check`) and the CPU scanline recomputes them, so coincident
    /// triangles cost nothing in exactness. `None` (a surface straight from a GPU buffer): those columns
    /// keep what peeling gave.
    pub mesh: Option<&'a crate::voxel::mesh::TriMesh>,
}

/// The depth-peeling raster pass.
pub struct PeelPass {
    count: GraphicsPipeline,
    peel: GraphicsPipeline,
    sampler: Owned<vk::Sampler>,
    pub stride: u32,
}

impl PeelPass {
    /// Builds the pipelines for vertices of `stride` bytes.
    pub fn new(ctx: &Context, stride: u32) -> Result<Self> {
        let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let vertex_input = |d: &mut GraphicsDesc| {
            d.vertex_bindings = vec![vk::VertexInputBindingDescription {
                binding: 0,
                stride,
                input_rate: vk::VertexInputRate::VERTEX,
            }];
            d.vertex_attributes = vec![vk::VertexInputAttributeDescription {
                location: 0,
                binding: 0,
                format: vk::Format::R32G32B32_SFLOAT,
                offset: 0,
            }];
            d.push_constant_bytes = std::mem::size_of::<PeelPush>() as u32;
            d.push_constant_stages = stages;
            d.cull_mode = vk::CullModeFlags::NONE;
            d.front_face = vk::FrontFace::COUNTER_CLOCKWISE;
        };
        let count_layout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(1, vk::ShaderStageFlags::FRAGMENT)
            .build(ctx, "peel count set")?;
        let mut desc = GraphicsDesc::new(
            shaders::PEEL_VERT,
            shaders::PEEL_COUNT_FRAG,
            vk::Format::UNDEFINED,
            vk::Format::UNDEFINED,
        );
        vertex_input(&mut desc);
        desc.set_layouts = vec![count_layout];
        let count = GraphicsPipeline::new(ctx, "peel count", desc)?;

        let peel_layout = DescriptorSetLayoutBuilder::new()
            .sampled_image(0, vk::ShaderStageFlags::FRAGMENT)
            .build(ctx, "peel set")?;
        let mut desc = GraphicsDesc::new(
            shaders::PEEL_VERT,
            shaders::PEEL_FRAG,
            vk::Format::R32_SFLOAT,
            vk::Format::D32_SFLOAT,
        );
        vertex_input(&mut desc);
        desc.set_layouts = vec![peel_layout];
        desc.depth_compare = vk::CompareOp::LESS;
        let peel = GraphicsPipeline::new(ctx, "peel layer", desc)?;
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE);
        let sampler = ctx.create_sampler(&info, "peel nearest sampler")?;
        Ok(PeelPass {
            count,
            peel,
            sampler,
            stride,
        })
    }

    /// The nearest sampler (also used by the fill pass to read the layers).
    pub fn sampler(&self) -> vk::Sampler {
        self.sampler.raw()
    }

    fn bind_geometry(&self, ctx: &Context, cmd: vk::CommandBuffer, geom: &PeelGeometry) {
        // SAFETY: recording command buffer inside a render pass.
        unsafe {
            ctx.device
                .cmd_bind_vertex_buffers(cmd, 0, &[geom.vertices.raw()], &[0]);
            ctx.device
                .cmd_bind_index_buffer(cmd, geom.indices.raw(), 0, vk::IndexType::UINT32);
        }
    }

    /// Records the count pre-pass into `counts` (zeroed by the caller: 1 + width·height u32).
    pub fn record_count(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        geom: &PeelGeometry,
        push: &PeelPush,
        counts: &Buffer,
    ) {
        let extent = push.framebuffer();
        let info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D {
                offset: vk::Offset2D::default(),
                extent,
            })
            .layer_count(1);
        ctx.cmd_begin_rendering(cmd, &info);
        self.count.bind(
            ctx,
            cmd,
            &[(1, Binding::Storage(counts.raw()))],
            bytemuck::bytes_of(push),
            extent,
        );
        self.bind_geometry(ctx, cmd, geom);
        // SAFETY: inside the render pass with pipeline and buffers bound.
        unsafe {
            ctx.device
                .cmd_draw_indexed(cmd, geom.index_count, 1, 0, 0, 0)
        };
        ctx.cmd_end_rendering(cmd);
    }

    /// Records one peeling pass (see the module invariants for layouts).
    #[allow(clippy::too_many_arguments)]
    pub fn record_layer(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        geom: &PeelGeometry,
        push: &PeelPush,
        prev_depth: &Image,
        depth: &Image,
        layer_view: vk::ImageView,
    ) {
        let extent = push.framebuffer();
        let color = [vk::RenderingAttachmentInfo::default()
            .image_view(layer_view)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                color: vk::ClearColorValue { float32: [0.0; 4] },
            })];
        let depth_att = vk::RenderingAttachmentInfo::default()
            .image_view(depth.view())
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
            .color_attachments(&color)
            .depth_attachment(&depth_att);
        ctx.cmd_begin_rendering(cmd, &info);
        let prev = Binding::Sampled {
            view: prev_depth.view(),
            sampler: self.sampler.raw(),
            layout: vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL,
        };
        self.peel
            .bind(ctx, cmd, &[(0, prev)], bytemuck::bytes_of(push), extent);
        self.bind_geometry(ctx, cmd, geom);
        // SAFETY: inside the render pass with pipeline and buffers bound.
        unsafe {
            ctx.device
                .cmd_draw_indexed(cmd, geom.index_count, 1, 0, 0, 0)
        };
        ctx.cmd_end_rendering(cmd);
    }
}
