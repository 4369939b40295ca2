//! `VoxelRaycastPass`: ray casts a bit-packed voxel grid in a compute shader (glsl/voxel_raycast.comp, a
//! two-level 3D DDA over 4³ bricks (occupancy from glsl/voxel_raycast_bricks.comp) and voxels, Lambert + ambient
//! shading; CPU reference `voxel::raycast`) into an RGBA8 storage image, and shows
//! that image in a region of a colour target with a full-viewport textured triangle
//! (glsl/voxel_raycast_blit.*).
//!
//! Why a draw and not a blit: swapchain images are created with COLOR_ATTACHMENT | TRANSFER_SRC only
//! (gpu/present.rs), and scenes receive the target's view, not its image, so the one operation that works on
//! both the offscreen ring and a swapchain is rendering into the colour attachment.
//!
//! Invariants: the pass owns its pipelines and its nearest sampler; grid, brick buffer, image and id buffer
//! are the caller's; the bricks are rebuilt from the grid by every `record`. `record` expects the grid's
//! writes to be visible to compute shaders, leaves the image in
//! `SHADER_READ_ONLY_OPTIMAL` for the fragment stage and the optional per-pixel `(voxel id, rgba8)` words
//! visible to transfers. `record_show` expects the colour target in `COLOR_ATTACHMENT_OPTIMAL` and leaves it so.
//! The grid's bit axis is z (the resident voxelizer's peel axis).
use crate::error::Result;
use crate::gpu::pipeline::{
    Binding, ComputePipeline, DescriptorSetLayoutBuilder, GraphicsDesc, GraphicsPipeline,
};
use crate::gpu::resources::{compute_to_compute, image_barrier, memory_barrier};
use crate::gpu::Owned;
use crate::gpu::{shaders, Buffer, Context, Image, ImageDesc};
use crate::passes::draw::{with_resolve, ColorTarget};
use crate::voxel::grid::GridFrame;
use crate::voxel::raycast::{RayCamera, RayShading, BRICK};
use ash::vk;

/// The image format the ray caster writes.
pub const RAYCAST_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

/// Push constants of the brick occupancy kernel (`Push` in glsl/voxel_raycast_bricks.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct BricksPush {
    /// Voxels per side R.
    res: u32,
    /// Bricks per side.
    nb: u32,
}

/// Push constants of the ray cast (`Push` in glsl/voxel_raycast.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct CastPush {
    eye: [f32; 4],
    forward: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    origin: [f32; 4],
    light: [f32; 4],
    color: [f32; 4],
    params: [u32; 4],
}

/// Push constants of the display draw (`Push` in glsl/voxel_raycast_blit.frag).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct ShowPush {
    /// The region's offset in the target, pixels.
    offset: [i32; 2],
    /// Target pixels per image texel.
    scale: i32,
}

/// The ray casting pass.
pub struct VoxelRaycastPass {
    bricks: ComputePipeline,
    cast: ComputePipeline,
    show: GraphicsPipeline,
    sampler: Owned<vk::Sampler>,
}

/// Bytes of the brick occupancy buffer of a grid of `res` voxels per side (one u32 per 4³ brick).
pub fn bricks_bytes(res: u32) -> u64 {
    (res.div_ceil(BRICK) as u64).pow(3) * 4
}

/// Bytes of the optional per-pixel output: `(voxel id, packed rgba8)` per pixel.
pub fn ids_bytes(width: u32, height: u32) -> u64 {
    width as u64 * height as u64 * 8
}

