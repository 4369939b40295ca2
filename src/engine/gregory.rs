//! The Gregory surface on the GPU: cage (rest) → (deform) → cage → (SpMV) control points = W·cage →
//! (evaluate) device-local vertex buffer, which the graphics pipelines and the voxelizer read directly.
//!
//! Invariants:
//! - `GregorySurface` owns every buffer of the chain and the passes; nothing is copied to the host per frame.
//! - The vertex buffer has STORAGE | VERTEX usage and holds `SurfaceVertex` (stride 32, position first), so
//!   `SurfaceDrawPass` draws it and `PeelVoxelizer::new(ctx, 32)` peels it as-is.
//! - `record` starts with a barrier from every earlier reader of the chain's buffers (vertex input, vertex
//!   and fragment shaders, compute, copies — including those of the previous frame still in flight) to the
//!   compute writes, so one set of buffers serves all frames in flight.
//! - Adaptive mode (`set_adaptive`): the current `level` is L_max; patch p's own (L_p+1)² grid fills the start
//!   of its slot of (L_max+1)² vertices (vertex p·(L_max+1)² + j·(L_p+1) + i), boundary rows snapped to the
//!   shared edge levels (crack-free), drawn with one indexed-indirect command per patch
//!   (`record_draw_indirect`). Vertices past a patch's grid in its slot hold stale data and are never drawn.
//! - Shared boundary control points come from shared W rows (same row ⇒ identical bits), and patch edge
//!   vertices are evaluated canonically, so neighbouring patches meet without cracks.
//! - Two evaluators write the vertex buffer ([`Evaluator`]): the Vulkan kernel (every GPU, and every
//!   `record`) and, on CPU devices, the host kernel ([`crate::surface::gregory_host`], from
//!   [`GregorySurface::evaluate`]), which reads the points and writes the vertices through host-visible
//!   mappings of the same buffers after the device's deform + W·cage: the same layout, the same shared-edge
//!   bits, the shader's arithmetic. Adaptive mode always evaluates on the device.
//! - [`GregorySurface::curvature`] follows the same choice: the host curvature kernel on CPU devices, the
//!   curvature pass elsewhere, both from the points the device wrote last.
//! - Ptex layout ([`GregorySurface::new_ptex`]: patches of different depths side by side, the feature-adaptive
//!   layout of [`crate::surface::adaptive`]): the vertex buffer holds one grid per ptex face
//!   ([`crate::surface::ptex_grid::grid_plan`]: `(level + 1)²` vertices a quad, `(level/2 + 1)²` a sub-face
//!   of an n-gon, grid after grid), evaluated by the patch-at pass from queries located once on the host
//!   (patch, local (u, v)); every grid point two faces share carries the first face's query, so both
//!   vertices have the same bits and the mesh closes. W·cage and deformation are the patch layout's.
//!   It is always evaluated on the device; adaptive mode, curvature and the host kernels, which read patch
//!   grids, refuse it by name. Cost: building a level locates every distinct grid point on the host
//!   (O(points · depth), a hash map of the shared ones) and holds its (face, u, v); a level whose vertex
//!   buffer would pass one allocation or u32 indices is refused from the face count before any point is
//!   listed. An update costs W·cage plus 20 gathered control points per vertex (no shared-memory staging:
//!   the grids follow faces, not patches). The attacking input is a deep layout: `catmark_car` at L = 6
//!   (136,419 patches under 1,575 faces, tests/surface_ptex_device.rs).
use crate::error::{Error, Result};
use crate::gpu::profiler::scoped;
use crate::gpu::resources::{compute_writes_to_host, memory_barrier, record_update, BufferRange};
use crate::gpu::{Buffer, Context, MemoryLocation, Profiler};
use crate::mesh::SparseMatrix;
use crate::passes::adaptive_levels::{
    adaptive_indices, AdaptiveBuffers, AdaptiveLevelsPass, AdaptiveParams, DrawCommand,
    EdgeTopology,
};
use crate::passes::cage_deform::{CageDeformPass, DeformParams, Deformation};
use crate::passes::gregory_eval::{
    grid_indices, vertex_count, AdaptiveInputs, ControlPoints, GregoryEvalPass, SurfaceVertex,
    MAX_LEVEL,
};
use crate::passes::patch_at::{PatchAtPass, PatchQuery};
use crate::passes::spmv::{GpuSparse, SpmvPass};
use crate::passes::surface_curvature::{SurfaceCurvaturePass, CURVATURE_STRIDE};
use crate::surface::gregory_host::{self, HostPatches, HostSimd, HostVertex};
use crate::surface::ptex_grid::{grid_plan, grid_point_count};
use crate::surface::PtexMap;
use ash::vk;
use glam::DVec3;

/// The host kernels' view of a host-evaluated surface: the mapped points buffer (vec4 rows, then each
/// row's residual: half of its rows) and the patch layout.
fn mapped_patches<'a>(
    points: &'a Buffer,
    patch_points: &'a [[u32; 20]],
    patch_flags: &'a [u32],
) -> Result<HostPatches<'a>> {
    let rows = (points.size() / 32) as u32;
    let points: &[[f32; 4]] = bytemuck::try_cast_slice(points.mapped()?)
        .map_err(|e| Error::Invalid(format!("gregory points mapping: {e}")))?;
    Ok(HostPatches {
        points,
        residual_rows: rows,
        patch_points,
        patch_flags,
    })
}

/// What the GPU needs to know about a patch layout: the stencil matrix and, per patch, its 20 point rows and
/// canonical-edge flags.
#[derive(Clone, Debug)]
pub struct GregoryTopology {
    /// Control points = `w` · cage (rows: points, columns: cage vertices).
    pub w: SparseMatrix<f64>,
    /// Per patch, the row of `w` of each GREGORY_BASIS point.
    pub patch_points: Vec<[u32; 20]>,
    /// Per patch, bit e set when edge e runs from the higher cage vertex to the lower (see
    /// [`canonical_edge_flags`]).
    pub patch_flags: Vec<u32>,
    /// The interior cage vertices of valence 2 (see [`SingularPoint`]), in vertex order.
    pub singular: Vec<SingularPoint>,
}

