//! Gregory surfaces through the API: building one from a cage ([`Gpu::gregory_surface`]), updating it now
//! (deform, new cage, level: each waits for the device), and, for a renderer that owns the frame, recording
//! the same updates and draws into the caller's command buffers ([`Surface::record`],
//! [`Surface::record_cage`], [`Surface::record_draw`]) with the vertices in gregvox's buffer or in a range
//! of the caller's ([`VertexTarget`]), and the curvature stream beside them
//! ([`Surface::enable_curvature`]).
//!
//! The recording contract (docs/embedding.md):
//! - `record` starts with an execution dependency on every earlier draw, compute and copy of the queue
//!   (so the previous frame's reads of the vertex buffer finish before it is rewritten) and ends with a
//!   memory barrier that makes the vertices (and, in adaptive mode, the indirect commands) visible to
//!   vertex input, index and indirect reads, every shader stage and copies: no barrier is the caller's to
//!   add between `record` and a draw in the same command buffer or a later one on the same queue.
//! - Buffers gregvox hands out ([`SurfaceBuffers`]) are exclusive to the lent queue's family, never change
//!   while the surface lives except through `set_level`, and are last written by `COMPUTE_SHADER` with
//!   `SHADER_STORAGE_WRITE`.
//! - Recording submits nothing and waits for nothing; `set_level`, `set_adaptive` (first call), the
//!   constructors and the immediate updates (`deform`, `set_cage`) submit one-shot work on the queue and
//!   wait for it.
use super::{to_mesh_error, Gpu};
use crate::engine::cage::{surface_topologies, CageTopologies, Layout};
use crate::engine::gregory::Evaluator;
use crate::engine::gregory::GregorySurface;
use crate::error::{Error, Result};
use crate::gpu::resources::{memory_barrier, BufferRange};
use crate::gpu::{Buffer, MemoryLocation};
use crate::mesh::{Cage, Mesh};
pub use crate::passes::adaptive_levels::AdaptiveParams;
use crate::passes::cage_deform::{DeformParams, Deformation};
use crate::passes::gregory_eval::{grid_indices, vertex_count, SurfaceVertex, MAX_LEVEL};
use crate::passes::patch_at::{PatchAtPass, PatchQuery, PatchSample};
use crate::passes::surface_curvature::{SurfaceCurvaturePass, CURVATURE_STRIDE};
use crate::surface::{gregory_host, LimitEvaluator, PtexMap, Tangents};
use ash::vk;
use glam::DVec3;

impl Gpu {
    /// Builds the ACC-2 Gregory surface of a quad cage (non-quad cages are refined once, with a note) at
    /// `level` (1–64), evaluated on the GPU.
    pub fn gregory_surface(&self, cage: &Mesh, level: u32) -> Result<Surface<'_>> {
        self.gregory_surface_with(cage, level, Tangents::OpenSubdiv)
    }

    /// [`Gpu::gregory_surface`] with a choice of edge-point masks.
    pub fn gregory_surface_with(
        &self,
        cage: &Mesh,
        level: u32,
        tangents: Tangents,
    ) -> Result<Surface<'_>> {
        self.tagged_gregory_surface(&Cage::from(cage.clone()), level, tangents)
    }

    /// [`Gpu::gregory_surface_with`] for a tagged cage ([`Cage`]: infinitely sharp creases and corners,
    /// holes, boundary interpolation, as OpenSubdiv's `t` tags give them; see
    /// [`crate::surface::GregoryStencils::from_cage`]).
    pub fn tagged_gregory_surface(
        &self,
        cage: &Cage,
        level: u32,
        tangents: Tangents,
    ) -> Result<Surface<'_>> {
        if !(1..=MAX_LEVEL).contains(&level) {
            return Err(Error::Invalid(format!(
                "--level {level} is out of range: the tessellation level must be between 1 and {MAX_LEVEL}"
            )));
        }
        let t = surface_topologies(cage, tangents, true).map_err(to_mesh_error)?;
        let inner = t.gregory_surface(&self.ctx, level)?;
        let CageTopologies {
            rest,
            note,
            ptex,
            layout,
            uv,
            ..
        } = t;
        let uv = match (uv, layout) {
            (Some(uv), _) => Some(Uv::Patches(Box::new(GregorySurface::new(
                &self.ctx,
                &uv.topology,
                &uv.values,
                level,
            )?))),
            (None, Layout::Ptex { uv: Some(e), .. }) => Some(Uv::ptex(&self.ctx, &inner, e)?),
            _ => None,
        };
        let mut surface = Surface {
            gpu: self,
            inner,
            rest,
            note,
            curvature: None,
            uv,
            ptex,
            at_pass: std::cell::OnceCell::new(),
        };
        surface.evaluate(None)?;
        surface.evaluate_uv()?;
        Ok(surface)
    }
}