impl VoxelRaycastPass {
    /// Builds the compute pipeline and the display pipeline for `color` targets.
    pub fn new(ctx: &Context, color: impl Into<ColorTarget>) -> Result<Self> {
        let color: ColorTarget = color.into();
        let blayout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(1, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "voxel bricks set")?;
        let bricks = ComputePipeline::new(
            ctx,
            "voxel bricks",
            shaders::VOXEL_RAYCAST_BRICKS_COMP,
            vec![blayout],
            std::mem::size_of::<BricksPush>() as u32,
            64,
        )?;
        let layout = DescriptorSetLayoutBuilder::new()
            .storage_image(0, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(1, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(2, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(3, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "voxel raycast set")?;
        let cast = ComputePipeline::new(
            ctx,
            "voxel raycast",
            shaders::VOXEL_RAYCAST_COMP,
            vec![layout],
            std::mem::size_of::<CastPush>() as u32,
            64,
        )?;
        let show_layout = DescriptorSetLayoutBuilder::new()
            .sampled_image(0, vk::ShaderStageFlags::FRAGMENT)
            .build(ctx, "voxel raycast show set")?;
        let mut desc = GraphicsDesc::new(
            shaders::VOXEL_RAYCAST_BLIT_VERT,
            shaders::VOXEL_RAYCAST_BLIT_FRAG,
            color.format,
            vk::Format::UNDEFINED,
        );
        desc.set_layouts = vec![show_layout];
        desc.push_constant_bytes = std::mem::size_of::<ShowPush>() as u32;
        desc.push_constant_stages = vk::ShaderStageFlags::FRAGMENT;
        desc.samples = color.samples;
        let show = GraphicsPipeline::new(ctx, "voxel raycast show", desc)?;
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE);
        let sampler = ctx.create_sampler(&info, "voxel raycast sampler")?;
        Ok(VoxelRaycastPass {
            bricks,
            cast,
            show,
            sampler,
        })
    }

    /// Creates an output image of `width`×`height` the pass can write and show.
    pub fn create_image(ctx: &Context, name: &str, width: u32, height: u32) -> Result<Image> {
        ctx.create_image(
            name,
            &ImageDesc::d2(
                width,
                height,
                RAYCAST_FORMAT,
                vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::SAMPLED,
            ),
        )
    }

    /// Records the brick occupancy of `grid` into `bricks` (≥ [`bricks_bytes`]) and the ray cast of `grid`
    /// (placed by `frame`, bit axis z) into `image` (whole image, previous contents discarded); with `ids`
    /// (≥ [`ids_bytes`]) also the per-pixel voxel index and colour.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        grid: &Buffer,
        bricks: &Buffer,
        frame: &GridFrame,
        image: &Image,
        ids: Option<&Buffer>,
        cam: &RayCamera,
        shading: &RayShading,
    ) -> Result<()> {
        let vk::Extent2D {
            width: w,
            height: h,
        } = image.extent2d();
        if let Some(b) = ids {
            if b.size() < ids_bytes(w, h) {
                return Err(crate::Error::Invalid(format!(
                    "voxel raycast: the id buffer '{}' holds {} bytes, {} needed",
                    b.name(),
                    b.size(),
                    ids_bytes(w, h)
                )));
            }
        }
        let res = frame.cubic_res().ok_or_else(|| {
            crate::Error::Invalid(format!(
                "voxel raycast: the ray caster draws cubic grids of cubic voxels, not {:?} voxels of {:?}",
                frame.dims, frame.voxel_size
            ))
        })?;
        if bricks.size() < bricks_bytes(res) {
            return Err(crate::Error::Invalid(format!(
                "voxel raycast: the brick buffer '{}' holds {} bytes, {} needed",
                bricks.name(),
                bricks.size(),
                bricks_bytes(res)
            )));
        }
        // The previous ray cast's reads of the bricks are done before they are rewritten.
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::NONE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        );
        let nb = res.div_ceil(BRICK);
        self.bricks.bind(
            ctx,
            cmd,
            &[
                (0, Binding::Storage(grid.raw())),
                (1, Binding::Storage(bricks.raw())),
            ],
            bytemuck::bytes_of(&BricksPush { res, nb }),
        );
        self.bricks.dispatch_linear(ctx, cmd, (nb as u64).pow(3))?;
        compute_to_compute(ctx, cmd);
        let inv_pitch = 1.0 / frame.voxel_size[0] as f32;
        let v4 = |v: [f32; 3], w: f32| [v[0], v[1], v[2], w];
        let bg = shading.background;
        let push = CastPush {
            eye: v4(cam.eye, inv_pitch),
            forward: v4(cam.forward, shading.ambient),
            right: v4(cam.right, bg[0]),
            up: v4(cam.up, bg[1]),
            origin: v4(frame.origin.map(|x| x as f32), bg[2]),
            light: v4(shading.light, 0.0),
            color: v4(shading.color, 1.0),
            params: [res, w, h, ids.is_some() as u32],
        };
        // The image's previous reader (last frame's display draw) is done before it is overwritten.
        image_barrier(
            ctx,
            cmd,
            image.raw(),
            image.range(),
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::GENERAL,
            (
                vk::PipelineStageFlags2::FRAGMENT_SHADER,
                vk::AccessFlags2::NONE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        );
        // Without an id buffer the shader never writes binding 2; the grid stands in as a valid buffer.
        let id_buffer = ids.map_or(grid.raw(), |b| b.raw());
        self.cast.bind(
            ctx,
            cmd,
            &[
                (
                    0,
                    Binding::StorageImage {
                        view: image.view(),
                        layout: vk::ImageLayout::GENERAL,
                    },
                ),
                (1, Binding::Storage(grid.raw())),
                (2, Binding::Storage(id_buffer)),
                (3, Binding::Storage(bricks.raw())),
            ],
            bytemuck::bytes_of(&push),
        );
        // SAFETY: recording with the pipeline bound; 8×8 groups, far below the group-count limit for any
        // image maxImageDimension2D allows.
        unsafe {
            ctx.device
                .cmd_dispatch(cmd, w.div_ceil(8), h.div_ceil(8), 1)
        };
        image_barrier(
            ctx,
            cmd,
            image.raw(),
            image.range(),
            vk::ImageLayout::GENERAL,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                vk::PipelineStageFlags2::FRAGMENT_SHADER,
                vk::AccessFlags2::SHADER_SAMPLED_READ,
            ),
        );
        if ids.is_some() {
            memory_barrier(
                ctx,
                cmd,
                (
                    vk::PipelineStageFlags2::COMPUTE_SHADER,
                    vk::AccessFlags2::SHADER_STORAGE_WRITE,
                ),
                (
                    vk::PipelineStageFlags2::ALL_TRANSFER,
                    vk::AccessFlags2::TRANSFER_READ,
                ),
            );
        }
        Ok(())
    }

