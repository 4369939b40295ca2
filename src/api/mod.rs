//! The high-level API: one call per operation (as libigl does), over the engine, the passes and the GPU
//! foundation. The CLI, the demo and the bench are clients of it; so is a Rust user.
//!
//! Invariants:
//! - Every policy a user would otherwise have to re-derive lives here once: fan triangulation and cleaning
//!   of the input, the grid frame, open-mesh detection and the 3-axis vote, the cheapest peeling axis, the
//!   device-memory check, the cage topology of a quad cage (one Catmull–Clark step for non-quad cages).
//! - Nothing here needs cleanup by the caller: [`Gpu`], [`Surface`] and everything they create release their
//!   GPU objects when dropped (`gpu::lifetime`).
//! - Errors are [`crate::Error`] values that name the input and the problem; nothing panics on bad input.
use crate::engine::voxelize::checkpoint;
use crate::engine::voxelize::{
    memory_estimate, voxelize_gregory_surface, voxelize_surface_gpu, AbufferVoxelizer,
    GpuTriangles, GpuVoxelizer, PeelVoxelizer,
};
use crate::error::{Error, Result};
use crate::gpu::Context;
pub use crate::gpu::{
    ContextDesc, DeviceInfo, DeviceRequirements, ExternalDevice, ExternalRecording, Profiler,
    Validation,
};
use crate::voxel::cpu::voxelize_cpu;
use crate::voxel::gwn::{self, GwnParams, Inside, Proxy};
use crate::voxel::mesh::{CleanReport, TriMesh};
use std::path::Path;

pub mod batch;
pub mod levelset;
pub mod query;
pub mod simplify;
pub mod surface;
pub mod tessellate;

pub use crate::engine::voxelize::{Deadline, ProgressFn, DEFAULT_MAX_LAYERS};
pub use crate::mesh::{
    BoundaryInterpolation, Cage, CornerTag, Crease, Mesh, MeshMatrix, SubdivTags, TopologyReport,
};
pub use crate::passes::cage_deform::Deformation;
pub use crate::passes::gregory_eval::SurfaceVertex as Vertex;
pub use crate::surface::{LimitEvaluator, LimitSample, Tangents};
pub use crate::voxel::cpu::FillRule;
pub use crate::voxel::export::SaveOptions;
pub use crate::voxel::grid::{Axis, Bounds, GridFrame, GridSize, GridSpec, VoxelGrid};
pub use crate::voxel::gwn::GwnStats;
pub use crate::voxel::surface::Fill;
pub use query::{MeshQuery, QueryOptions, SdfSign};
pub use simplify::{
    simplify, simplify_lod, Placement, SimplifiedMesh, SimplifyOptions, SimplifyReport,
};
pub use surface::{
    AdaptiveParams, IndirectDraws, Surface, SurfaceBuffers, SurfaceUpdate, VertexTarget,
};

/// Largest number of voxels along any axis (2048³ bits = 1 GiB).
pub const MAX_RES: u32 = crate::voxel::grid::MAX_DIM;

/// Loads a mesh file: OBJ, STL (ASCII or binary), PLY (ASCII or binary), OFF, glTF 2.0 or GLB, detected
/// from the content, else the extension ([`crate::mesh::load_mesh_file`]; STL and glTF are welded exactly).
/// Errors name the file, then the line (text) or byte offset (binary data), then the problem.
pub fn load_mesh(path: impl AsRef<Path>) -> Result<Mesh> {
    let path = path.as_ref();
    // A Beziex model is patches, not a mesh: say so, rather than what its gzip bytes look like to a mesh
    // parser ("binary data").
    if tessellate::is_beziex(path) && path.is_file() {
        return Err(Error::parse(
            path,
            "a Beziex patch model, not a mesh (tessellate it first: gregvox tessellate MODEL --out MESH.obj)",
        ));
    }
    crate::mesh::load_mesh_file(path)
}

/// Loads a subdivision cage: an OBJ with its OpenSubdiv tag lines (`t crease`, `t corner`, `t hole`,
/// `t interpolateboundary`, …), any other mesh format untagged. A tag gregvox does not know is an error
/// naming it and its line.
pub fn load_cage(path: impl AsRef<Path>) -> Result<Cage> {
    let path = path.as_ref();
    if tessellate::is_beziex(path) && path.is_file() {
        return Err(Error::parse(
            path,
            "a Beziex patch model, not a cage (tessellate it directly: gregvox tessellate MODEL --out MESH.obj)",
        ));
    }
    crate::mesh::load_cage_file(path)
}

/// The topology report of a mesh, computed from its mesh matrices (`gregvox mesh --json`).
pub fn topology(mesh: &Mesh) -> TopologyReport {
    MeshMatrix::from_mesh(mesh).report()
}

/// Subdivision schemes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Scheme {
    /// Catmull–Clark (any polygon mesh; boundaries with the edge-only rule).
    CatmullClark,
    /// Loop with Warren's β (triangles only; = libigl `igl::loop`).
    LoopWarren,
    /// Loop with Loop's original β (triangles only; = trimesh `subdivide_loop`).
    Loop,
}

/// Subdivides `mesh` `levels` times, each level one sparse matrix applied to the positions. Refuses, before
/// any work, a result whose corner count would pass u32 indices; Loop schemes refuse non-triangle meshes.
pub fn subdivide(mesh: &Mesh, levels: u32, scheme: Scheme) -> Result<Mesh> {
    // Each level multiplies the corner count by 4.
    let mut corners = mesh.indices.len() as u128;
    for _ in 0..levels {
        corners = corners.saturating_mul(4);
    }
    if corners >= u32::MAX as u128 {
        return Err(Error::Invalid(format!(
            "--levels {levels}: the result would have about {corners} corners, more than u32 indices allow"
        )));
    }
    // The last level's working set per output corner (the refinement rows of the level before, the
    // refined topology, the positions and the output mesh): measured at 69 B (the cube at 9 levels peaks
    // at 432 MB for 6.3 M corners), with a margin.
    const BYTES_PER_CORNER: u128 = 96;
    let need = corners * BYTES_PER_CORNER;
    if let Some(free) = crate::io::host_memory_available() {
        if need > free as u128 {
            return Err(Error::Invalid(format!(
                "--levels {levels}: the result would have about {} M corners and need about {} MiB of \
                 memory, more than the {} MiB available",
                corners / 1_000_000,
                need >> 20,
                free >> 20
            )));
        }
    }
    Ok(match scheme {
        Scheme::CatmullClark => crate::mesh::catmull_clark(mesh, levels),
        Scheme::LoopWarren => {
            crate::mesh::loop_subdivide(mesh, levels, crate::mesh::LoopBeta::Warren)
                .map_err(to_mesh_error)?
        }
        Scheme::Loop => crate::mesh::loop_subdivide(mesh, levels, crate::mesh::LoopBeta::Loop)
            .map_err(to_mesh_error)?,
    })
}

