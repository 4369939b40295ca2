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
use crate::engine::cage::cage_topology;
use crate::engine::gregory::GregorySurface;
use crate::engine::voxelize::{
    memory_estimate, voxelize_gregory_surface, AbufferVoxelizer, GpuTriangles, GpuVoxelizer,
    PeelVoxelizer,
};
use crate::error::{Error, Result};
use crate::gpu::Context;
pub use crate::gpu::{ContextDesc, DeviceInfo, Profiler, Validation};
use crate::passes::cage_deform::DeformParams;
use crate::passes::gregory_eval::{grid_indices, SurfaceVertex, MAX_LEVEL};
use crate::voxel::cpu::voxelize_cpu;
use crate::voxel::mesh::{CleanReport, TriMesh};
use glam::DVec3;
use std::path::Path;

pub mod tessellate;

pub use crate::engine::voxelize::{ProgressFn, DEFAULT_MAX_LAYERS};
pub use crate::mesh::{Mesh, MeshMatrix, TopologyReport};
pub use crate::passes::cage_deform::Deformation;
pub use crate::passes::gregory_eval::SurfaceVertex as Vertex;
pub use crate::surface::Tangents;
pub use crate::voxel::cpu::FillRule;
pub use crate::voxel::grid::{Axis, GridFrame, VoxelGrid};

/// Largest grid resolution accepted (2048³ bits = 1 GiB).
pub const MAX_RES: u32 = 2048;

/// Loads a mesh file: OBJ, STL (ASCII or binary), PLY (ASCII or binary), OFF, glTF 2.0 or GLB, detected
/// from the content, else the extension ([`crate::mesh::load_mesh_file`]; STL and glTF are welded exactly).
/// Errors name the file, then the line (text) or byte offset (binary data), then the problem.
pub fn load_mesh(path: impl AsRef<Path>) -> Result<Mesh> {
    crate::mesh::load_mesh_file(path)
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
    let to_mesh_error = |e: Error| match e {
        Error::Invalid(msg) => Error::Mesh(msg),
        e => e,
    };
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
            Method::Peel => "peel",
            Method::Abuffer => "abuffer",
            Method::Cpu => "cpu",
        }
    }
}

/// Which axes to cast along.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axes {
    /// Open meshes: x, y and z with a 2-of-3 vote; closed meshes: the cheapest single axis (fewest layers ×
    /// covered columns; z for the CPU method).
    Auto,
    /// One axis: the cheapest (fewest layers × covered columns; z for the CPU method), also on open meshes.
    Best,
    /// This one axis.
    One(Axis),
    /// x, y and z with a 2-of-3 vote (forgives small holes).
    Three,
}

/// What [`Gpu::voxelize`] does; `VoxelizeOptions::default().res(256)` is a 256³ grid by depth peeling with
/// the winding rule.
#[derive(Clone)]
pub struct VoxelizeOptions {
    /// Voxels per side of the cubic grid (1–[`MAX_RES`]).
    pub res: u32,
    pub method: Method,
    pub rule: FillRule,
    pub axes: Axes,
    /// Refuse meshes needing more peeling passes than this.
    pub max_layers: u32,
    /// Called once per finished stage of a GPU voxelization (three per axis).
    pub progress: Option<ProgressFn>,
}

impl Default for VoxelizeOptions {
    fn default() -> Self {
        VoxelizeOptions {
            res: 128,
            method: Method::Peel,
            rule: FillRule::Winding,
            axes: Axes::Auto,
            max_layers: DEFAULT_MAX_LAYERS,
            progress: None,
        }
    }
}

impl std::fmt::Debug for VoxelizeOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VoxelizeOptions")
            .field("res", &self.res)
            .field("method", &self.method)
            .field("rule", &self.rule)
            .field("axes", &self.axes)
            .field("max_layers", &self.max_layers)
            .field("progress", &self.progress.is_some())
            .finish()
    }
}