/// An interior cage vertex of valence 2: the limit surface has no tangent plane there (OpenSubdiv's limit
/// normal is NaN), so the normals of the patches meeting at it differ (by up to 87° on real cages) and the
/// G1 measure is taken away from it. `vertex` is the cage's vertex index (0-based; a cage refined once keeps
/// its vertices' indices, and refinement makes no new valence-2 vertex).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SingularPoint {
    pub vertex: u32,
    /// The patch corners at the vertex: (patch, corner), corner 0–3 being the face's vertex 0–3, i.e. the
    /// grid samples (0,0), (L,0), (L,L), (0,L).
    pub corners: Vec<(u32, u8)>,
}

/// Canonical-edge flags of quad faces: edges are listed with the patch parameter increasing —
/// e0 = v0→v1, e1 = v1→v2, e2 = v3→v2, e3 = v0→v3 — and bit e is set when that list runs from the higher
/// cage vertex index to the lower.
///
/// ```
/// use gregvox::engine::gregory::canonical_edge_flags;
/// // Face 0 1 2 3: e0 0→1 ok, e1 1→2 ok, e2 3→2 reversed, e3 0→3 ok.
/// assert_eq!(canonical_edge_flags(&[[0, 1, 2, 3]]), [0b0100]);
/// ```
pub fn canonical_edge_flags(quads: &[[u32; 4]]) -> Vec<u32> {
    quads
        .iter()
        .map(|q| {
            let edges = [(q[0], q[1]), (q[1], q[2]), (q[3], q[2]), (q[0], q[3])];
            edges
                .iter()
                .enumerate()
                .fold(0, |f, (e, &(a, b))| f | (((a > b) as u32) << e))
        })
        .collect()
}

pub use super::evaluator::Evaluator;

/// The GPU Gregory surface. See the module invariants.
pub struct GregorySurface {
    spmv: SpmvPass,
    eval: GregoryEvalPass,
    deform: CageDeformPass,
    w: GpuSparse,
    rest: Buffer,
    cage: Buffer,
    points: Buffer,
    patch_points: Buffer,
    patch_flags: Buffer,
    vertices: Buffer,
    indices: Buffer,
    patch_count: u32,
    cage_count: u32,
    level: u32,
    canonical_edges: bool,
    box_min: [f32; 3],
    box_size: [f32; 3],
    adaptive: Option<Adaptive>,
    /// The patch point rows, kept for the adaptive edge topology and the host evaluator.
    patch_rows: Vec<[u32; 20]>,
    /// The canonical-edge flags, kept for the host evaluator.
    patch_flag_list: Vec<u32>,
    evaluator: Evaluator,
    /// The ptex layout, when the surface has one (see the module invariants).
    ptex: Option<PtexLayout>,
}

/// The ptex layout's host side and buffers: where each grid point is, how to grid another level.
struct PtexLayout {
    pass: PatchAtPass,
    /// The cage (its faces and holes make the grids).
    cage: crate::mesh::Cage,
    map: PtexMap,
    /// One located query per vertex.
    queries: Buffer,
    /// Per grid: its level.
    levels: Vec<u32>,
    /// (ptex face, u, v) of every vertex (what the UVs are evaluated at).
    at: Vec<(u32, f64, f64)>,
}

/// What [`PtexLayout::buffers`] makes for one level.
struct PtexLevel {
    queries: Buffer,
    vertices: Buffer,
    indices: Buffer,
    levels: Vec<u32>,
    at: Vec<(u32, f64, f64)>,
}