/// How a mesh becomes voxels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// The fastest for the device: the CPU scanline on a CPU Vulkan device (lavapipe) or with no Vulkan
    /// device at all; the A-buffer on a GPU (depth peeling when the A-buffer's fragments pass one binding).
    Auto,
    /// Raster depth peeling + compute fill on the GPU.
    Peel,
    /// GPU A-buffer: count, prefix sum, one scatter pass, per-column sort + fill (no equal-depth loss).
    Abuffer,
    /// The same-sampling CPU column scanline (all cores).
    Cpu,
}

impl Method {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Method::Auto => "auto",
            Method::Peel => "peel",
            Method::Abuffer => "abuffer",
            Method::Cpu => "cpu",
        }
    }
}

/// Which axes to cast along.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axes {
    /// The cheapest single axis (fewest layers × covered columns; z for the CPU method); x, y and z with a
    /// 2-of-3 vote for open meshes under the winding or parity rule.
    Auto,
    /// One axis: the cheapest (fewest layers × covered columns; z for the CPU method), also on open meshes.
    Best,
    /// This one axis.
    One(Axis),
    /// x, y and z with a 2-of-3 vote of the winding (or parity) rule on the uncapped mesh (forgives small
    /// holes); with [`FillRule::Gwn`] the vote replaces the generalized winding number.
    Three,
}

/// What [`Gpu::voxelize`] does; `VoxelizeOptions::default().res(256)` is a 256³ grid over the mesh's box,
/// solid where the generalized winding number is at least ½ (exact on open meshes and soups; the winding
/// rule on closed ones), by the fastest method for the device.
#[derive(Clone)]
pub struct VoxelizeOptions {
    /// The grid: its size (`res`, `dims` or `voxel_size`), box and padding.
    pub grid: GridSpec,
    pub method: Method,
    pub rule: FillRule,
    /// Solid, surface (every voxel a triangle touches) or both.
    pub fill: Fill,
    pub axes: Axes,
    /// Refuse meshes needing more peeling passes than this.
    pub max_layers: u32,
    /// Called once per finished stage of a GPU voxelization (three per axis).
    pub progress: Option<ProgressFn>,
    /// A time limit, checked between the stages of the voxelization and inside the generalized winding
    /// number's long loops, box by box and voxel by voxel (`Error::Timeout` past it).
    pub deadline: Option<Deadline>,
    /// Bytes the generalized winding number may spend ([`FillRule::Gwn`], [`FillRule::GwnPositive`]): its
    /// trees and crossing index, the voxels near the surface and every voxel it resolves one by one; a mesh
    /// that needs more is refused with [`Error::Budget`] before or while it is spent.
    pub gwn_budget: u64,
}

/// The default [`VoxelizeOptions::gwn_budget`]: 1 GiB.
pub const DEFAULT_GWN_BUDGET: u64 = 1 << 30;

impl Default for VoxelizeOptions {
    fn default() -> Self {
        VoxelizeOptions {
            grid: GridSpec::res(128),
            method: Method::Auto,
            rule: FillRule::Gwn,
            fill: Fill::Solid,
            axes: Axes::Auto,
            max_layers: DEFAULT_MAX_LAYERS,
            progress: None,
            deadline: None,
            gwn_budget: DEFAULT_GWN_BUDGET,
        }
    }
}

impl std::fmt::Debug for VoxelizeOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VoxelizeOptions")
            .field("grid", &self.grid)
            .field("method", &self.method)
            .field("rule", &self.rule)
            .field("fill", &self.fill)
            .field("axes", &self.axes)
            .field("max_layers", &self.max_layers)
            .field("progress", &self.progress.is_some())
            .field("deadline", &self.deadline)
            .field("gwn_budget", &self.gwn_budget)
            .finish()
    }
}

impl VoxelizeOptions {
    /// A cubic R³ grid whose side is the box's longest extent.
    pub fn res(mut self, res: u32) -> Self {
        self.grid.size = GridSize::Res(res);
        self
    }
    /// The box divided into X×Y×Z voxels.
    pub fn dims(mut self, dims: [u32; 3]) -> Self {
        self.grid.size = GridSize::Dims(dims);
        self
    }
    /// Cubic voxels of side `h` (dims = ceil(extent / h) per axis).
    pub fn voxel_size(mut self, h: f64) -> Self {
        self.grid.size = GridSize::VoxelSize(h);
        self
    }
    /// Voxelize this box instead of the mesh's (inside or outside is still decided by the whole mesh).
    pub fn bbox(mut self, min: [f64; 3], max: [f64; 3]) -> Self {
        self.grid.bbox = Some(Bounds { min, max });
        self
    }
    /// `n` empty voxels on every side.
    pub fn pad(mut self, n: u32) -> Self {
        self.grid.pad = n;
        self
    }
    /// The method.
    pub fn method(mut self, method: Method) -> Self {
        self.method = method;
        self
    }
    /// The inside rule.
    pub fn rule(mut self, rule: FillRule) -> Self {
        self.rule = rule;
        self
    }
    /// Solid, surface or both.
    pub fn fill(mut self, fill: Fill) -> Self {
        self.fill = fill;
        self
    }
    /// The axes.
    pub fn axes(mut self, axes: Axes) -> Self {
        self.axes = axes;
        self
    }
    /// The peeling-pass cap.
    pub fn max_layers(mut self, max_layers: u32) -> Self {
        self.max_layers = max_layers;
        self
    }
    /// The memory budget of the generalized winding number's direct voxels.
    pub fn gwn_budget(mut self, bytes: u64) -> Self {
        self.gwn_budget = bytes;
        self
    }
    /// A time limit of `seconds` from now on this voxelization (see [`Deadline`]).
    pub fn time_limit(mut self, seconds: f64) -> Self {
        self.deadline = Some(Deadline::after(seconds));
        self
    }
    /// A progress callback.
    pub fn on_progress(mut self, f: impl Fn(&str) + Send + Sync + 'static) -> Self {
        self.progress = Some(std::sync::Arc::new(f));
        self
    }
}