impl VoxelizeOptions {
    /// Voxels per side.
    pub fn res(mut self, res: u32) -> Self {
        self.res = res;
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
    /// A progress callback.
    pub fn on_progress(mut self, f: impl Fn(&str) + Send + Sync + 'static) -> Self {
        self.progress = Some(std::sync::Arc::new(f));
        self
    }

    fn validate(&self) -> Result<()> {
        if self.res == 0 || self.res > MAX_RES {
            return Err(Error::Invalid(format!(
                "--res {} is out of range: the resolution must be between 1 and {MAX_RES}",
                self.res
            )));
        }
        Ok(())
    }
}

/// What a voxelization did, for summaries and `--json`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct VoxelizeReport {
    pub method: Method,
    pub res: u32,
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
}

/// A voxel grid and how it was made.
#[derive(Clone, Debug)]
pub struct Voxelization {
    pub grid: VoxelGrid,
    pub report: VoxelizeReport,
}

/// A mesh made ready to voxelize: triangles, grid frame, and the report so far.
struct Prepared {
    tri: TriMesh,
    frame: GridFrame,
    report: VoxelizeReport,
    three: bool,
}

fn prepare(mesh: &Mesh, opts: &VoxelizeOptions) -> Result<Prepared> {
    opts.validate()?;
    let topo = topology(mesh);
    let (tri, removed) = TriMesh::fan(mesh).clean();
    if tri.triangles.is_empty() {
        return Err(Error::Mesh(
            "no triangle with a non-zero area to voxelize".into(),
        ));
    }
    let frame = GridFrame::from_points(&tri.positions, opts.res).map_err(|e| match e {
        Error::Invalid(msg) => Error::Mesh(msg),
        e => e,
    })?;
    let open = !topo.closed;
    let three = match opts.axes {
        Axes::Three => true,
        Axes::One(_) | Axes::Best => false,
        Axes::Auto => open,
    };
    let mut notes = Vec::new();
    if removed.duplicates + removed.cancelled + removed.zero_area > 0 {
        notes.push(format!(
            "removed {} duplicate, {} cancelling and {} zero-area triangles",
            removed.duplicates, removed.cancelled, removed.zero_area
        ));
    }
    if open {
        notes.push(format!(
            "open mesh ({} boundary and {} non-manifold edges){}",
            topo.boundary_edges,
            topo.non_manifold_edges,
            if three {
                ": peeling along x, y and z with a 2-of-3 vote"
            } else {
                ""
            }
        ));
    }
    let report = VoxelizeReport {
        method: opts.method,
        res: opts.res,
        triangles: tri.triangles.len(),
        removed,
        closed: topo.closed,
        boundary_edges: topo.boundary_edges,
        non_manifold_edges: topo.non_manifold_edges,
        axes: Vec::new(),
        layers: Vec::new(),
        notes,
    };
    Ok(Prepared {
        tri,
        frame,
        report,
        three,
    })
}

/// Voxelizes `mesh` on the CPU (the column scanline, all cores), with no Vulkan device at all; `opts.method`
/// is ignored.
pub fn voxelize_on_cpu(mesh: &Mesh, opts: &VoxelizeOptions) -> Result<Voxelization> {
    let Prepared {
        tri,
        frame,
        mut report,
        three,
    } = prepare(mesh, opts)?;
    report.method = Method::Cpu;
    report.axes = match (three, opts.axes) {
        (true, _) => Axis::ALL.to_vec(),
        (false, Axes::One(a)) => vec![a],
        (false, _) => vec![Axis::Z],
    };
    let grids: Vec<VoxelGrid> = report
        .axes
        .iter()
        .map(|&a| voxelize_cpu(&tri, &frame, a, opts.rule))
        .collect();
    let grid = if three {
        VoxelGrid::majority([&grids[0], &grids[1], &grids[2]])
    } else {
        grids.into_iter().next().expect("one axis")
    };
    Ok(Voxelization { grid, report })
}

