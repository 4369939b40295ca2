//! The capturing vertex-pull path as one call: draws Gregory or Beziex patches through `PatchPullPass`
//! into a small offscreen target and returns the vertices its vertex shader evaluated, in the compute path's
//! order (`gregvox tessellate --path vertex`, the bench's path comparison).
use crate::error::Result;
use crate::gpu::present::begin_color_target;
use crate::gpu::resources::image_barrier;
use crate::gpu::{Buffer, Context, ImageDesc, MemoryLocation, Profiler};
use crate::passes::gregory_eval::{grid_indices, vertex_count, ControlPoints, SurfaceVertex};
use crate::passes::patch_pull::{PatchKind, PatchPullPass};
use crate::passes::surface_draw::{DrawTarget, SurfacePush};
use ash::vk;

/// Draws the patches through the capturing vertex-pull pipeline into a small offscreen target and returns
/// the evaluated vertices (in the compute path's order).
#[allow(clippy::too_many_arguments)]
pub fn vertex_pull(
    ctx: &Context,
    kind: PatchKind,
    points: ControlPoints,
    patch_points: &Buffer,
    patches: u32,
    level: u32,
    repeat: u32,
    profiler: &mut Profiler,
) -> Result<Vec<SurfaceVertex>> {
    let (w, h) = (256, 256);
    let pass = PatchPullPass::new(
        ctx,
        vk::Format::B8G8R8A8_UNORM,
        vk::Format::D32_SFLOAT,
        true,
    )?;
    {
        let images = [
            ctx.create_image(
                "pull color",
                &ImageDesc::d2(
                    w,
                    h,
                    vk::Format::B8G8R8A8_UNORM,
                    vk::ImageUsageFlags::COLOR_ATTACHMENT,
                ),
            )?,
            ctx.create_image(
                "pull depth",
                &ImageDesc::d2(
                    w,
                    h,
                    vk::Format::D32_SFLOAT,
                    vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
                ),
            )?,
        ];
        let owned = [
            ctx.upload_buffer(
                "pull grid",
                bytemuck::cast_slice(&grid_indices(1, level)),
                vk::BufferUsageFlags::INDEX_BUFFER,
            )?,
            ctx.create_buffer(
                "pull capture",
                vertex_count(patches, level) * 32,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )?,
        ];
        let push = SurfacePush {
            view_proj: glam::Mat4::IDENTITY.to_cols_array_2d(),
            eye: [0.0, 0.0, 10.0, 1.0],
            light: [0.0, 0.0, 1.0, 0.3],
            color: [1.0; 4],
            mode: [0; 4],
        };
        let target = DrawTarget {
            color: images[0].view(),
            depth: images[1].view(),
            extent: vk::Extent2D {
                width: w,
                height: h,
            },
            resolve: None,
        };
        for _ in 0..repeat {
            ctx.one_shot(|cmd| {
                begin_color_target(ctx, cmd, images[0].raw());
                image_barrier(
                    ctx,
                    cmd,
                    images[1].raw(),
                    images[1].range(),
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                    (
                        vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
                            | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
                        vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
                    ),
                    (
                        vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS,
                        vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
                    ),
                );
                profiler.scope(ctx, cmd, 0, "vertex_pull", || {
                    pass.record(
                        ctx,
                        cmd,
                        &target,
                        Some([0.0; 4]),
                        kind,
                        points,
                        patch_points,
                        patches,
                        level,
                        &owned[0],
                        Some(&owned[1]),
                        &push,
                    )
                })
            })?;
            profiler.collect(ctx, 0)?;
        }
        ctx.read_pod(&owned[1])
    }
}