/// What a voxelization did, for summaries and `--json`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct VoxelizeReport {
    /// The method that ran (never `auto`).
    pub method: Method,
    /// Why `auto` chose it (`None` when the caller named the method).
    pub method_reason: Option<String>,
    /// Where the grid is: dims, origin, voxel size (voxel (i,j,k) centred at origin + (index + ½)·size).
    pub frame: GridFrame,
    pub fill: Fill,
    /// Triangles voxelized (after cleaning).
    pub triangles: usize,
    /// Triangles removed before voxelizing.
    pub removed: CleanReport,
    pub closed: bool,
    pub boundary_edges: usize,
    pub non_manifold_edges: usize,
    /// The axes cast along (three means a 2-of-3 vote).
    pub axes: Vec<Axis>,
    /// Peeling passes per axis (GPU methods).
    pub layers: Vec<(Axis, u32)>,
    /// Notes worth telling the user (removed triangles, open mesh, …).
    pub notes: Vec<String>,
    /// The inside rule applied (`gwn` becomes `winding` under a 3-axis vote).
    pub rule: FillRule,
    /// What the generalized winding number did (its rule on a solid fill only).
    pub gwn: Option<GwnStats>,
}

/// A voxel grid and how it was made.
#[derive(Clone, Debug)]
pub struct Voxelization {
    pub grid: VoxelGrid,
    pub report: VoxelizeReport,
}

impl Voxelization {
    /// The result, with a note when it is empty: a flat mesh, or parts thinner than a voxel, give no solid
    /// voxel, and that must not pass unsaid.
    fn new(grid: VoxelGrid, mut report: VoxelizeReport) -> Voxelization {
        if grid.count() == 0 {
            report.notes.push(match report.fill {
                Fill::Solid => {
                    "no voxel is solid: the mesh encloses no voxel centre (flat, open, or \
                                thinner than a voxel); --fill both keeps thin parts"
                        .into()
                }
                _ => "no voxel is set: no triangle touches the grid (is --bbox around the mesh?)"
                    .into(),
            });
        }
        Voxelization { grid, report }
    }
}

/// A mesh made ready to voxelize: triangles, grid frame, and the report so far.
struct Prepared {
    /// The cleaned triangles (M).
    tri: TriMesh,
    /// Under the generalized winding number on a mesh that is open once exact duplicates are welded: the
    /// weld, cap and ribbons, and M' ∪ C' (the welded mesh closed by its caps), whose winding rule the
    /// fractional term corrects.
    capped: Option<(Proxy, TriMesh)>,
    /// The grid, in the local frame of `tri` (world = local + `shift`).
    frame: GridFrame,
    report: VoxelizeReport,
    three: bool,
    /// The mesh's local origin in world coordinates (see [`local_origin`]).
    shift: [f64; 3],
}

impl Prepared {
    /// The triangles the solid pass voxelizes: M' ∪ C' when capped, else M.
    fn solid_mesh(&self) -> &TriMesh {
        self.capped.as_ref().map(|c| &c.1).unwrap_or(&self.tri)
    }
    /// The rule the solid pass applies (the fractional term does the rest).
    fn solid_rule(&self) -> FillRule {
        self.report.rule.solid_pass()
    }
    /// Runs the generalized winding number's correction on `grid` (the solid pass of [`Self::solid_mesh`])
    /// for a rasterizer with `subpixel_bits`; no-op when nothing was capped.
    fn resolve_gwn(
        &self,
        grid: &mut VoxelGrid,
        opts: &VoxelizeOptions,
        subpixel_bits: u32,
    ) -> Result<Option<GwnStats>> {
        let Some((proxy, closed)) = &self.capped else {
            return Ok(None);
        };
        let params = GwnParams {
            inside: if self.report.rule == FillRule::GwnPositive {
                Inside::Positive
            } else {
                Inside::Magnitude
            },
            near: gwn::near_distance(&self.frame, subpixel_bits),
            budget: opts.gwn_budget,
            deadline: opts.deadline.map(|d| (d.at, d.seconds)),
        };
        gwn::resolve(grid, &self.tri, closed, proxy, &params).map(Some)
    }
}