/// A Vulkan device and everything gregvox needs on it. Cheap to keep for many calls; dropping it releases
/// the device once the last object made from it is gone.
pub struct Gpu {
    ctx: Context,
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
            ctx: Context::with_desc(desc)?,
        })
    }

    /// The device report (`gregvox info`).
    pub fn info(&self) -> &DeviceInfo {
        &self.ctx.info
    }

    /// The Vulkan context, for code that records passes itself.
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// Waits for the device and reports what should not be left: GPU allocations still alive (call it after
    /// dropping what the work made) and validation messages (when the layer is on). Examples and tools end
    /// with it; dropping a `Gpu` without it is fine.
    pub fn finish(self) -> Result<()> {
        self.ctx.wait_idle()?;
        let live = self.ctx.live_allocations();
        if !live.is_empty() {
            return Err(Error::Invalid(format!(
                "internal error: GPU allocations still alive: {}",
                live.join(", ")
            )));
        }
        let n = self.ctx.validation.count();
        if n > 0 {
            let first = self.ctx.validation.messages().into_iter().next();
            return Err(Error::Invalid(format!(
                "internal error: {n} Vulkan validation message(s), the first: {}",
                first.unwrap_or_default()
            )));
        }
        Ok(())
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
        if opts.method == Method::Cpu {
            return voxelize_on_cpu(mesh, opts);
        }
        let Prepared {
            tri,
            frame,
            mut report,
            three,
        } = prepare(mesh, opts)?;
        let ctx = &self.ctx;
        let need = memory_estimate(ctx, frame.res, 16);
        let heap = ctx.info.device_local_heap_bytes;
        if heap > 0 && need > heap {
            return Err(Error::Limit {
                what: format!(
                    "--res {} (about {} MiB of device memory)",
                    frame.res,
                    need >> 20
                ),
                detail: format!("the device has {} MiB", heap >> 20),
            });
        }
        let stride = std::mem::size_of::<[f32; 3]>() as u32;
        let v = if opts.method == Method::Abuffer {
            let mut v = AbufferVoxelizer::new(ctx, stride)?;
            v.progress = opts.progress.clone();
            GpuVoxelizer::Abuffer(Box::new(v))
        } else {
            let mut v = PeelVoxelizer::new(ctx, stride)?;
            v.max_layers = opts.max_layers;
            v.progress = opts.progress.clone();
            GpuVoxelizer::Peel(Box::new(v))
        };
        let gpu = GpuTriangles::upload(ctx, &tri)?;
        let geom = gpu.geometry();
        let axes: Vec<Axis> = match (three, opts.axes) {
            (true, _) => Axis::ALL.to_vec(),
            (false, Axes::One(a)) => vec![a],
            (false, _) => {
                // The cheapest axis: fewest layers × columns covered, from the count pre-pass.
                let mut best = (u128::MAX, Axis::Z);
                for a in Axis::ALL {
                    let (l, area) = v.count_layers(ctx, &geom, &frame, a)?;
                    best = best.min(((l as u128) * (area as u128), a));
                }
                vec![best.1]
            }
        };
        let (grid, stats) = v.voxelize(ctx, &geom, &frame, &axes, opts.rule, profiler)?;
        report.axes = axes;
        report.layers = stats.iter().map(|s| (s.axis, s.layers)).collect();
        Ok(Voxelization { grid, report })
    }

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
        if !(1..=MAX_LEVEL).contains(&level) {
            return Err(Error::Invalid(format!(
                "--level {level} is out of range: the tessellation level must be between 1 and {MAX_LEVEL}"
            )));
        }
        let (topo, rest, note) = cage_topology(cage, tangents).map_err(|e| match e {
            Error::Invalid(msg) => Error::Mesh(msg),
            e => e,
        })?;
        let inner = GregorySurface::new(&self.ctx, &topo, &rest, level)?;
        let surface = Surface {
            gpu: self,
            inner,
            rest,
            note,
        };
        surface.evaluate(None)?;
        Ok(surface)
    }

    /// Voxelizes the Gregory surface of `cage` at `level` straight from the device-local vertex buffer (no
    /// CPU round trip of the surface), by depth peeling.
    pub fn voxelize_gregory(
        &self,
        cage: &Mesh,
        level: u32,
        opts: &VoxelizeOptions,
        profiler: Option<&mut Profiler>,
    ) -> Result<Voxelization> {
        opts.validate()?;
        if opts.method != Method::Peel {
            return Err(Error::Invalid(
                "--gregory-level voxelizes the GPU surface by depth peeling: use --method peel"
                    .into(),
            ));
        }
        let topo_report = topology(cage);
        let surface = self.gregory_surface(cage, level)?;
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
        let (grid, stats) = voxelize_gregory_surface(
            &self.ctx,
            &surface.inner,
            opts.res,
            &axes,
            opts.rule,
            opts.max_layers,
            profiler,
        )?;
        let report = VoxelizeReport {
            method: Method::Peel,
            res: opts.res,
            triangles: 2 * surface.patch_count() as usize * (level * level) as usize,
            removed: CleanReport::default(),
            closed: topo_report.closed,
            boundary_edges: topo_report.boundary_edges,
            non_manifold_edges: topo_report.non_manifold_edges,
            axes,
            layers: stats.iter().map(|s| (s.axis, s.layers)).collect(),
            notes: surface.note().map(String::from).into_iter().collect(),
        };
        Ok(Voxelization { grid, report })
    }
}