    /// Draws `image` into the `region` of the colour target `color` starting at `offset`, each image texel
    /// covering `scale`×`scale` pixels (nearest; the image is at least `ceil(region / scale)`), loading the
    /// rest of the target (resolving the region into `resolve` when `color` is multisampled).
    #[allow(clippy::too_many_arguments)]
    pub fn record_show(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        image: &Image,
        color: vk::ImageView,
        resolve: Option<vk::ImageView>,
        offset: vk::Offset2D,
        region: vk::Extent2D,
        scale: u32,
    ) {
        let extent = region;
        let att = [with_resolve(
            vk::RenderingAttachmentInfo::default()
                .image_view(color)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::LOAD)
                .store_op(vk::AttachmentStoreOp::STORE),
            resolve,
        )];
        let area = vk::Rect2D { offset, extent };
        let info = vk::RenderingInfo::default()
            .render_area(area)
            .layer_count(1)
            .color_attachments(&att);
        ctx.cmd_begin_rendering(cmd, &info);
        let push = ShowPush {
            offset: [offset.x, offset.y],
            scale: scale.max(1) as i32,
        };
        self.show.bind(
            ctx,
            cmd,
            &[(
                0,
                Binding::Sampled {
                    view: image.view(),
                    sampler: self.sampler.raw(),
                    layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                },
            )],
            bytemuck::bytes_of(&push),
            extent,
        );
        // SAFETY: inside the render pass with the pipeline bound; viewport and scissor are dynamic.
        unsafe {
            ctx.device.cmd_set_viewport(
                cmd,
                0,
                &[vk::Viewport {
                    x: offset.x as f32,
                    y: offset.y as f32,
                    width: extent.width as f32,
                    height: extent.height as f32,
                    min_depth: 0.0,
                    max_depth: 1.0,
                }],
            );
            ctx.device.cmd_set_scissor(cmd, 0, &[area]);
            ctx.device.cmd_draw(cmd, 3, 1, 0, 0);
        }
        ctx.cmd_end_rendering(cmd);
    }
}
