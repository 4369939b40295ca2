//! `PatchAtPass`: the Gregory surface at arbitrary (patch, u, v) points on the device (glsl/patch_at.comp):
//! position and exact first and second derivatives in f32, for millions of points per dispatch chain; or, built with
//! [`PatchAtPass::new_vertices`] (glsl/patch_at_vertex.comp), surface vertices (position and unit normal):
//! the device surface's ptex layout (`engine::gregory`).
//!
//! Invariants: the pass owns only its pipeline. The control points are the caller's (the f32 rows and their
//! residuals of [`crate::passes::gregory_eval::ControlPoints`], 20 point indices per patch); the queries are
//! already located (patch, local (u, v) and the Jacobian of the ptex-to-patch map, see
//! [`crate::surface::PtexMap::locate_all`]), every patch index in range (checked here on the host).
//! One query in, one [`PatchSample`] (or [`SurfaceVertex`]) out, in order. Batches bind ranges of the query and sample buffers, so
//! neither is limited by `maxStorageBufferRange`. On exit the writes are visible to transfers and shaders.
//!
//! Cost: one invocation per query, 20 gathered points each (the gathers dominate: the same memory-bound
//! pattern the grid kernel avoids by staging a patch in shared memory; queries of one patch that arrive
//! together share cache lines).
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::{compute_writes_to_readers, BufferRange};
use crate::gpu::{shaders, Buffer, Context};
use crate::passes::gregory_eval::{ControlPoints, SurfaceVertex};
use ash::vk;

/// One located query (`Query` in glsl/patch_at.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PatchQuery {
    pub patch: u32,
    pub u: f32,
    pub v: f32,
    pub pad: u32,
    /// d(u', v')/d(u, v) as [J00, J01, J10, J11].
    pub jac: [f32; 4],
}

impl PatchQuery {
    /// The query of a located point ([`crate::surface::PtexMap::locate_all`]), in f32.
    pub fn from_located(&(patch, u, v, j): &crate::surface::Located) -> PatchQuery {
        PatchQuery {
            patch,
            u: u as f32,
            v: v as f32,
            pad: 0,
            jac: [j[0][0], j[0][1], j[1][0], j[1][1]].map(|x| x as f32),
        }
    }
}

/// One result (`Sample` in glsl/patch_at.comp): position (w = 1) and the exact first and second
/// derivatives with respect to the ptex face's (u, v) (w = 0).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PatchSample {
    pub position: [f32; 4],
    pub du: [f32; 4],
    pub dv: [f32; 4],
    pub duu: [f32; 4],
    pub duv: [f32; 4],
    pub dvv: [f32; 4],
}

/// Push constants (`Push` in glsl/patch_at.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    count: u32,
    residual_rows: u32,
    pad: [u32; 2],
}

/// Queries per dispatch: 32 MiB of queries and 96 MiB of samples, under lavapipe's 128 MiB binding limit.
pub const QUERIES_PER_BATCH: u64 = 1 << 20;

/// The evaluation-at-points compute pass.
pub struct PatchAtPass {
    pipeline: ComputePipeline,
    /// Bytes of one result: a [`PatchSample`] or a [`SurfaceVertex`].
    stride: u64,
}

impl PatchAtPass {
    /// Builds the pipeline writing [`PatchSample`]s.
    pub fn new(ctx: &Context) -> Result<Self> {
        Self::build(ctx, false)
    }

    /// Builds the pipeline writing [`SurfaceVertex`]es (position, unit normal of the patch-local partials).
    pub fn new_vertices(ctx: &Context) -> Result<Self> {
        Self::build(ctx, true)
    }

    fn build(ctx: &Context, vertices: bool) -> Result<Self> {
        let mut b = DescriptorSetLayoutBuilder::new();
        for i in 0..4 {
            b = b.storage_buffer(i, vk::ShaderStageFlags::COMPUTE);
        }
        let layout = b.build(ctx, "patch at set")?;
        let (name, code, stride) = if vertices {
            (
                "patch at (vertices)",
                shaders::PATCH_AT_VERTEX_COMP,
                std::mem::size_of::<SurfaceVertex>(),
            )
        } else {
            (
                "patch at",
                shaders::PATCH_AT_COMP,
                std::mem::size_of::<PatchSample>(),
            )
        };
        Ok(PatchAtPass {
            pipeline: ComputePipeline::new(
                ctx,
                name,
                code,
                vec![layout],
                std::mem::size_of::<Push>() as u32,
                64,
            )?,
            stride: stride as u64,
        })
    }

    /// Records the evaluation of `count` queries of `queries` into `samples` (at least `count` of each;
    /// samples or vertices, as the pass was built).
    #[allow(clippy::too_many_arguments)]
    pub fn record<'o>(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        points: ControlPoints<'_>,
        patch_points: &Buffer,
        queries: &Buffer,
        samples: impl Into<BufferRange<'o>>,
        count: u64,
    ) -> Result<()> {
        let samples: BufferRange = samples.into();
        let qs = std::mem::size_of::<PatchQuery>() as u64;
        let ss = self.stride;
        if count * qs > queries.size() || count * ss > samples.size {
            return Err(Error::Invalid(format!(
                "{count} queries do not fit buffers '{}' and '{}'",
                queries.name(),
                samples.name
            )));
        }
        let mut first = 0u64;
        while first < count {
            let n = (count - first).min(QUERIES_PER_BATCH);
            let push = Push {
                count: n as u32,
                residual_rows: points.residual_rows,
                pad: [0; 2],
            };
            let bindings = [
                (0, Binding::Storage(points.buffer.raw())),
                (1, Binding::Storage(patch_points.raw())),
                (
                    2,
                    Binding::StorageRange {
                        buffer: queries.raw(),
                        offset: first * qs,
                        range: n * qs,
                    },
                ),
                (
                    3,
                    Binding::StorageRange {
                        buffer: samples.buffer,
                        offset: samples.offset + first * ss,
                        range: n * ss,
                    },
                ),
            ];
            self.pipeline
                .bind(ctx, cmd, &bindings, bytemuck::bytes_of(&push));
            self.pipeline.dispatch_linear(ctx, cmd, n)?;
            first += n;
        }
        compute_writes_to_readers(ctx, cmd);
        Ok(())
    }
}