/// A range of the caller's buffer to evaluate the surface into: created with `STORAGE_BUFFER` usage (and
/// `VERTEX_BUFFER` to draw from it), `offset` a multiple of the device's
/// `minStorageBufferOffsetAlignment`, at least [`Surface::vertex_bytes`] long. The layout is gregvox's
/// vertex buffer's ([`SurfaceBuffers::vertices`]).
#[derive(Clone, Copy, Debug)]
pub struct VertexTarget {
    pub buffer: vk::Buffer,
    pub offset: u64,
    pub size: u64,
}

/// One recorded update of a surface.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceUpdate {
    /// How the cage moves (from the rest cage, or the cage last set by [`Surface::record_cage`]).
    pub deformation: Deformation,
    /// Time in seconds.
    pub t: f32,
    /// Size of the deformation, a fraction of the cage's box.
    pub amplitude: f32,
    /// Where the vertices go (`None`: the surface's own vertex buffer).
    pub target: Option<VertexTarget>,
}

impl Default for SurfaceUpdate {
    fn default() -> Self {
        SurfaceUpdate {
            deformation: Deformation::None,
            t: 0.0,
            amplitude: 0.0,
            target: None,
        }
    }
}

/// The buffers a renderer draws a surface from (see the module's recording contract).
#[derive(Clone, Copy, Debug)]
pub struct SurfaceBuffers {
    /// Vertices, stride [`SurfaceBuffers::VERTEX_STRIDE`]: position as four f32 (w = 1) at byte 0, unit
    /// normal as four f32 (w = 0) at byte 16; usage `STORAGE_BUFFER | VERTEX_BUFFER | TRANSFER_SRC`.
    pub vertices: vk::Buffer,
    /// Bytes of vertices written by `record`.
    pub vertex_bytes: u64,
    /// u32 triangle list of the uniform grids (usage `INDEX_BUFFER`), counter-clockwise seen from the
    /// normal side.
    pub indices: vk::Buffer,
    /// Indices to draw in uniform mode.
    pub index_count: u32,
    /// Mean and Gaussian curvature (H, K) as two f32 per vertex, in the vertex order (usage
    /// `STORAGE_BUFFER | VERTEX_BUFFER | TRANSFER_SRC`: a second vertex stream), once
    /// [`Surface::enable_curvature`] was called; uniform mode only.
    pub curvature: Option<vk::Buffer>,
    /// UVs (a cage with UVs): a second vertex stream with the vertices' layout (stride
    /// [`SurfaceBuffers::VERTEX_STRIDE`], u and v the first two f32 of each vertex), vertex for vertex:
    /// the uniform grids of the current level, in adaptive mode the grids each `record` computes (the same
    /// slots, so the indirect draws read both streams), and the ptex layout's grids.
    pub uvs: Option<vk::Buffer>,
    /// Adaptive mode: the index buffer of every level's grid and one `VkDrawIndexedIndirectCommand` per
    /// patch (usage `INDIRECT_BUFFER`), `patches` of them, [`SurfaceBuffers::INDIRECT_STRIDE`] apart.
    pub indirect: Option<IndirectDraws>,
}

/// The adaptive mode's draw commands.
#[derive(Clone, Copy, Debug)]
pub struct IndirectDraws {
    pub indices: vk::Buffer,
    pub commands: vk::Buffer,
    pub patches: u32,
}

impl SurfaceBuffers {
    /// Bytes per vertex.
    pub const VERTEX_STRIDE: u32 = std::mem::size_of::<SurfaceVertex>() as u32;
    /// Bytes per indirect draw command.
    pub const INDIRECT_STRIDE: u32 = 20;
}