/// A Gregory surface on the GPU: one bicubic Gregory patch per cage quad, evaluated into a device-local
/// vertex buffer on a (level+1)² grid per patch (vertex `j·(L+1)+i` at (i/L, j/L), u along the face's
/// first edge).
pub struct Surface<'g> {
    gpu: &'g Gpu,
    inner: GregorySurface,
    rest: Vec<DVec3>,
    note: Option<String>,
}

impl Surface<'_> {
    /// Re-evaluates the surface of the rest cage, or of the cage moved by `deform` on the GPU.
    fn evaluate(&self, deform: Option<&DeformParams>) -> Result<()> {
        let ctx = &self.gpu.ctx;
        ctx.one_shot(|cmd| self.inner.record(ctx, cmd, deform, None))
    }

    /// Moves the cage on the GPU by a built-in deformation at time `t` (seconds) with `amplitude` (a fraction
    /// of the cage's size) and re-evaluates the surface; [`Deformation::None`] restores the rest cage.
    pub fn deform(&mut self, mode: Deformation, t: f32, amplitude: f32) -> Result<()> {
        if !t.is_finite() || !amplitude.is_finite() {
            return Err(Error::Invalid(format!(
                "deformation time {t} and amplitude {amplitude} must be finite"
            )));
        }
        let params = DeformParams {
            mode,
            t,
            amplitude,
            box_min: self.inner.box_min(),
            box_size: self.inner.box_size(),
        };
        self.evaluate(Some(&params))
    }

    /// Uploads new cage positions (one per cage vertex, in the cage's order) and re-evaluates the surface.
    pub fn set_cage(&mut self, positions: &[DVec3]) -> Result<()> {
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::Invalid(format!(
                "cage vertex {} is not finite: {:?}",
                i + 1,
                positions[i]
            )));
        }
        let ctx = &self.gpu.ctx;
        ctx.one_shot(|cmd| self.inner.record_cage_update(ctx, cmd, positions))
    }

    /// Switches the tessellation level (1–64) and re-evaluates the rest cage.
    pub fn set_level(&mut self, level: u32) -> Result<()> {
        self.inner.set_level(&self.gpu.ctx, level)?;
        self.evaluate(None)
    }

    /// Reads the evaluated positions and unit normals back, patch after patch.
    pub fn read_vertices(&self) -> Result<Vec<SurfaceVertex>> {
        self.inner.read_vertices(&self.gpu.ctx)
    }

    /// Triangles of the uniform grids (two per grid cell, counter-clockwise seen from the normal side).
    pub fn indices(&self) -> Vec<u32> {
        grid_indices(self.inner.patch_count(), self.inner.level())
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
