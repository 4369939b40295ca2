//! `PatchPullPass`: the vertex-pull evaluation path (the Beziex seed's instanced grid): one instance per patch,
//! a static index buffer over one (L+1)² grid, and a vertex shader that evaluates Gregory or Beziex patches
//! straight from storage buffers (glsl/include/patch_pull_body.glsl), shaded by glsl/surface.frag.
//!
//! Invariants: the pass owns its pipeline(s); patch buffers, index buffer and targets are the caller's. Targets
//! as in `SurfaceDrawPass` (color in `COLOR_ATTACHMENT_OPTIMAL`, depth in `DEPTH_ATTACHMENT_OPTIMAL`, unchanged
//! on exit). The capture variant (needs `vertexPipelineStoresAndAtomics`) also writes every evaluated vertex to
//! a buffer in the compute path's order; on exit those writes are visible to transfers.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, DescriptorSetLayoutBuilder, GraphicsDesc, GraphicsPipeline};
use crate::gpu::resources::memory_barrier;
use crate::gpu::{shaders, Buffer, Context};
use crate::passes::draw::ColorTarget;
use crate::passes::draw::{begin_color_depth, DrawTarget};
use crate::passes::gregory_eval::ControlPoints;
use crate::passes::surface_draw::SurfacePush;
use ash::vk;

/// Which patch type the vertex shader evaluates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PatchKind {
    /// 20 point indices per patch into the points buffer.
    Gregory = 0,
    /// 56 points per patch (`BeziexPatch::to_gpu`).
    Beziex = 1,
}

/// The vertex-pull pass.
pub struct PatchPullPass {
    pipeline: GraphicsPipeline,
    capture: bool,
}

impl PatchPullPass {
    /// Builds the pipeline; `capture` selects the variant that also stores every evaluated vertex.
    pub fn new(
        ctx: &Context,
        color: impl Into<ColorTarget>,
        depth: vk::Format,
        capture: bool,
    ) -> Result<Self> {
        let color: ColorTarget = color.into();
        if capture && !ctx.info.features.vertex_pipeline_stores_and_atomics {
            return Err(Error::Limit {
                what: "capturing vertex-pull output".into(),
                detail: "the device lacks vertexPipelineStoresAndAtomics".into(),
            });
        }
        let stage = vk::ShaderStageFlags::VERTEX;
        let mut b = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, stage)
            .storage_buffer(1, stage);
        if capture {
            b = b.storage_buffer(2, stage);
        }
        let layout = b.build(ctx, "patch pull set")?;
        let vs = if capture {
            shaders::PATCH_PULL_CAPTURE_VERT
        } else {
            shaders::PATCH_PULL_VERT
        };
        let mut desc = GraphicsDesc::new(vs, shaders::SURFACE_FRAG, color.format, depth);
        desc.set_layouts = vec![layout];
        desc.push_constant_bytes = std::mem::size_of::<SurfacePush>() as u32;
        desc.push_constant_stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        desc.samples = color.samples;
        Ok(PatchPullPass {
            pipeline: GraphicsPipeline::new(ctx, "patch pull", desc)?,
            capture,
        })
    }

    /// Records the instanced draw of `patch_count` patches at `level` (`grid_indices` is `grid_indices(1, L)`;
    /// for Beziex `patch_points` is unused but must be a valid buffer, and `points` has no residuals).
    /// `push.mode` gets the level, the kind and the residual rows.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        target: &DrawTarget,
        clear: Option<[f32; 4]>,
        kind: PatchKind,
        points: ControlPoints,
        patch_points: &Buffer,
        patch_count: u32,
        level: u32,
        grid_indices: &Buffer,
        capture: Option<&Buffer>,
        push: &SurfacePush,
    ) -> Result<()> {
        if self.capture != capture.is_some() {
            return Err(Error::Invalid(
                "patch pull: capture buffer given to the wrong pipeline variant".into(),
            ));
        }

        if let Some(c) = capture {
            // The capture is one storage binding (the draw itself has no such limit).
            let bytes = crate::passes::gregory_eval::vertex_count(patch_count, level)
                * std::mem::size_of::<crate::passes::gregory_eval::SurfaceVertex>() as u64;
            let max = ctx.limits.max_storage_buffer_range as u64;
            if bytes > max {
                return Err(Error::Limit {
                    what: format!("capturing {} MiB of vertex-pull output", bytes >> 20),
                    detail: format!("one storage binding holds at most {} MiB", max >> 20),
                });
            }
            if bytes > c.size() {
                return Err(Error::Invalid(format!(
                    "patch pull: capture buffer '{}' holds {} B, {bytes} B needed",
                    c.name(),
                    c.size()
                )));
            }
        }
        let mut p = *push;
        p.mode[1] = level;
        p.mode[2] = kind as u32;
        // mode.w (unused by surface.frag): the Gregory points' residual rows, as in the compute path.
        p.mode[3] = match kind {
            PatchKind::Gregory => points.residual_rows,
            PatchKind::Beziex => 0,
        };
        let mut bindings = vec![
            (0, Binding::Storage(points.buffer.raw())),
            (1, Binding::Storage(patch_points.raw())),
        ];
        if let Some(c) = capture {
            bindings.push((2, Binding::Storage(c.raw())));
        }
        begin_color_depth(ctx, cmd, target, clear);
        self.pipeline
            .bind(ctx, cmd, &bindings, bytemuck::bytes_of(&p), target.extent);
        // SAFETY: inside the render pass with the pipeline bound; the index buffer covers one grid.
        unsafe {
            ctx.device
                .cmd_bind_index_buffer(cmd, grid_indices.raw(), 0, vk::IndexType::UINT32);
            ctx.device
                .cmd_draw_indexed(cmd, level * level * 6, patch_count, 0, 0, 0);
        }
        ctx.cmd_end_rendering(cmd);
        if capture.is_some() {
            memory_barrier(
                ctx,
                cmd,
                (
                    vk::PipelineStageFlags2::VERTEX_SHADER,
                    vk::AccessFlags2::SHADER_STORAGE_WRITE,
                ),
                (
                    vk::PipelineStageFlags2::COPY,
                    vk::AccessFlags2::TRANSFER_READ,
                ),
            );
        }
        Ok(())
    }
}