/// A Gregory surface on the GPU: one bicubic Gregory patch per cage quad, evaluated into a device-local
/// vertex buffer on a (level+1)² grid per patch (vertex `j·(L+1)+i` at (i/L, j/L), u along the face's
/// first edge). A cage whose uniform refinement would pass [`crate::surface::acc2::MAX_REFINED_PATCHES`]
/// (semi-sharp creases on a large cage) gets OpenSubdiv's feature-adaptive patches instead, tessellated
/// with one grid per ptex face (`level` segments per cage edge, [`Surface::ptex_levels`]), crack-free
/// where patches of different depths meet; its note says so.
pub struct Surface<'g> {
    gpu: &'g Gpu,
    inner: GregorySurface,
    rest: Vec<DVec3>,
    note: Option<String>,
    /// The curvature stream `record` also writes, once [`Surface::enable_curvature`] was called.
    curvature: Option<Curvature>,
    /// The UVs (a cage with UVs). They do not move with the cage, so they are evaluated once per level.
    uv: Option<Uv>,
    /// Where each (ptex face, u, v) is among the patches ([`Surface::evaluate_at`]).
    ptex: PtexMap,
    /// The evaluation-at-points pass, built on the first [`Surface::evaluate_at`].
    at_pass: std::cell::OnceCell<PatchAtPass>,
}

/// The surface at (face, u, v) points, from the device ([`Surface::evaluate_at`]): f32, in the order of the
/// points.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceSamples {
    pub position: Vec<[f32; 3]>,
    /// Exact first derivatives with respect to the ptex face's u and v.
    pub du: Vec<[f32; 3]>,
    pub dv: Vec<[f32; 3]>,
    /// Exact second derivatives (S_uu, S_uv, S_vv) with respect to the ptex face's u and v.
    pub duu: Vec<[f32; 3]>,
    pub duv: Vec<[f32; 3]>,
    pub dvv: Vec<[f32; 3]>,
    /// The UVs there, when the surface has UVs.
    pub uv: Option<Vec<[f32; 2]>>,
}

/// Queries uploaded at once by [`Surface::evaluate_at`] (128 bytes each on the device).
const QUERIES_PER_UPLOAD: usize = 1 << 22;

/// The curvature pass and its (H, K) buffer at the surface's current level.
struct Curvature {
    pass: SurfaceCurvaturePass,
    buffer: Buffer,
}

/// The UVs at `at` from the host's UV evaluator (f64, rounded to f32).
fn ptex_uvs(evaluator: &LimitEvaluator, at: &[(u32, f64, f64)]) -> Result<Vec<[f32; 2]>> {
    Ok(evaluator
        .evaluate_uv(at)?
        .iter()
        .map(|t| [t[0] as f32, t[1] as f32])
        .collect())
}

/// A surface's UVs.
enum Uv {
    /// The UV surface on the same patches and grids: its vertices' positions are (u, v, 0).
    Patches(Box<GregorySurface>),
    /// The ptex layout's: the host's UV evaluator, and its values at the grid points (u, v, 0, 1 as
    /// vertices, for renderers), uploaded once per level.
    Ptex {
        evaluator: Box<LimitEvaluator>,
        values: Vec<[f32; 2]>,
        buffer: Buffer,
    },
}

impl Uv {
    /// The ptex layout's UVs at the grid points of `surface` (its current level).
    fn ptex(
        ctx: &crate::gpu::Context,
        surface: &GregorySurface,
        evaluator: Box<LimitEvaluator>,
    ) -> Result<Uv> {
        let (values, buffer) = surface.ptex_uvs(ctx, &evaluator)?.ok_or_else(|| {
            Error::Invalid("UVs of the ptex layout asked of a surface without it".into())
        })?;
        Ok(Uv::Ptex {
            evaluator,
            values,
            buffer,
        })
    }
}