impl PtexLayout {
    /// The queries, vertex buffer and index buffer of the grids at `level`.
    fn buffers(
        ctx: &Context,
        cage: &crate::mesh::Cage,
        map: &PtexMap,
        level: u32,
        location: MemoryLocation,
    ) -> Result<PtexLevel> {
        // Refused before the host lists a single point: the grid points' count is known from the faces.
        let points = grid_point_count(cage, level);
        let bytes = points.saturating_mul(std::mem::size_of::<SurfaceVertex>() as u64);
        if points > u32::MAX as u64 || bytes > ctx.info.max_memory_allocation_size {
            return Err(Error::Limit {
                what: format!(
                    "{points} grid vertices at level {level} ({} MiB)",
                    bytes >> 20
                ),
                detail: format!(
                    "one vertex buffer of at most {} MiB and u32 indices (lower the level)",
                    ctx.info.max_memory_allocation_size >> 20
                ),
            });
        }
        let plan = grid_plan(cage, map, level)?;
        if plan.at.is_empty() {
            return Err(Error::Invalid(
                "no ptex face to tessellate: every face is a hole".into(),
            ));
        }
        let located = map.locate_all(&plan.unique)?;
        let queries: Vec<PatchQuery> = plan
            .slot
            .iter()
            .map(|&k| PatchQuery::from_located(&located[k as usize]))
            .collect();
        let queries = ctx.upload_buffer(
            "ptex grid queries",
            bytemuck::cast_slice(&queries),
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let vertices = ctx.create_buffer(
            "gregory vertices (ptex grids)",
            plan.at.len() as u64 * std::mem::size_of::<SurfaceVertex>() as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::VERTEX_BUFFER
                | vk::BufferUsageFlags::TRANSFER_SRC,
            location,
        )?;
        let indices = ctx.upload_buffer(
            "gregory indices (ptex grids)",
            bytemuck::cast_slice(&crate::passes::adaptive_levels::compact_grid_indices(
                &plan.levels,
            )),
            vk::BufferUsageFlags::INDEX_BUFFER | vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        Ok(PtexLevel {
            queries,
            vertices,
            indices,
            levels: plan.levels,
            at: plan.at,
        })
    }

    fn vertex_count(&self) -> u64 {
        self.at.len() as u64
    }
}

/// The adaptive mode's passes and buffers (created by `set_adaptive`, kept when it is switched off).
struct Adaptive {
    params: Option<AdaptiveParams>,
    levels_pass: AdaptiveLevelsPass,
    eval: GregoryEvalPass,
    edge_count: u32,
    edge_ids: Buffer,
    edge_offsets: Buffer,
    edge_patches: Buffer,
    edge_levels: Buffer,
    levels: Buffer,
    commands: Buffer,
    /// Grids of levels 1…L_max concatenated (`adaptive_indices(level)`).
    indices: Buffer,
    indices_level: u32,
}

impl Adaptive {
    fn new(ctx: &Context, patch_points: &[[u32; 20]], l_max: u32) -> Result<Self> {
        let topo = EdgeTopology::new(patch_points);
        let patches = patch_points.len() as u64;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
        let gpu = MemoryLocation::GpuOnly;
        // A closed cage always has edges; keep the buffer non-empty for patches without any (impossible
        // with 4 edges per patch, but an empty buffer cannot be created).
        let mut edge_patches = topo.edge_patches.clone();
        edge_patches.push(0);
        Ok(Adaptive {
            params: None,
            levels_pass: AdaptiveLevelsPass::new(ctx)?,
            eval: GregoryEvalPass::new_adaptive(ctx)?,
            edge_count: topo.edge_count(),
            edge_ids: ctx.upload_buffer(
                "edge ids",
                bytemuck::cast_slice(&topo.edge_ids),
                storage,
            )?,
            edge_offsets: ctx.upload_buffer(
                "edge offsets",
                bytemuck::cast_slice(&topo.edge_offsets),
                storage,
            )?,
            edge_patches: ctx.upload_buffer(
                "edge patches",
                bytemuck::cast_slice(&edge_patches),
                storage,
            )?,
            edge_levels: ctx.create_buffer(
                "edge levels",
                topo.edge_count() as u64 * 4,
                storage,
                gpu,
            )?,
            levels: ctx.create_buffer("patch levels", patches * 4, storage, gpu)?,
            commands: ctx.create_buffer(
                "adaptive draw commands",
                patches * std::mem::size_of::<DrawCommand>() as u64,
                storage | vk::BufferUsageFlags::INDIRECT_BUFFER,
                gpu,
            )?,
            indices: Self::index_buffer(ctx, l_max)?,
            indices_level: l_max,
        })
    }

    fn index_buffer(ctx: &Context, l_max: u32) -> Result<Buffer> {
        ctx.upload_buffer(
            "adaptive indices",
            bytemuck::cast_slice(&adaptive_indices(l_max)),
            vk::BufferUsageFlags::INDEX_BUFFER | vk::BufferUsageFlags::STORAGE_BUFFER,
        )
    }
}

/// Every patch's own (L_p+1)² grid, in patch order, from an adaptive vertex buffer of (L_max+1)² slots.
fn compact_grids(all: &[SurfaceVertex], levels: &[u32], l_max: u32) -> Vec<SurfaceVertex> {
    let slot = ((l_max + 1) * (l_max + 1)) as usize;
    let mut out = Vec::new();
    for (p, &l) in levels.iter().enumerate() {
        let n = ((l + 1) * (l + 1)) as usize;
        out.extend_from_slice(&all[p * slot..p * slot + n]);
    }
    out
}

fn vec4s(points: &[DVec3]) -> Vec<[f32; 4]> {
    points
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32, 1.0])
        .collect()
}

impl GregorySurface {
    /// Uploads the layout and the rest cage and creates the buffers for `level`, evaluated by
    /// [`Evaluator::for_device`].
    pub fn new(ctx: &Context, topo: &GregoryTopology, cage: &[DVec3], level: u32) -> Result<Self> {
        Self::with_evaluator(ctx, topo, cage, level, Evaluator::for_device(ctx)?)
    }

    /// [`GregorySurface::new`] with the evaluator chosen by the caller (tests compare the two).
    pub fn with_evaluator(
        ctx: &Context,
        topo: &GregoryTopology,
        cage: &[DVec3],
        level: u32,
        evaluator: Evaluator,
    ) -> Result<Self> {
        Self::build(ctx, topo, cage, level, evaluator, None)
    }

    /// A surface in the ptex layout (see the module invariants): `topo` the patches of any depths (the
    /// feature-adaptive stencils of [`crate::surface::adaptive::AdaptiveStencils`]), `map` where each
    /// (ptex face, u, v) lies among them, `tagged` the cage they were built from, `level` the segments of
    /// every cage edge. Evaluated on the device.
    pub fn new_ptex(
        ctx: &Context,
        topo: &GregoryTopology,
        tagged: &crate::mesh::Cage,
        map: PtexMap,
        level: u32,
    ) -> Result<Self> {
        Self::build(
            ctx,
            topo,
            &tagged.mesh.positions,
            level,
            Evaluator::Vulkan,
            Some((tagged.clone(), map)),
        )
    }