/// The local origin of a mesh: the minimum corner of the box of the vertices its faces use (f64), for a
/// mesh far from the world origin ([`is_far`]), else the world origin. Positions become f32 only relative to
/// it, so a mesh 10⁷ units away keeps the precision of one at the origin: f32 world coordinates rounded spot
/// moved by 10⁷ to nothing ("no triangle with a non-zero area") and moved by 10⁴ to 34 wrong voxels. A mesh
/// near the world origin is voxelized exactly as before (its f32 world coordinates lose nothing that
/// matters: at most 16 sizes out, the rounding stays below 1e-6 of its size).
fn local_origin(mesh: &Mesh) -> [f64; 3] {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in &mesh.indices {
        let p = mesh.positions[i as usize].to_array();
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    if is_far(lo, hi) {
        lo
    } else {
        [0.0; 3]
    }
}

pub(crate) use crate::geom::is_far;

/// The triangles of `mesh` fanned, positions relative to `shift` in f32.
fn fan_local(mesh: &Mesh, shift: [f64; 3]) -> TriMesh {
    let mut fan = TriMesh::fan(mesh);
    for (q, p) in fan.positions.iter_mut().zip(&mesh.positions) {
        *q = [
            (p.x - shift[0]) as f32,
            (p.y - shift[1]) as f32,
            (p.z - shift[2]) as f32,
        ];
    }
    fan
}

/// `opts.grid` with its box (`--bbox`) in the local frame of `shift`.
fn local_grid(opts: &VoxelizeOptions, shift: [f64; 3]) -> GridSpec {
    let mut grid = opts.grid;
    if let Some(b) = &mut grid.bbox {
        for (a, s) in shift.iter().enumerate() {
            b.min[a] -= s;
            b.max[a] -= s;
        }
    }
    grid
}

/// A local grid frame moved to world coordinates.
fn to_world(mut frame: GridFrame, shift: [f64; 3]) -> GridFrame {
    for (o, s) in frame.origin.iter_mut().zip(shift) {
        *o += s;
    }
    frame
}

impl Voxelization {
    /// What `gregvox voxelize --json` reports of this result (the CLI adds the input, the size flag, the
    /// time and the profile): the grid's `dims`, `voxel_size`, `origin` and `index_to_world`, the method
    /// and why, the rule, the fill, triangles and removed ones, closed, the axes, peeling layers per axis
    /// and the solid voxel count. The Python `Grid.report` is this object.
    ///
    /// ```
    /// # use gregvox::api::{Mesh, VoxelizeOptions, voxelize_on_cpu}; use glam::DVec3;
    /// let cube = gregvox::api::Mesh::from_polygons(
    ///     (0..8).map(|i| DVec3::new((i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2) as f64)).collect(),
    ///     &[vec![0, 2, 3, 1], vec![4, 5, 7, 6], vec![0, 1, 5, 4], vec![2, 6, 7, 3], vec![0, 4, 6, 2], vec![1, 3, 7, 5]],
    /// ).unwrap();
    /// let v = voxelize_on_cpu(&cube, &VoxelizeOptions::default().res(4)).unwrap();
    /// let json = v.summary_json();
    /// assert_eq!(json["solid_voxels"], 64);
    /// assert_eq!(json["rule"], "gwn");
    /// ```
    pub fn summary_json(&self) -> serde_json::Value {
        let (report, grid) = (&self.report, &self.grid);
        let f = &grid.frame;
        let layers: std::collections::BTreeMap<String, u32> = report
            .layers
            .iter()
            .map(|(a, l)| (a.name().to_string(), *l))
            .collect();
        serde_json::json!({
            "dims": f.dims,
            "voxel_size": f.voxel_size,
            "origin": f.origin,
            "index_to_world": f.index_to_world(),
            "method": report.method,
            "method_reason": report.method_reason,
            "rule": report.rule.name(),
            "gwn": report.gwn,
            "fill": report.fill,
            "triangles": report.triangles,
            "removed": report.removed,
            "closed": report.closed,
            "axes": report.axes.iter().map(|a| a.name()).collect::<Vec<_>>(),
            "layers": layers,
            "solid_voxels": grid.count(),
        })
    }

    /// The result of a voxelization in the local frame of `shift`, moved to world coordinates.
    fn in_world(mut self, shift: [f64; 3]) -> Voxelization {
        self.grid.frame = to_world(self.grid.frame, shift);
        self.report.frame = to_world(self.report.frame, shift);
        self
    }
}

fn prepare(mesh: &Mesh, opts: &VoxelizeOptions) -> Result<Prepared> {
    // Only whether it is closed, and the open edges the report names (`MeshMatrix::edge_counts`).
    let (boundary_edges, non_manifold_edges) = MeshMatrix::from_mesh(mesh).edge_counts();
    // The box of the vertices the faces use: a stray unreferenced vertex must not move the grid.
    let shift = local_origin(mesh);
    let fan = fan_local(mesh, shift);
    let frame = frame_of(&fan, &local_grid(opts, shift))?;
    let (tri, removed) = fan.clean();
    if tri.triangles.is_empty() {
        return Err(Error::Mesh(
            "no triangle with a non-zero area to voxelize".into(),
        ));
    }
    let closed = boundary_edges == 0 && non_manifold_edges == 0;
    let open = !closed;
    let gwn = opts.rule.is_gwn();
    let three = match opts.axes {
        Axes::Three => true,
        Axes::One(_) | Axes::Best => false,
        Axes::Auto => open && !gwn,
    };
    let mut notes = Vec::new();
    let rule = if gwn && three {
        notes.push(
            "--axes 3: the 2-of-3 vote of the winding rule replaces the generalized winding number"
                .into(),
        );
        FillRule::Winding
    } else {
        opts.rule
    };
    // The cap is built from the welded soup: a mesh open only by its indices (unwelded duplicates) has none,
    // and one whose seams are a hair apart (within the weld tolerance) is closed with thin ribbons.
    let capped = if rule.is_gwn() && opts.fill != Fill::Surface {
        let proxy = Proxy::new(&tri, gwn::weld_tolerance(&frame))?;
        (!proxy.is_trivial()).then(|| {
            let closed = proxy.closed(&tri);
            (proxy, closed)
        })
    } else {
        None
    };
    if removed.duplicates + removed.cancelled + removed.zero_area > 0 {
        notes.push(format!(
            "removed {} duplicate, {} cancelling and {} zero-area triangles",
            removed.duplicates, removed.cancelled, removed.zero_area
        ));
    }
    if let Some((proxy, _)) = &capped {
        let welded = if proxy.moved > 0 {
            format!(
                "{} vertices welded within {:.3e}, {} ribbon triangles; ",
                proxy.moved,
                proxy.tolerance,
                proxy.ribbons.len()
            )
        } else {
            String::new()
        };
        notes.push(format!(
            "open mesh: {welded}{} boundary edges after welding, {} boundary loops capped; the \
             generalized winding number decides where they matter",
            proxy.cap.boundary_edges,
            proxy.cap.loops.len()
        ));
    } else if open && opts.fill != Fill::Surface && !rule.is_gwn() {
        notes.push(format!(
            "open mesh ({} boundary and {} non-manifold edges){}",
            boundary_edges,
            non_manifold_edges,
            if three {
                ": peeling along x, y and z with a 2-of-3 vote"
            } else {
                ""
            }
        ));
    }
    let report = VoxelizeReport {
        method: opts.method,
        method_reason: None,
        frame,
        fill: opts.fill,
        triangles: tri.triangles.len(),
        removed,
        closed,
        boundary_edges,
        non_manifold_edges,
        axes: Vec::new(),
        layers: Vec::new(),
        notes,
        rule,
        gwn: None,
    };
    Ok(Prepared {
        tri,
        capped,
        frame,
        report,
        three,
        shift,
    })
}

/// The grid `opts` gives for `mesh` (what a voxelization will use), without voxelizing: callers check an
/// output format against it before any work.
pub fn grid_frame(mesh: &Mesh, opts: &VoxelizeOptions) -> Result<GridFrame> {
    let shift = local_origin(mesh);
    let local = frame_of(&fan_local(mesh, shift), &local_grid(opts, shift))?;
    Ok(to_world(local, shift))
}

/// The grid `grid` gives for the fanned triangles `fan` (before cleaning: every face counts for the box).
fn frame_of(fan: &TriMesh, grid: &GridSpec) -> Result<GridFrame> {
    let mesh_box = Bounds::of_triangles(&fan.positions, &fan.triangles).map_err(to_mesh_error)?;
    grid.frame(mesh_box).map_err(|e| match e {
        Error::Invalid(msg) if grid.bbox.is_none() && msg.contains("box") => Error::Mesh(msg),
        e => e,
    })
}

fn to_mesh_error(e: Error) -> Error {
    match e {
        Error::Invalid(msg) => Error::Mesh(msg),
        e => e,
    }
}

/// Adds the surface voxels to `grid` as `fill` says (solid: unchanged; surface: only them; both: the union).
fn apply_fill(grid: Option<VoxelGrid>, tri: &TriMesh, frame: &GridFrame, fill: Fill) -> VoxelGrid {
    let surface = || crate::voxel::surface::voxelize_surface(tri, frame);
    match (fill, grid) {
        (Fill::Solid, Some(g)) => g,
        (Fill::Both, Some(g)) => g.union(&surface()),
        _ => surface(),
    }
}

/// Voxelizes `mesh` as `opts` says, creating a Vulkan device only when the method needs one: `auto` probes the
/// device first (no logical device, no pipelines) and runs the CPU scanline on a CPU device such as lavapipe
/// or when there is no Vulkan device at all; `cpu` never touches Vulkan.
pub fn voxelize(mesh: &Mesh, opts: &VoxelizeOptions) -> Result<Voxelization> {
    match opts.method {
        Method::Cpu => voxelize_on_cpu(mesh, opts),
        Method::Auto => match crate::gpu::context::probe_device() {
            Ok((_, kind)) if kind != "CPU" => Gpu::new()?.voxelize(mesh, opts),
            Ok((name, _)) => {
                cpu_by_auto(mesh, opts, format!("the Vulkan device ({name}) is a CPU"))
            }
            Err(e) => cpu_by_auto(mesh, opts, format!("no usable Vulkan device ({e})")),
        },
        _ => Gpu::new()?.voxelize(mesh, opts),
    }
}

/// What `--method auto` runs on `device`, and why: the CPU scanline on a CPU device (lavapipe's rasterizer
/// and compute run on the same cores the scanline uses, with pipeline and transfer costs on top), the
/// A-buffer on a GPU (two geometry passes whatever the depth; [`Gpu::voxelize`] falls back to depth peeling
/// when its fragments pass one binding).
pub fn auto_method(device: &DeviceInfo) -> (Method, String) {
    if device.device_type == "CPU" {
        (
            Method::Cpu,
            format!(
                "auto: the Vulkan device ({}) is a CPU, so the CPU scanline",
                device.name
            ),
        )
    } else {
        (
            Method::Abuffer,
            "auto: a GPU, so the A-buffer (two geometry passes whatever the depth)".into(),
        )
    }
}

fn cpu_by_auto(mesh: &Mesh, opts: &VoxelizeOptions, why: String) -> Result<Voxelization> {
    let mut v = voxelize_on_cpu(mesh, opts)?;
    v.report.method_reason = Some(format!("auto: {why}, so the CPU scanline"));
    Ok(v)
}

/// Voxelizes `mesh` on the CPU (the column scanline, all cores), with no Vulkan device at all; `opts.method`
/// is ignored (reported as `cpu`).
pub fn voxelize_on_cpu(mesh: &Mesh, opts: &VoxelizeOptions) -> Result<Voxelization> {
    let prepared = prepare(mesh, opts)?;
    checkpoint(&opts.deadline, "after cleaning the mesh")?;
    let (frame, three) = (prepared.frame, prepared.three);
    let mut report = prepared.report.clone();
    report.method = Method::Cpu;
    if opts.method == Method::Auto {
        report.method_reason = Some("auto: no GPU asked for, so the CPU scanline".into());
    }
    let solid = if opts.fill == Fill::Surface {
        None
    } else {
        report.axes = match (three, opts.axes) {
            (true, _) => Axis::ALL.to_vec(),
            (false, Axes::One(a)) => vec![a],
            (false, _) => vec![Axis::Z],
        };
        let (solid_mesh, rule) = (prepared.solid_mesh(), prepared.solid_rule());
        let grids: Vec<VoxelGrid> = report
            .axes
            .iter()
            .map(|&a| voxelize_cpu(solid_mesh, &frame, a, rule))
            .collect();
        let mut grid = if three {
            VoxelGrid::majority([&grids[0], &grids[1], &grids[2]])
        } else {
            grids.into_iter().next().expect("one axis")
        };
        checkpoint(&opts.deadline, "after the scanline")?;
        report.gwn = prepared.resolve_gwn(&mut grid, opts, gwn::CPU_SUBPIXEL_BITS)?;
        Some(grid)
    };
    let grid = apply_fill(solid, &prepared.tri, &frame, opts.fill);
    Ok(Voxelization::new(grid, report).in_world(prepared.shift))
}

/// A Vulkan device and everything gregvox needs on it. Cheap to keep for many calls; dropping it releases
/// the device once the last object made from it is gone.
pub struct Gpu {
    /// The voxelizers' pipelines, made on first use and kept for the next call: a batch of thousands of
    /// models builds them once (on lavapipe each build compiles shaders). Declared before `ctx` so they
    /// are released before the device.
    voxelizers: std::sync::Mutex<VoxelizerCache>,
    /// The distance queries' nearest-piece search (`passes::closest_point`), made on first use and kept:
    /// a caller querying batch after batch compiles it once.
    closest_point:
        std::sync::Mutex<Option<std::sync::Arc<crate::passes::closest_point::ClosestPointPass>>>,
    ctx: Context,
}

/// The pipelines of each GPU method, when made. They hold no per-grid state: every setting is set again
/// at the start of each call.
#[derive(Default)]
struct VoxelizerCache {
    peel: Option<GpuVoxelizer>,
    abuffer: Option<GpuVoxelizer>,
}

impl Gpu {
    /// The default device (discrete > integrated > virtual > CPU; `GREGVOX_DEVICE` picks by name), with the
    /// validation layer as `GREGVOX_VALIDATION` says (on in debug builds when installed).
    pub fn new() -> Result<Gpu> {
        Gpu::with_desc(&ContextDesc::default())
    }

    /// A device chosen and configured by `desc`.
    pub fn with_desc(desc: &ContextDesc) -> Result<Gpu> {
        Ok(Gpu {
            voxelizers: Default::default(),
            closest_point: Default::default(),
            ctx: Context::with_desc(desc)?,
        })
    }

    /// gregvox on a device the caller created and keeps (a renderer's): what [`Gpu::new`] does, on the
    /// caller's instance, device and queue. Ask [`Gpu::requirements`] before creating the device. gregvox
    /// never destroys what it did not create; dropping the `Gpu` (and everything made from it) waits for
    /// the device to be idle and frees gregvox's memory. See docs/embedding.md.
    ///
    /// # Safety
    /// The promises of [`Context::from_external`]: valid handles created with the requirements enabled,
    /// the device outliving the `Gpu` and everything made from it, and no other thread on the queue while
    /// a gregvox call submits or waits.
    pub unsafe fn from_external(device: &ExternalDevice) -> Result<Gpu> {
        Ok(Gpu {
            voxelizers: Default::default(),
            closest_point: Default::default(),
            // SAFETY: the caller's promise, passed on.
            ctx: unsafe { Context::from_external(device)? },
        })
    }

    /// What gregvox needs of `physical_device` (of an instance created for `api_version`): extensions,
    /// features and the queue family to create a device with; an error naming what the device lacks.
    pub fn requirements(
        instance: &ash::Instance,
        physical_device: ash::vk::PhysicalDevice,
        api_version: u32,
    ) -> Result<DeviceRequirements> {
        DeviceRequirements::query(instance, physical_device, api_version)
    }

    /// Starts recording gregvox work into a command buffer of the caller's ([`Surface::record`] and the
    /// like); end it with `submitted(semaphore, value)` after submitting that command buffer, so that
    /// what gregvox releases meanwhile waits for it. See [`ExternalRecording`].
    pub fn begin_recording(&self) -> Result<ExternalRecording<'_>> {
        self.ctx.begin_external()
    }

    /// The device report (`gregvox info`).
    pub fn info(&self) -> &DeviceInfo {
        &self.ctx.info
    }

    /// The Vulkan context, for code that records passes itself.
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// The nearest-piece search of the distance queries, with the shader this device needs (made on the
    /// first call, then kept).
    pub(crate) fn closest_point_pass(
        &self,
    ) -> Result<std::sync::Arc<crate::passes::closest_point::ClosestPointPass>> {
        use crate::passes::closest_point::{ieee_division, ClosestPointPass};
        let mut cache = self.closest_point.lock().unwrap_or_else(|e| e.into_inner());
        if cache.is_none() {
            let pass = ClosestPointPass::new(&self.ctx, !ieee_division(&self.ctx))?;
            *cache = Some(std::sync::Arc::new(pass));
        }
        Ok(cache.clone().expect("made above"))
    }

    /// Waits for the device and reports what should not be left: GPU allocations still alive (call it after
    /// dropping what the work made) and validation messages (when the layer is on). Examples and tools end
    /// with it; dropping a `Gpu` without it is fine.
    pub fn finish(self) -> Result<()> {
        let Gpu {
            voxelizers,
            closest_point,
            ctx,
        } = self;
        drop(voxelizers);
        drop(closest_point);
        ctx.wait_idle()?;
        let live = ctx.live_allocations();
        if !live.is_empty() {
            return Err(Error::Invalid(format!(
                "internal error: GPU allocations still alive: {}",
                live.join(", ")
            )));
        }
        let n = ctx.validation.count();
        if n > 0 {
            let first = ctx.validation.messages().into_iter().next();
            return Err(Error::Invalid(format!(
                "internal error: {n} Vulkan validation message(s), the first: {}",
                first.unwrap_or_default()
            )));
        }
        Ok(())
    }

    /// Builds the pipelines `method` voxelizes with (`auto`: the A-buffer's, what it picks on a GPU) now
    /// rather than on the first call, so that a batch's per-model times and time limits count the
    /// models' own work, not the driver's shader compilation. `cpu` builds nothing.
    pub fn prepare(&self, method: Method) -> Result<()> {
        let mut cache = self.voxelizers.lock().unwrap_or_else(|e| e.into_inner());
        match method {
            Method::Cpu => {}
            Method::Peel if cache.peel.is_none() => cache.peel = Some(self.new_voxelizer(method)?),
            Method::Abuffer | Method::Auto if cache.abuffer.is_none() => {
                cache.abuffer = Some(self.new_voxelizer(Method::Abuffer)?)
            }
            _ => {}
        }
        Ok(())
    }

    /// A new voxelizer for a GPU `method` (the A-buffer's for `Abuffer`, depth peeling's otherwise).
    fn new_voxelizer(&self, method: Method) -> Result<GpuVoxelizer> {
        let stride = std::mem::size_of::<[f32; 3]>() as u32;
        Ok(if method == Method::Abuffer {
            GpuVoxelizer::Abuffer(Box::new(AbufferVoxelizer::new(&self.ctx, stride)?))
        } else {
            GpuVoxelizer::Peel(Box::new(PeelVoxelizer::new(&self.ctx, stride)?))
        })
    }

    /// A timestamp profiler for the calls that take one (one frame slot, up to 4,096 scopes).
    pub fn profiler(&self) -> Result<Profiler> {
        Profiler::new(&self.ctx, 1, 4096)
    }

    /// Voxelizes `mesh` as `opts` says (see [`Gpu::voxelize_profiled`]).
    pub fn voxelize(&self, mesh: &Mesh, opts: &VoxelizeOptions) -> Result<Voxelization> {
        self.voxelize_profiled(mesh, opts, None)
    }

    /// Voxelizes `mesh`, recording per-pass GPU times into `profiler`. Refuses a resolution whose working
    /// set passes the device's memory before any GPU work.
    pub fn voxelize_profiled(
        &self,
        mesh: &Mesh,
        opts: &VoxelizeOptions,
        profiler: Option<&mut Profiler>,
    ) -> Result<Voxelization> {
        let (method, reason) = match opts.method {
            Method::Auto => {
                let (m, why) = auto_method(&self.ctx.info);
                (m, Some(why))
            }
            m => (m, None),
        };
        if method == Method::Cpu {
            let mut v = voxelize_on_cpu(mesh, opts)?;
            v.report.method_reason = reason;
            return Ok(v);
        }
        let prepared = prepare(mesh, opts)?;
        let (tri, frame, three, rule) = (
            &prepared.tri,
            prepared.frame,
            prepared.three,
            prepared.solid_rule(),
        );
        let mut report = prepared.report.clone();
        report.method_reason = reason;
        let ctx = &self.ctx;
        let need = memory_estimate(ctx, &frame, 16);
        let heap = ctx.info.device_local_heap_bytes;
        if heap > 0 && need > heap {
            let [x, y, z] = frame.dims;
            return Err(Error::Limit {
                what: format!(
                    "a {x}×{y}×{z} grid (about {} MiB of device memory)",
                    need >> 20
                ),
                detail: format!("the device has {} MiB", heap >> 20),
            });
        }
        // M' ∪ C' when capped (what the solid pass draws); the surface pass of `--fill both` reads M itself.
        let gpu = GpuTriangles::upload(ctx, prepared.solid_mesh())?;
        let surface_upload = match (&prepared.capped, opts.fill) {
            (Some(_), Fill::Both) => Some(GpuTriangles::upload(ctx, tri)?),
            _ => None,
        };
        let surface_tris = surface_upload.as_ref().unwrap_or(&gpu);
        // The voxels the triangles touch, on the GPU when it computes in f64 (the exact test), else on
        // the CPU: the same bits either way.
        let surface = match opts.fill {
            Fill::Solid => None,
            _ => {
                let on_gpu = if ctx.info.features.shader_float64 {
                    voxelize_surface_gpu(ctx, surface_tris, tri, &frame, None)?
                } else {
                    None
                };
                Some(on_gpu.unwrap_or_else(|| {
                    report.notes.push(
                        "surface voxels computed on the CPU (the device lacks shaderFloat64, or the \
                         work list passes one dispatch)"
                            .into(),
                    );
                    crate::voxel::surface::voxelize_surface(tri, &frame)
                }))
            }
        };
        if opts.fill == Fill::Surface {
            report.method = method;
            return Ok(Voxelization::new(surface.expect("computed above"), report)
                .in_world(prepared.shift));
        }
        // The host copy lets depth peeling recompute the columns where it lost an equal-depth fragment.
        let geom = crate::passes::peel::PeelGeometry {
            mesh: Some(prepared.solid_mesh()),
            ..gpu.geometry()
        };
        let result = self.run_gpu_method(method, opts, rule, &geom, &frame, three, profiler);
        // Auto on a GPU: the A-buffer holds every fragment in one binding; past that, depth peeling.
        let (grid, axes, stats) = match result {
            Err(Error::Limit { what, .. })
                if opts.method == Method::Auto && what.contains("fragments") =>
            {
                report.method = Method::Peel;
                report.method_reason = Some(format!(
                    "auto: a GPU; {what} pass one A-buffer binding, so depth peeling"
                ));
                self.run_gpu_method(Method::Peel, opts, rule, &geom, &frame, three, None)?
            }
            r => {
                report.method = method;
                r?
            }
        };
        report.axes = axes;
        report.layers = stats.iter().map(|s| (s.axis, s.layers)).collect();
        let repaired: u64 = stats.iter().map(|s| s.repaired_columns).sum();
        if repaired > 0 {
            report.notes.push(format!(
                "depth peeling lost equal-depth fragments (coincident triangles) in {repaired} columns; \
                 the CPU recomputed them"
            ));
        }
        let mut grid = grid;
        checkpoint(&opts.deadline, "after the solid grid")?;
        // The fractional term on the host, for a rasterizer with the device's sub-pixel precision: the same
        // decisions as the CPU method, whose every voxel they are exact at.
        report.gwn = prepared.resolve_gwn(&mut grid, opts, ctx.limits.sub_pixel_precision_bits)?;
        let grid = match surface {
            Some(s) => grid.union(&s),
            None => grid,
        };
        Ok(Voxelization::new(grid, report).in_world(prepared.shift))
    }

    /// One GPU method along the axes `three` and `opts.axes` give: (grid, axes, per-axis figures).
    #[allow(clippy::too_many_arguments)]
    fn run_gpu_method(
        &self,
        method: Method,
        opts: &VoxelizeOptions,
        rule: FillRule,
        geom: &crate::passes::peel::PeelGeometry,
        frame: &GridFrame,
        three: bool,
        profiler: Option<&mut Profiler>,
    ) -> Result<(
        VoxelGrid,
        Vec<Axis>,
        Vec<crate::engine::voxelize::AxisStats>,
    )> {
        let ctx = &self.ctx;
        // Take the method's voxelizer from the cache (a concurrent call on the same `Gpu` finds the slot
        // empty and builds its own), set this call's options, and put it back whatever the outcome.
        let cached = {
            let mut cache = self.voxelizers.lock().unwrap_or_else(|e| e.into_inner());
            match method {
                Method::Abuffer => cache.abuffer.take(),
                _ => cache.peel.take(),
            }
        };
        let mut v = match cached {
            Some(v) => v,
            None => self.new_voxelizer(method)?,
        };
        match &mut v {
            GpuVoxelizer::Abuffer(a) => {
                a.progress = opts.progress.clone();
                a.deadline = opts.deadline;
            }
            GpuVoxelizer::Peel(p) => {
                p.max_layers = opts.max_layers;
                p.progress = opts.progress.clone();
                p.deadline = opts.deadline;
            }
        }
        // The axis choice and the voxelization; the voxelizer goes back to the cache whatever the outcome.
        let result = (|| {
            let axes: Vec<Axis> = match (three, opts.axes) {
                (true, _) => Axis::ALL.to_vec(),
                (false, Axes::One(a)) => vec![a],
                (false, _) => {
                    // The cheapest axis: fewest layers × columns covered, from the count pre-pass.
                    let mut best = (u128::MAX, Axis::Z);
                    for a in Axis::ALL {
                        let (l, area) = v.count_layers(ctx, geom, frame, a)?;
                        best = best.min(((l as u128) * (area as u128), a));
                    }
                    vec![best.1]
                }
            };
            let (grid, stats) = v.voxelize(ctx, geom, frame, &axes, rule, profiler)?;
            Ok((grid, axes, stats))
        })();
        let mut cache = self.voxelizers.lock().unwrap_or_else(|e| e.into_inner());
        match method {
            Method::Abuffer => cache.abuffer = Some(v),
            _ => cache.peel = Some(v),
        }
        result
    }

    /// Voxelizes the Gregory surface of `cage` (tagged or `&Cage::from(mesh)`) at `level` straight from the
    /// device-local vertex buffer (no CPU round trip of the surface), by depth peeling.
    pub fn voxelize_gregory(
        &self,
        cage: &Cage,
        level: u32,
        opts: &VoxelizeOptions,
        profiler: Option<&mut Profiler>,
    ) -> Result<Voxelization> {
        if !matches!(opts.method, Method::Peel | Method::Auto) {
            return Err(Error::Invalid(
                "--gregory-level voxelizes the GPU surface by depth peeling: use --method peel or auto"
                    .into(),
            ));
        }
        if opts.fill != Fill::Solid {
            return Err(Error::Invalid(
                "--gregory-level voxelizes the solid of the GPU surface: --fill surface and both need \
                 the triangles on the CPU (tessellate to OBJ first)"
                    .into(),
            ));
        }
        let mut topo_report = topology(&cage.mesh);
        // Hole faces leave the surface of a closed cage open.
        topo_report.closed &= cage.tags.holes.is_empty();
        // A cage far from the world origin is evaluated and voxelized relative to its own corner (f64),
        // as meshes are: in f32 world coordinates a cube 10⁷ away came out as a 2-unit box at 9999999.
        let shift = local_origin(&cage.mesh);
        let local;
        let cage = if shift == [0.0; 3] {
            cage
        } else {
            let mut c = cage.clone();
            for p in &mut c.mesh.positions {
                *p -= glam::DVec3::from(shift);
            }
            local = c;
            &local
        };
        let surface = self.tagged_gregory_surface(cage, level, Tangents::OpenSubdiv)?;
        let three = match opts.axes {
            Axes::Three => true,
            Axes::One(_) | Axes::Best => false,
            Axes::Auto => !topo_report.closed,
        };
        let axes: Vec<Axis> = match (three, opts.axes) {
            (true, _) => Axis::ALL.to_vec(),
            (false, Axes::One(a)) => vec![a],
            (false, _) => vec![Axis::Z],
        };
        let mut notes: Vec<String> = surface.note().map(String::from).into_iter().collect();
        // The Gregory surface stays on the GPU: no cap is built from it, so the generalized winding number
        // is the winding rule there (exact on the closed surfaces of closed cages).
        let rule = match opts.rule {
            r if r.is_gwn() => {
                if !topo_report.closed {
                    notes.push(format!(
                        "--gregory-level: the open surface is voxelized by the {} rule (no cap is built on \
                         the GPU surface)",
                        if r == FillRule::Gwn { "winding" } else { "positive" }
                    ));
                }
                r.solid_pass()
            }
            r => r,
        };
        let (grid, stats) = voxelize_gregory_surface(
            &self.ctx,
            surface.engine(),
            &local_grid(opts, shift),
            &axes,
            rule,
            opts.max_layers,
            profiler,
        )?;
        let report = VoxelizeReport {
            method: Method::Peel,
            method_reason: (opts.method == Method::Auto)
                .then(|| "auto: a Gregory surface is voxelized on the GPU by depth peeling".into()),
            frame: grid.frame,
            fill: Fill::Solid,
            triangles: surface.engine().index_count() as usize / 3,
            removed: CleanReport::default(),
            closed: topo_report.closed,
            boundary_edges: topo_report.boundary_edges,
            non_manifold_edges: topo_report.non_manifold_edges,
            axes,
            layers: stats.iter().map(|s| (s.axis, s.layers)).collect(),
            notes,
            rule,
            gwn: None,
        };
        Ok(Voxelization::new(grid, report).in_world(shift))
    }
}