impl Surface<'_> {
    /// The buffers to draw from (valid until the next `set_level`).
    pub fn buffers(&self) -> SurfaceBuffers {
        let e = &self.inner;
        SurfaceBuffers {
            vertices: e.vertices().raw(),
            vertex_bytes: self.vertex_bytes(),
            indices: e.indices().raw(),
            index_count: e.index_count(),
            curvature: self.curvature.as_ref().map(|c| c.buffer.raw()),
            uvs: self.uv.as_ref().map(|u| match u {
                Uv::Patches(s) => s.vertices().raw(),
                Uv::Ptex { buffer, .. } => buffer.raw(),
            }),
            indirect: e.adaptive_draw().map(|(indices, commands)| IndirectDraws {
                indices: indices.raw(),
                commands: commands.raw(),
                patches: e.patch_count(),
            }),
        }
    }

    /// Bytes of vertices an update writes (what a [`VertexTarget`] must hold).
    pub fn vertex_bytes(&self) -> u64 {
        self.inner.vertex_count() * SurfaceBuffers::VERTEX_STRIDE as u64
    }

    /// The deformation parameters of `update`, checked.
    fn deform_params(&self, d: Deformation, t: f32, amplitude: f32) -> Result<DeformParams> {
        if !t.is_finite() || !amplitude.is_finite() {
            return Err(Error::Invalid(format!(
                "deformation time {t} and amplitude {amplitude} must be finite"
            )));
        }
        Ok(DeformParams {
            mode: d,
            t,
            amplitude,
            box_min: self.inner.box_min(),
            box_size: self.inner.box_size(),
        })
    }

    /// Records one update into `cmd`, a command buffer of the caller's in the recording state, outside a
    /// render pass: (deform) → control points → evaluation (per-patch levels and indirect commands too in
    /// adaptive mode), between the barriers of the module's contract. Submits nothing.
    pub fn record(&self, cmd: vk::CommandBuffer, update: &SurfaceUpdate) -> Result<()> {
        let ctx = &self.gpu.ctx;
        let deform = match update.deformation {
            Deformation::None => None,
            d => Some(self.deform_params(d, update.t, update.amplitude)?),
        };
        let target = update.target.map(|t| BufferRange {
            buffer: t.buffer,
            offset: t.offset,
            size: t.size,
            name: "the caller's vertex target",
        });
        memory_barrier(
            ctx,
            cmd,
            (READERS, vk::AccessFlags2::NONE),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::ALL_TRANSFER,
                vk::AccessFlags2::NONE,
            ),
        );
        self.inner
            .record_into(ctx, cmd, deform.as_ref(), None, target)?;
        if let (Some(Uv::Patches(uv)), Some(_)) = (&self.uv, self.inner.adaptive()) {
            // The UVs on this update's adaptive grids, in the same slots as the vertices.
            self.inner.record_adaptive_of(ctx, cmd, uv)?;
        }
        if let Some(c) = &self.curvature {
            if self.inner.adaptive().is_none() {
                let e = &self.inner;
                c.pass.record(
                    ctx,
                    cmd,
                    e.points(),
                    e.patch_points(),
                    e.patch_count(),
                    e.level(),
                    &c.buffer,
                )?;
            }
        }
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                READERS,
                vk::AccessFlags2::VERTEX_ATTRIBUTE_READ
                    | vk::AccessFlags2::INDEX_READ
                    | vk::AccessFlags2::INDIRECT_COMMAND_READ
                    | vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::SHADER_SAMPLED_READ
                    | vk::AccessFlags2::TRANSFER_READ,
            ),
        );
        Ok(())
    }

    /// Records new cage positions (one per cage vertex, in the cage's order) into `cmd`: later updates
    /// start from them (frames in flight keep theirs). Outside a render pass; submits nothing.
    pub fn record_cage(&mut self, cmd: vk::CommandBuffer, positions: &[DVec3]) -> Result<()> {
        check_cage(positions)?;
        self.inner.record_cage_update(&self.gpu.ctx, cmd, positions)
    }

    /// Records the draw of the surface's own vertex buffer into `cmd`, inside the caller's render pass
    /// with a graphics pipeline bound whose vertex input reads binding 0 with the layout of
    /// [`SurfaceBuffers::vertices`] as a triangle list: uniform grids as one indexed draw, adaptive mode
    /// as one indexed indirect draw per patch.
    pub fn record_draw(&self, cmd: vk::CommandBuffer) -> Result<()> {
        let ctx = &self.gpu.ctx;
        if self.inner.adaptive().is_some() {
            return self.inner.record_draw_indirect(ctx, cmd);
        }
        // SAFETY: the caller records inside a render pass with a compatible pipeline bound; the buffers
        // live as long as the surface.
        unsafe {
            ctx.device
                .cmd_bind_vertex_buffers(cmd, 0, &[self.inner.vertices().raw()], &[0]);
            ctx.device.cmd_bind_index_buffer(
                cmd,
                self.inner.indices().raw(),
                0,
                vk::IndexType::UINT32,
            );
            ctx.device
                .cmd_draw_indexed(cmd, self.inner.index_count(), 1, 0, 0, 0);
        }
        Ok(())
    }

    /// From now on `record` also writes the curvature stream ([`SurfaceBuffers::curvature`]: (H, K) per
    /// vertex of the uniform grids, for curvature shading), rebuilt by `set_level`. Builds the pass and
    /// the buffer; submits nothing.
    pub fn enable_curvature(&mut self) -> Result<()> {
        if self.inner.ptex_levels().is_some() {
            return Err(Error::Invalid(
                "curvature shading works on one grid per patch; this surface is tessellated per ptex face \
                 over feature-adaptive patches"
                    .into(),
            ));
        }
        let ctx = &self.gpu.ctx;
        let n = vertex_count(self.inner.patch_count(), self.inner.level());
        self.curvature = Some(Curvature {
            pass: SurfaceCurvaturePass::new(ctx)?,
            buffer: ctx.create_buffer(
                "surface curvature",
                n * CURVATURE_STRIDE,
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::VERTEX_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )?,
        });
        Ok(())
    }

    /// Switches screen-space adaptive tessellation on (`Some`, the current level becoming the maximum) or
    /// off; each later `record` computes the levels for `params`' view. The first call builds the
    /// adaptive passes (one-shot uploads, waited for).
    pub fn set_adaptive(&mut self, params: Option<AdaptiveParams>) -> Result<()> {
        self.inner.set_adaptive(&self.gpu.ctx, params)
    }

    /// Re-evaluates the surface of the rest cage, or of the cage moved by `deform` on the GPU.
    fn evaluate(&mut self, deform: Option<&DeformParams>) -> Result<()> {
        self.inner.evaluate(&self.gpu.ctx, deform, None)
    }

    /// Moves the cage on the GPU by a built-in deformation at time `t` (seconds) with `amplitude` (a fraction
    /// of the cage's size) and re-evaluates the surface; [`Deformation::None`] restores the rest cage.
    pub fn deform(&mut self, mode: Deformation, t: f32, amplitude: f32) -> Result<()> {
        let params = self.deform_params(mode, t, amplitude)?;
        self.evaluate(Some(&params))
    }

    /// Uploads new cage positions (one per cage vertex, in the cage's order) and re-evaluates the surface.
    pub fn set_cage(&mut self, positions: &[DVec3]) -> Result<()> {
        check_cage(positions)?;
        let ctx = &self.gpu.ctx;
        ctx.one_shot(|cmd| self.inner.record_cage_update(ctx, cmd, positions))
    }

    /// Switches the tessellation level (1–64) and re-evaluates the rest cage (and the UVs).
    pub fn set_level(&mut self, level: u32) -> Result<()> {
        self.inner.set_level(&self.gpu.ctx, level)?;
        match self.uv.take() {
            Some(Uv::Patches(mut uv)) => {
                uv.set_level(&self.gpu.ctx, level)?;
                self.uv = Some(Uv::Patches(uv));
            }
            Some(Uv::Ptex { evaluator, .. }) => {
                self.uv = Some(Uv::ptex(&self.gpu.ctx, &self.inner, evaluator)?);
            }
            None => {}
        }
        if self.curvature.is_some() {
            self.enable_curvature()?;
        }
        self.evaluate(None)?;
        self.evaluate_uv()
    }

    fn evaluate_uv(&mut self) -> Result<()> {
        match self.uv.as_mut() {
            Some(Uv::Patches(uv)) => uv.evaluate(&self.gpu.ctx, None, None),
            Some(Uv::Ptex { .. }) => Ok(()),
            None => Ok(()),
        }
    }

    /// The surface at each `(face, u, v)` (OpenSubdiv ptex faces, as [`crate::surface::LimitEvaluator`]
    /// numbers them): position, exact first derivatives and the UVs, in f32, from the control points the
    /// device wrote last (the rest cage, or the last `deform`/`set_cage`). The points are located on the
    /// host (O(isolation level) each, in parallel) and evaluated by the surface's evaluator: the device pass
    /// ([`crate::passes::patch_at`], one invocation each, 4 M at a time), or on CPU devices the host
    /// evaluation of [`Surface::evaluate_at_with`]. Errors name the first bad row, before any device work.
    pub fn evaluate_at(&self, at: &[(u32, f64, f64)]) -> Result<SurfaceSamples> {
        self.evaluate_at_with(at, self.inner.evaluator())
    }

    /// [`Surface::evaluate_at`] by the evaluator given: [`Evaluator::Vulkan`], the device pass (every
    /// device), or [`Evaluator::Host`], the same evaluation on the host from the mapped control points (in
    /// f64 from the f32 rows and their residuals, every core), which only a surface whose device is a CPU
    /// holds (the one `evaluate_at` picks there; tests compare the two).
    pub fn evaluate_at_with(
        &self,
        at: &[(u32, f64, f64)],
        evaluator: Evaluator,
    ) -> Result<SurfaceSamples> {
        let located = self.ptex.locate_all(at)?;
        if evaluator == Evaluator::Host {
            let eval = |s: &GregorySurface| -> Result<Vec<[[f32; 3]; 6]>> {
                Ok(gregory_host::evaluate_at(&s.host_patches()?, &located))
            };
            let pos = eval(&self.inner)?;
            let uv = match &self.uv {
                Some(Uv::Patches(u)) => Some(eval(u)?.iter().map(|s| [s[0][0], s[0][1]]).collect()),
                Some(Uv::Ptex { evaluator, .. }) => Some(ptex_uvs(evaluator, at)?),
                None => None,
            };
            return Ok(SurfaceSamples {
                position: pos.iter().map(|s| s[0]).collect(),
                du: pos.iter().map(|s| s[1]).collect(),
                dv: pos.iter().map(|s| s[2]).collect(),
                duu: pos.iter().map(|s| s[3]).collect(),
                duv: pos.iter().map(|s| s[4]).collect(),
                dvv: pos.iter().map(|s| s[5]).collect(),
                uv,
            });
        }
        let ctx = &self.gpu.ctx;
        let pass = match self.at_pass.get() {
            Some(p) => p,
            None => {
                let p = PatchAtPass::new(ctx)?;
                self.at_pass.get_or_init(|| p)
            }
        };
        let mut out = SurfaceSamples {
            uv: self.uv.as_ref().map(|_| Vec::with_capacity(at.len())),
            ..Default::default()
        };
        for chunk in located.chunks(QUERIES_PER_UPLOAD) {
            let queries: Vec<PatchQuery> = chunk.iter().map(PatchQuery::from_located).collect();
            let n = queries.len() as u64;
            let qbuf = ctx.upload_buffer(
                "patch queries",
                bytemuck::cast_slice(&queries),
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?;
            let run = |s: &GregorySurface| -> Result<Vec<PatchSample>> {
                let samples = ctx.create_buffer(
                    "patch samples",
                    n * std::mem::size_of::<PatchSample>() as u64,
                    vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
                    MemoryLocation::GpuOnly,
                )?;
                ctx.one_shot(|cmd| {
                    pass.record(
                        ctx,
                        cmd,
                        s.control_points(),
                        s.patch_points(),
                        &qbuf,
                        &samples,
                        n,
                    )
                })?;
                ctx.read_pod(&samples)
            };
            for s in run(&self.inner)? {
                out.position
                    .push([s.position[0], s.position[1], s.position[2]]);
                out.du.push([s.du[0], s.du[1], s.du[2]]);
                out.dv.push([s.dv[0], s.dv[1], s.dv[2]]);
                out.duu.push([s.duu[0], s.duu[1], s.duu[2]]);
                out.duv.push([s.duv[0], s.duv[1], s.duv[2]]);
                out.dvv.push([s.dvv[0], s.dvv[1], s.dvv[2]]);
            }
            if let (Some(Uv::Patches(uv)), Some(list)) = (&self.uv, out.uv.as_mut()) {
                list.extend(run(uv)?.iter().map(|s| [s.position[0], s.position[1]]));
            }
        }
        if let Some(Uv::Ptex { evaluator, .. }) = &self.uv {
            out.uv = Some(ptex_uvs(evaluator, at)?);
        }
        Ok(out)
    }

    /// Reads the evaluated positions and unit normals back, grid after grid (patches, or ptex faces).
    pub fn read_vertices(&self) -> Result<Vec<SurfaceVertex>> {
        self.inner.read_vertices(&self.gpu.ctx)
    }

    /// Whether the surface carries UVs (its cage had `vt` on every face).
    pub fn has_uv(&self) -> bool {
        self.uv.is_some()
    }

    /// Reads the UV of every vertex back, in the order of [`Surface::read_vertices`] (uniform grids of the
    /// current level): OpenSubdiv's face-varying limit ([`crate::surface::fvar`]). `None` without UVs.
    pub fn read_uvs(&self) -> Result<Option<Vec<[f32; 2]>>> {
        match &self.uv {
            None => Ok(None),
            Some(Uv::Patches(uv)) => Ok(Some(
                uv.read_vertices(&self.gpu.ctx)?
                    .iter()
                    .map(SurfaceVertex::uv)
                    .collect(),
            )),
            Some(Uv::Ptex { values, .. }) => Ok(Some(values.clone())),
        }
    }

    /// Triangles of the grids (two per grid cell, counter-clockwise seen from the normal side): one grid
    /// per patch, or per ptex face in the ptex layout ([`Surface::ptex_levels`]).
    pub fn indices(&self) -> Vec<u32> {
        match self.inner.ptex_levels() {
            Some(levels) => crate::passes::adaptive_levels::compact_grid_indices(levels),
            None => grid_indices(self.inner.patch_count(), self.inner.level()),
        }
    }

    /// Per ptex grid, its level, when the surface is tessellated per ptex face over feature-adaptive
    /// patches (a cage whose uniform refinement would pass
    /// [`crate::surface::acc2::MAX_REFINED_PATCHES`]); `None` for one grid per patch.
    pub fn ptex_levels(&self) -> Option<&[u32]> {
        self.inner.ptex_levels()
    }

    /// The tessellation level.
    pub fn level(&self) -> u32 {
        self.inner.level()
    }

    /// Patches (one per cage quad).
    pub fn patch_count(&self) -> u32 {
        self.inner.patch_count()
    }

    /// The rest cage's positions (after the Catmull–Clark step for non-quad cages).
    pub fn rest_cage(&self) -> &[DVec3] {
        &self.rest
    }

    /// What was done to the cage before building patches (a refinement step), if anything.
    pub fn note(&self) -> Option<&str> {
        self.note.as_deref()
    }

    /// The engine-level surface, for recording its passes into your own command buffers.
    pub fn engine(&self) -> &GregorySurface {
        &self.inner
    }
}

/// Every stage that may read a surface's buffers (the start barrier waits for them, the end barrier makes
/// the writes visible to them).
const READERS: vk::PipelineStageFlags2 = vk::PipelineStageFlags2::from_raw(
    vk::PipelineStageFlags2::VERTEX_ATTRIBUTE_INPUT.as_raw()
        | vk::PipelineStageFlags2::INDEX_INPUT.as_raw()
        | vk::PipelineStageFlags2::DRAW_INDIRECT.as_raw()
        | vk::PipelineStageFlags2::VERTEX_SHADER.as_raw()
        | vk::PipelineStageFlags2::FRAGMENT_SHADER.as_raw()
        | vk::PipelineStageFlags2::COMPUTE_SHADER.as_raw()
        | vk::PipelineStageFlags2::ALL_TRANSFER.as_raw(),
);

/// One message for the first cage position that is not finite.
fn check_cage(positions: &[DVec3]) -> Result<()> {
    match positions.iter().position(|p| !p.is_finite()) {
        Some(i) => Err(Error::Invalid(format!(
            "cage vertex {} is not finite: {:?}",
            i + 1,
            positions[i]
        ))),
        None => Ok(()),
    }
}