    fn build(
        ctx: &Context,
        topo: &GregoryTopology,
        cage: &[DVec3],
        level: u32,
        evaluator: Evaluator,
        ptex: Option<(crate::mesh::Cage, PtexMap)>,
    ) -> Result<Self> {
        if topo.patch_points.is_empty() {
            return Err(Error::Invalid("no patches to evaluate".into()));
        }
        if cage.len() != topo.w.n_cols as usize {
            return Err(Error::Invalid(format!(
                "the cage has {} vertices but the stencils expect {}",
                cage.len(),
                topo.w.n_cols
            )));
        }
        if topo.patch_flags.len() != topo.patch_points.len() {
            return Err(Error::Invalid(
                "patch flags and patch points differ in length".into(),
            ));
        }
        if let Some(bad) = topo
            .patch_points
            .iter()
            .flatten()
            .find(|&&r| r >= topo.w.n_rows)
        {
            return Err(Error::Invalid(format!(
                "patch point row {bad} is past the {} stencil rows",
                topo.w.n_rows
            )));
        }
        if !(1..=MAX_LEVEL).contains(&level) {
            return Err(Error::Invalid(format!(
                "tessellation level {level} is outside 1…{MAX_LEVEL}"
            )));
        }
        // The points pass sums relative to each row's first cage vertex, which is exact only for affine rows.
        for r in 0..topo.w.n_rows as usize {
            let (a, b) = (topo.w.row_ptr[r] as usize, topo.w.row_ptr[r + 1] as usize);
            let sum: f64 = topo.w.val[a..b].iter().sum();
            if (sum - 1.0).abs() > 1e-9 {
                return Err(Error::Invalid(format!(
                    "stencil row {r} sums to {sum}, not 1: control points must be affine combinations of \
                     the cage"
                )));
            }
        }
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in cage {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a] as f32);
                hi[a] = hi[a].max(p[a] as f32);
            }
        }
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let rw = storage | vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST;
        let (vertices, indices, ptex) = match ptex {
            None => {
                let (v, i) =
                    Self::level_buffers(ctx, topo.patch_points.len() as u32, level, evaluator)?;
                (v, i, None)
            }
            Some((tagged, map)) => {
                let l = PtexLayout::buffers(ctx, &tagged, &map, level, evaluator.write_location())?;
                let layout = PtexLayout {
                    pass: PatchAtPass::new_vertices(ctx)?,
                    cage: tagged,
                    map,
                    queries: l.queries,
                    levels: l.levels,
                    at: l.at,
                };
                (l.vertices, l.indices, Some(layout))
            }
        };
        Ok(GregorySurface {
            spmv: SpmvPass::new_affine_split(ctx)?,
            eval: GregoryEvalPass::new(ctx)?,
            deform: CageDeformPass::new(ctx)?,
            w: GpuSparse::upload(ctx, "gregory W", &topo.w)?,
            rest: ctx.upload_buffer("cage rest", bytemuck::cast_slice(&vec4s(cage)), rw)?,
            cage: ctx.create_buffer("cage", cage.len() as u64 * 16, rw, MemoryLocation::GpuOnly)?,
            // hi + lo: 2 points per row (gregory_points.comp).
            points: ctx.create_buffer(
                "gregory points",
                topo.w.n_rows.max(1) as u64 * 32,
                rw,
                evaluator.read_location(),
            )?,
            patch_points: ctx.upload_buffer(
                "patch points",
                bytemuck::cast_slice(&topo.patch_points),
                storage,
            )?,
            patch_flags: ctx.upload_buffer(
                "patch flags",
                bytemuck::cast_slice(&topo.patch_flags),
                storage,
            )?,
            vertices,
            indices,
            patch_count: topo.patch_points.len() as u32,
            cage_count: cage.len() as u32,
            level,
            canonical_edges: true,
            box_min: lo,
            box_size: [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]],
            adaptive: None,
            patch_rows: topo.patch_points.clone(),
            patch_flag_list: topo.patch_flags.clone(),
            evaluator,
            ptex,
        })
    }

    fn level_buffers(
        ctx: &Context,
        patches: u32,
        level: u32,
        evaluator: Evaluator,
    ) -> Result<(Buffer, Buffer)> {
        let n = vertex_count(patches, level);
        let bytes = n * std::mem::size_of::<SurfaceVertex>() as u64;
        // More than one storage binding holds is fine (the evaluation binds batches of patches); the vertex
        // and index counts must fit u32 indices, the buffers one allocation each (create_buffer checks).
        if n > u32::MAX as u64 {
            return Err(Error::Limit {
                what: format!("{patches} patches at level {level} ({n} vertices)"),
                detail: "u32 vertex indices address at most 4,294,967,295 vertices".into(),
            });
        }
        let vertices = ctx.create_buffer(
            "gregory vertices",
            bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::VERTEX_BUFFER
                | vk::BufferUsageFlags::TRANSFER_SRC,
            evaluator.write_location(),
        )?;
        let idx = grid_indices(patches, level);
        let indices = ctx.upload_buffer(
            "gregory indices",
            bytemuck::cast_slice(&idx),
            vk::BufferUsageFlags::INDEX_BUFFER | vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        Ok((vertices, indices))
    }

    /// Patches (one per cage quad).
    pub fn patch_count(&self) -> u32 {
        self.patch_count
    }

    /// Vertices of the cage (columns of W).
    pub fn cage_count(&self) -> u32 {
        self.cage_count
    }

    /// The tessellation level (the maximum L_max with adaptive tessellation on).
    pub fn level(&self) -> u32 {
        self.level
    }

    /// Whether shared edges are evaluated from one canonical side (bit-identical edge vertices).
    pub fn canonical_edges(&self) -> bool {
        self.canonical_edges
    }

    /// The rest cage's bounding-box minimum (f32, as uploaded).
    pub fn box_min(&self) -> [f32; 3] {
        self.box_min
    }

    /// The rest cage's bounding-box size.
    pub fn box_size(&self) -> [f32; 3] {
        self.box_size
    }

    /// Switches to `level`. The old vertex and index buffers are released through the release queue, so
    /// frames in flight that still draw them stay valid.
    pub fn set_level(&mut self, ctx: &Context, level: u32) -> Result<()> {
        if !(1..=MAX_LEVEL).contains(&level) {
            return Err(Error::Invalid(format!(
                "tessellation level {level} is outside 1…{MAX_LEVEL}"
            )));
        }
        if level == self.level {
            return Ok(());
        }
        if let Some(p) = self.ptex.as_mut() {
            let l =
                PtexLayout::buffers(ctx, &p.cage, &p.map, level, self.evaluator.write_location())?;
            (p.queries, p.levels, p.at) = (l.queries, l.levels, l.at);
            self.level = level;
            self.vertices = l.vertices;
            self.indices = l.indices;
            return Ok(());
        }
        let (vertices, indices) =
            Self::level_buffers(ctx, self.patch_count, level, self.evaluator)?;
        if let Some(a) = self.adaptive.as_mut() {
            a.indices = Adaptive::index_buffer(ctx, level)?;
            a.indices_level = level;
        }
        self.level = level;
        self.vertices = vertices;
        self.indices = indices;
        Ok(())
    }

    /// Switches screen-space adaptive tessellation on (`Some`) or off (`None`). With it on, the current
    /// `level` is the maximum L_max, `record` also computes per-patch levels from `params` (on the GPU, every
    /// frame), and the surface is drawn with [`GregorySurface::record_draw_indirect`]; the OBJ-style uniform
    /// `indices`/`index_count` no longer describe the vertex buffer. The first call builds the adaptive
    /// passes and buffers; later calls only change the view.
    pub fn set_adaptive(&mut self, ctx: &Context, params: Option<AdaptiveParams>) -> Result<()> {
        if let Some(p) = &params {
            p.validate()?;
            if self.ptex.is_some() {
                return Err(Error::Invalid(
                    "screen-space adaptive tessellation works on the uniform patch layout; this surface is \
                     tessellated per ptex face over feature-adaptive patches"
                        .into(),
                ));
            }
        }
        if params.is_some() && self.adaptive.is_none() {
            self.adaptive = Some(Adaptive::new(ctx, &self.patch_rows, self.level)?);
        }
        if let Some(a) = self.adaptive.as_mut() {
            a.params = params;
        }
        Ok(())
    }

    /// The adaptive parameters in use, if adaptive tessellation is on.
    pub fn adaptive(&self) -> Option<&AdaptiveParams> {
        self.adaptive.as_ref().and_then(|a| a.params.as_ref())
    }

    /// The adaptive draw: (index buffer of all levels' grids, one `DrawCommand` per patch). `None` when
    /// adaptive tessellation is off.
    pub fn adaptive_draw(&self) -> Option<(&Buffer, &Buffer)> {
        let a = self.adaptive.as_ref()?;
        a.params.as_ref()?;
        Some((&a.indices, &a.commands))
    }

    /// Reads the per-patch adaptive levels back (tests, `gregvox tessellate --adaptive`).
    pub fn read_levels(&self, ctx: &Context) -> Result<Vec<u32>> {
        let a = self.adaptive_state()?;
        ctx.read_pod(&a.levels)
    }

    /// Reads an adaptive tessellation back compactly: every patch's own (L_p+1)² grid in patch order (rows
    /// of u inner, as in uniform mode), and the levels L_p. Triangles: `compact_grid_indices(&levels)`.
    pub fn read_adaptive_grids(&self, ctx: &Context) -> Result<(Vec<SurfaceVertex>, Vec<u32>)> {
        let levels = self.read_levels(ctx)?;
        let out = compact_grids(&self.read_vertices(ctx)?, &levels, self.level);
        Ok((out, levels))
    }

    /// Records the evaluation of `other` — a surface of the same patch layout and level, such as a cage's UV
    /// surface, from its rest cage — on this surface's adaptive grids into `other`'s vertex buffer (the same
    /// slots, so one indirect draw reads both streams). Record it after this surface's `record` in the same
    /// command buffer or a later one on the queue: it reads the levels that update computed.
    pub fn record_adaptive_of(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        other: &GregorySurface,
    ) -> Result<()> {
        let a = self.adaptive_state()?;
        if other.patch_count != self.patch_count || other.level != self.level {
            return Err(Error::Invalid(format!(
                "a surface of {} patches at level {} cannot be evaluated on the grids of {} patches at level {}",
                other.patch_count, other.level, self.patch_count, self.level
            )));
        }
        other.record_points(ctx, cmd, None, &mut None)?;
        a.eval.record_adaptive(
            ctx,
            cmd,
            other.control_points(),
            &other.patch_points,
            &other.patch_flags,
            other.patch_count,
            self.level,
            &AdaptiveInputs {
                levels: &a.levels,
                edge_ids: &a.edge_ids,
                edge_levels: &a.edge_levels,
            },
            &other.vertices,
        )
    }

    /// Evaluates `other` — a surface of the same patch layout and level, such as a cage's UV surface — on
    /// this surface's adaptive grids (the per-patch and per-edge levels its last update computed; the
    /// caller waited for it) into `other`'s vertex buffer, and reads them back compacted as
    /// [`Self::read_adaptive_grids`] does, so vertex k of both lists is the same (patch, u, v).
    pub fn read_adaptive_grids_of(
        &self,
        ctx: &Context,
        other: &GregorySurface,
    ) -> Result<Vec<SurfaceVertex>> {
        self.adaptive_state()?;
        ctx.one_shot(|cmd| self.record_adaptive_of(ctx, cmd, other))?;
        let levels = self.read_levels(ctx)?;
        Ok(compact_grids(
            &other.read_vertices(ctx)?,
            &levels,
            self.level,
        ))
    }

    /// Reads the per-edge adaptive levels and each patch edge's edge id back (tests).
    pub fn read_edge_levels(&self, ctx: &Context) -> Result<(Vec<u32>, Vec<u32>)> {
        let a = self.adaptive_state()?;
        Ok((ctx.read_pod(&a.edge_levels)?, ctx.read_pod(&a.edge_ids)?))
    }

    /// Reads the adaptive draw commands back (tests).
    pub fn read_draw_commands(&self, ctx: &Context) -> Result<Vec<DrawCommand>> {
        let a = self.adaptive_state()?;
        ctx.read_pod(&a.commands)
    }

    fn adaptive_state(&self) -> Result<&Adaptive> {
        match &self.adaptive {
            Some(a) if a.params.is_some() => Ok(a),
            _ => Err(Error::Invalid("adaptive tessellation is off".into())),
        }
    }

    /// Records the adaptive draw into a bound graphics pipeline whose vertex input reads `vertices()` at
    /// binding 0: binds the all-levels index buffer and issues one `vkCmdDrawIndexedIndirect` per patch
    /// (drawCount 1: the context does not enable multiDrawIndirect, so one multi-draw is not allowed).
    pub fn record_draw_indirect(&self, ctx: &Context, cmd: vk::CommandBuffer) -> Result<()> {
        let a = self.adaptive_state()?;
        let stride = std::mem::size_of::<DrawCommand>() as u64;
        // SAFETY: recording inside a render pass with a compatible pipeline bound; the buffers are alive.
        unsafe {
            ctx.device
                .cmd_bind_vertex_buffers(cmd, 0, &[self.vertices.raw()], &[0]);
            ctx.device
                .cmd_bind_index_buffer(cmd, a.indices.raw(), 0, vk::IndexType::UINT32);
            for p in 0..self.patch_count as u64 {
                ctx.device.cmd_draw_indexed_indirect(
                    cmd,
                    a.commands.raw(),
                    p * stride,
                    1,
                    stride as u32,
                );
            }
        }
        Ok(())
    }

    /// The device-local vertex buffer (stride 32: position, normal).
    pub fn vertices(&self) -> &Buffer {
        &self.vertices
    }

    /// The static index buffer of the current level (u32, triangle list).
    pub fn indices(&self) -> &Buffer {
        &self.indices
    }

    /// Number of indices of the current level.
    pub fn index_count(&self) -> u32 {
        match &self.ptex {
            Some(p) => p.levels.iter().map(|&l| 6 * l * l).sum(),
            None => self.patch_count * self.level * self.level * 6,
        }
    }

    /// Number of vertices of the current level (what [`Self::vertices`] holds; in adaptive mode the
    /// slots of every patch).
    pub fn vertex_count(&self) -> u64 {
        match &self.ptex {
            Some(p) => p.vertex_count(),
            None => vertex_count(self.patch_count, self.level),
        }
    }

    /// The UVs of the ptex layout's vertices at the current level, from the host's f64 UV evaluator
    /// (`uv`, built for the same cage): the values, and a vertex stream for renderers (u, v, 0, 1 as
    /// [`SurfaceVertex`] positions, the layout of a UV surface's vertices). UVs do not deform, so this is
    /// made once per level. `None` without the ptex layout.
    pub fn ptex_uvs(
        &self,
        ctx: &Context,
        uv: &crate::surface::LimitEvaluator,
    ) -> Result<Option<(Vec<[f32; 2]>, Buffer)>> {
        let Some(at) = self.ptex_grid_points() else {
            return Ok(None);
        };
        let values: Vec<[f32; 2]> = uv
            .evaluate_uv(at)?
            .iter()
            .map(|t| [t[0] as f32, t[1] as f32])
            .collect();
        let vertices: Vec<SurfaceVertex> = values
            .iter()
            .map(|t| SurfaceVertex {
                position: [t[0], t[1], 0.0, 1.0],
                normal: [0.0, 0.0, 1.0, 0.0],
            })
            .collect();
        let buffer = ctx.upload_buffer(
            "surface uvs (ptex grids)",
            bytemuck::cast_slice(&vertices),
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::VERTEX_BUFFER,
        )?;
        Ok(Some((values, buffer)))
    }

    /// The (ptex face, u, v) of every vertex of the current level, in order, when the surface has the ptex
    /// layout ([`Self::new_ptex`]; `None` otherwise): what a caller evaluates beside the vertices (UVs).
    pub fn ptex_grid_points(&self) -> Option<&[(u32, f64, f64)]> {
        self.ptex.as_ref().map(|p| p.at.as_slice())
    }

    /// Per ptex grid, its level, when the surface has the ptex layout ([`Self::new_ptex`]): the vertices
    /// are these grids, `(level + 1)²` each, in order (triangles:
    /// [`crate::passes::adaptive_levels::compact_grid_indices`]).
    pub fn ptex_levels(&self) -> Option<&[u32]> {
        self.ptex.as_ref().map(|p| p.levels.as_slice())
    }

    /// The control points buffer: a vec4 point per W row (w = 1), then each row's residual (see
    /// [`Self::control_points`]); readers wanting plain f32 points use the first rows.
    pub fn points(&self) -> &Buffer {
        &self.points
    }

    /// The canonical-edge flags per patch (u32, see [`canonical_edge_flags`]).
    pub fn patch_flags(&self) -> &Buffer {
        &self.patch_flags
    }

    /// The 20 control point indices per patch (u32, GREGORY_BASIS order), e.g. for the demo's curvature pass.
    pub fn patch_points(&self) -> &Buffer {
        &self.patch_points
    }

    /// The evaluator [`GregorySurface::evaluate`] uses (`record` always records the Vulkan kernel).
    pub fn evaluator(&self) -> Evaluator {
        self.evaluator
    }

    /// Updates the surface now: (deform) → W·cage on the device, then the evaluation by
    /// [`GregorySurface::evaluator`] (the host kernel reads the points and writes the vertices through their
    /// mappings; adaptive mode always evaluates on the device), and waits. With a profiler, its slot 0 is
    /// collected and the host evaluation joins the statistics as "gregory_eval (host)".
    pub fn evaluate(
        &mut self,
        ctx: &Context,
        deform: Option<&DeformParams>,
        mut profiler: Option<&mut Profiler>,
    ) -> Result<()> {
        if self.evaluator == Evaluator::Vulkan || self.adaptive().is_some() {
            ctx.one_shot(|cmd| {
                self.record(ctx, cmd, deform, profiler.as_mut().map(|p| (&mut **p, 0)))
            })?;
            if let Some(p) = profiler {
                p.collect(ctx, 0)?;
            }
            return Ok(());
        }
        ctx.one_shot(|cmd| {
            self.record_points(
                ctx,
                cmd,
                deform,
                &mut profiler.as_mut().map(|p| (&mut **p, 0)),
            )?;
            compute_writes_to_host(ctx, cmd);
            Ok(())
        })?;
        if let Some(p) = profiler.as_mut() {
            p.collect(ctx, 0)?;
        }
        let t0 = std::time::Instant::now();
        self.evaluate_host()?;
        if let Some(p) = profiler {
            p.record_host("gregory_eval (host)", t0.elapsed().as_secs_f64() * 1e3);
        }
        Ok(())
    }

    /// The control points the device wrote last, read through their mapping (only with [`Evaluator::Host`],
    /// whose points buffer is host-visible; the caller waited for that submission).
    pub fn host_patches(&self) -> Result<HostPatches<'_>> {
        if self.evaluator != Evaluator::Host {
            return Err(Error::Invalid(
                "the control points are mapped only on a surface created with Evaluator::Host"
                    .into(),
            ));
        }
        mapped_patches(&self.points, &self.patch_rows, &self.patch_flag_list)
    }

    /// The host evaluation alone: reads the control points the device wrote last (the caller waited for
    /// that submission) and writes every vertex. Only with [`Evaluator::Host`], whose buffers are mapped;
    /// the next submission that reads the vertices sees the writes (host-coherent memory).
    pub fn evaluate_host(&mut self) -> Result<()> {
        if self.evaluator != Evaluator::Host {
            return Err(Error::Invalid(
                "the host evaluation needs a surface created with Evaluator::Host".into(),
            ));
        }
        let patches = mapped_patches(&self.points, &self.patch_rows, &self.patch_flag_list)?;
        let vertices: &mut [HostVertex] = bytemuck::try_cast_slice_mut(self.vertices.mapped_mut()?)
            .map_err(|e| Error::Invalid(format!("gregory vertices mapping: {e}")))?;
        gregory_host::evaluate(
            &patches,
            self.level,
            self.canonical_edges,
            HostSimd::Auto,
            vertices,
        )
    }

    /// Mean and Gaussian curvature (H, K) at every vertex of the current (uniform) level, in the vertex
    /// order, from the control points the device wrote last (the caller waited for that submission, e.g.
    /// [`GregorySurface::evaluate`]), by the surface's evaluator: with [`Evaluator::Host`] the host
    /// curvature kernel ([`gregory_host::curvature`]) on the mapped points; with [`Evaluator::Vulkan`] the
    /// curvature pass (glsl/surface_curvature.comp, built for this call) into a device buffer, read back.
    /// Singular vertices get (0, 0). Not in adaptive mode (its grids differ per patch).
    pub fn curvature(&self, ctx: &Context) -> Result<Vec<[f32; 2]>> {
        if self.adaptive().is_some() {
            return Err(Error::Invalid(
                "curvature is computed on uniform grids only (adaptive tessellation is on)".into(),
            ));
        }
        if self.ptex.is_some() {
            return Err(Error::Invalid(
                "curvature is computed on uniform patch grids only (this surface is tessellated per ptex \
                 face over feature-adaptive patches)"
                    .into(),
            ));
        }
        let n = vertex_count(self.patch_count, self.level);
        if self.evaluator == Evaluator::Host {
            let patches = mapped_patches(&self.points, &self.patch_rows, &self.patch_flag_list)?;
            let mut out = vec![[0.0f32; 2]; n as usize];
            gregory_host::curvature(&patches, self.level, HostSimd::Auto, &mut out)?;
            return Ok(out);
        }
        let pass = SurfaceCurvaturePass::new(ctx)?;
        let out = ctx.create_buffer(
            "surface curvature (read back)",
            (n * CURVATURE_STRIDE).max(CURVATURE_STRIDE),
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        ctx.one_shot(|cmd| {
            pass.record(
                ctx,
                cmd,
                &self.points,
                &self.patch_points,
                self.patch_count,
                self.level,
                &out,
            )
        })?;
        let mut hk: Vec<[f32; 2]> = ctx.read_pod(&out)?;
        hk.truncate(n as usize);
        Ok(hk)
    }

    /// Records the barrier from earlier readers, the deformation (if any) and W·cage.
    fn record_points(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        deform: Option<&DeformParams>,
        profiler: &mut Option<(&mut Profiler, usize)>,
    ) -> Result<()> {
        // Earlier readers (this or the previous frame's draw, peel, copies) before this frame's writes.
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::VERTEX_ATTRIBUTE_INPUT
                    | vk::PipelineStageFlags2::VERTEX_SHADER
                    | vk::PipelineStageFlags2::FRAGMENT_SHADER
                    | vk::PipelineStageFlags2::COMPUTE_SHADER
                    | vk::PipelineStageFlags2::DRAW_INDIRECT
                    | vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::NONE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        );
        let mut scope =
            |name: &str, f: &mut dyn FnMut() -> Result<()>| scoped(ctx, cmd, profiler, name, f);
        let source = match deform {
            Some(d) if d.mode != Deformation::None => {
                scope("cage deform", &mut || {
                    self.deform
                        .record(ctx, cmd, &self.rest, &self.cage, self.cage_count, d)
                })?;
                &self.cage
            }
            _ => &self.rest,
        };
        scope("gregory_points", &mut || {
            self.spmv.record(ctx, cmd, &self.w, source, &self.points)
        })
    }

    /// Records a whole update: (deform) → W·cage → evaluate with the Vulkan kernel. `deform` = None
    /// evaluates the rest cage.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        deform: Option<&DeformParams>,
        profiler: Option<(&mut Profiler, usize)>,
    ) -> Result<()> {
        self.record_into(ctx, cmd, deform, profiler, None)
    }

    /// [`Self::record`], writing the vertices into `target` (the same layout as [`Self::vertices`]: a
    /// (level+1)² grid per patch, or an (l_max+1)² slot per patch in adaptive mode) instead of the
    /// surface's own buffer when given.
    pub fn record_into(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        deform: Option<&DeformParams>,
        mut profiler: Option<(&mut Profiler, usize)>,
        target: Option<BufferRange>,
    ) -> Result<()> {
        let out = target.unwrap_or_else(|| (&self.vertices).into());
        self.record_points(ctx, cmd, deform, &mut profiler)?;
        let mut scope = |name: &str, f: &mut dyn FnMut() -> Result<()>| {
            scoped(ctx, cmd, &mut profiler, name, f)
        };
        if let Some(p) = self.ptex.as_ref() {
            return scope("gregory_eval", &mut || {
                p.pass.record(
                    ctx,
                    cmd,
                    self.control_points(),
                    &self.patch_points,
                    &p.queries,
                    out,
                    p.vertex_count(),
                )
            });
        }
        if let Some(a) = self.adaptive.as_ref() {
            if let Some(params) = a.params.as_ref() {
                debug_assert_eq!(a.indices_level, self.level);
                scope("adaptive_levels", &mut || {
                    a.levels_pass.record(
                        ctx,
                        cmd,
                        &AdaptiveBuffers {
                            points: &self.points,
                            patch_points: &self.patch_points,
                            levels: &a.levels,
                            commands: &a.commands,
                            edge_offsets: &a.edge_offsets,
                            edge_patches: &a.edge_patches,
                            edge_levels: &a.edge_levels,
                        },
                        params,
                        (self.patch_count, a.edge_count, self.level),
                    )
                })?;
                return scope("gregory_eval", &mut || {
                    a.eval.record_adaptive(
                        ctx,
                        cmd,
                        self.control_points(),
                        &self.patch_points,
                        &self.patch_flags,
                        self.patch_count,
                        self.level,
                        &AdaptiveInputs {
                            levels: &a.levels,
                            edge_ids: &a.edge_ids,
                            edge_levels: &a.edge_levels,
                        },
                        out,
                    )
                });
            }
        }
        scope("gregory_eval", &mut || {
            self.eval.record(
                ctx,
                cmd,
                self.control_points(),
                &self.patch_points,
                &self.patch_flags,
                self.patch_count,
                self.level,
                self.canonical_edges,
                out,
            )
        })
    }

    /// Replaces the rest cage (user-moved vertices) from the command buffer, so frames in flight keep the old
    /// one: `vkCmdUpdateBuffer` in chunks of 64 KiB.
    pub fn record_cage_update(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        cage: &[DVec3],
    ) -> Result<()> {
        if cage.len() != self.cage_count as usize {
            return Err(Error::Invalid(format!(
                "{} cage vertices given, {} expected",
                cage.len(),
                self.cage_count
            )));
        }
        record_update(ctx, cmd, &self.rest, bytemuck::cast_slice(&vec4s(cage)))
    }

    /// Reads the evaluated vertices back (tests, `gregvox tessellate`).
    pub fn read_vertices(&self, ctx: &Context) -> Result<Vec<SurfaceVertex>> {
        ctx.read_pod(&self.vertices)
    }

    /// Reads the control points back (the f32 points; their residuals are [`Self::read_residuals`]).
    pub fn read_points(&self, ctx: &Context) -> Result<Vec<[f32; 4]>> {
        let mut all: Vec<[f32; 4]> = ctx.read_pod(&self.points)?;
        all.truncate(self.point_rows() as usize);
        Ok(all)
    }

    /// Reads the control points' f32 residuals back: point r is `read_points()[r] + read_residuals()[r]`.
    pub fn read_residuals(&self, ctx: &Context) -> Result<Vec<[f32; 4]>> {
        let all: Vec<[f32; 4]> = ctx.read_pod(&self.points)?;
        Ok(all[self.point_rows() as usize..].to_vec())
    }

    fn point_rows(&self) -> u32 {
        self.w.rows.max(1)
    }

    /// The control points as the evaluation reads them: f32 points in rows `0..rows`, residuals after.
    pub fn control_points(&self) -> ControlPoints<'_> {
        ControlPoints {
            buffer: &self.points,
            residual_rows: self.point_rows(),
        }
    }
}

/// The bounding box of a surface's evaluated vertices, reduced on the GPU (six numbers read back): the bounds
/// pass and its result buffer, for the voxelizers that place a grid around a surface that never leaves the
/// device.
pub struct SurfaceBounds {
    pass: crate::passes::bounds::BoundsPass,
    result: Buffer,
}

impl SurfaceBounds {
    /// Builds the pass and its 24-byte result buffer.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(SurfaceBounds {
            pass: crate::passes::bounds::BoundsPass::new(ctx)?,
            result: ctx.create_buffer(
                "surface bounds",
                24,
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )?,
        })
    }

    /// Records the reduction over `surface`'s vertex buffer (after its evaluation in the same command buffer).
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        surface: &GregorySurface,
    ) -> Result<()> {
        let count = surface.vertex_count() as u32;
        let stride = std::mem::size_of::<SurfaceVertex>() as u32;
        self.pass
            .record(ctx, cmd, surface.vertices(), count, stride, &self.result)
    }

    /// The (min, max) corners recorded last.
    pub fn read(&self, ctx: &Context) -> Result<([f32; 3], [f32; 3])> {
        use crate::passes::bounds::decode;
        let w = ctx.read_pod::<u32>(&self.result)?;
        Ok((
            [decode(w[0]), decode(w[1]), decode(w[2])],
            [decode(w[3]), decode(w[4]), decode(w[5])],
        ))
    }
}
