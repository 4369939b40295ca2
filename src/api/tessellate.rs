//! Tessellation as one call: a quad cage (ACC-2 Gregory patches) or Beziex patches evaluated on the GPU by
//! the compute path or the vertex-pull path, uniformly or with screen-space adaptive levels, and read back
//! in the contract order of docs/ARCHITECTURE.md (one (L+1)² grid per patch, rows of u inner).
//!
//! Invariants: every check on the input happens before any GPU work; the vertices come back exactly as the
//! GPU wrote them (the compute and vertex-pull paths agree bit for bit on the same points).
use super::{Deformation, Gpu, Mesh, Tangents};
use crate::engine::cage::{cage_topology, max_jump_coincident, max_jump_shared_edges};
use crate::engine::gregory::{GregorySurface, GregoryTopology};
use crate::engine::vertex_pull::vertex_pull;
use crate::error::{Error, Result};
use crate::gpu::{MemoryLocation, Profiler};
use crate::io::write_atomic;
use crate::passes::adaptive_levels::{compact_grid_indices, AdaptiveParams};
use crate::passes::beziex_eval::BeziexEvalPass;
use crate::passes::cage_deform::DeformParams;
use crate::passes::gregory_eval::{
    grid_indices, vertex_count, ControlPoints, SurfaceVertex, MAX_LEVEL,
};
use crate::passes::patch_pull::PatchKind;
use crate::surface::beziex::{load_beziex, BeziexPatch};
use ash::vk;
use glam::DVec3;
use std::path::Path;

/// Where patches come from.
pub enum Patches {
    /// A quad cage's ACC-2 Gregory patches (a non-quad cage refined once; `note` says so).
    Cage {
        topology: GregoryTopology,
        rest: Vec<DVec3>,
        note: Option<String>,
    },
    /// Beziex patches (the "Beziex patch 2019" format).
    Beziex(Vec<BeziexPatch>),
}

impl Patches {
    /// The Gregory patches of a cage with the given edge-point masks.
    pub fn from_cage(cage: &Mesh, tangents: Tangents) -> Result<Patches> {
        let (topology, rest, note) = cage_topology(cage, tangents).map_err(|e| match e {
            Error::Invalid(msg) => Error::Mesh(msg),
            e => e,
        })?;
        Ok(Patches::Cage {
            topology,
            rest,
            note,
        })
    }

    /// Loads `.gzjson`/`.json` as Beziex patches, anything else as a cage mesh; errors name the file.
    pub fn load(path: &Path, tangents: Tangents) -> Result<Patches> {
        if is_beziex(path) {
            return Ok(Patches::Beziex(load_beziex(path)?));
        }
        Patches::from_cage(&super::load_mesh(path)?, tangents).map_err(|e| e.for_input(path))
    }

    /// Number of patches.
    pub fn count(&self) -> u32 {
        match self {
            Patches::Cage { topology, .. } => topology.patch_points.len() as u32,
            Patches::Beziex(p) => p.len() as u32,
        }
    }

    /// What was done to the input before building patches, if anything.
    pub fn note(&self) -> Option<&str> {
        match self {
            Patches::Cage { note, .. } => note.as_deref(),
            Patches::Beziex(_) => None,
        }
    }
}

impl Patches {
    /// The minimum corner of the cage's used vertices or of every control point (f64): positions are
    /// evaluated relative to it (see [`Tessellation::origin`]). Models near the world origin (not
    /// `api::is_far`) keep it, so their output is bit for bit what it was.
    pub fn local_origin(&self) -> [f64; 3] {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        match self {
            Patches::Cage { rest, .. } => {
                for p in rest {
                    lo = lo.min(*p);
                    hi = hi.max(*p);
                }
            }
            Patches::Beziex(list) => {
                for p in list.iter().flat_map(|p| p.ra.iter().chain(&p.rb)).flatten() {
                    lo = lo.min(*p);
                    hi = hi.max(*p);
                }
            }
        }
        if super::is_far(lo.to_array(), hi.to_array()) {
            lo.to_array()
        } else {
            [0.0; 3]
        }
    }
}

/// Whether `path` names a Beziex model (by extension).
pub fn is_beziex(path: &Path) -> bool {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    ext == "gzjson" || ext == "json"
}

/// How patches are evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum EvalPath {
    /// Compute shader into a device-local vertex buffer.
    Compute,
    /// Instanced grid whose vertex shader evaluates the patches (the Beziex seed's method).
    Vertex,
}

/// The screen-space view of adaptive tessellation.
#[derive(Clone, Copy, Debug)]
pub struct AdaptiveView {
    /// Target pixels per tessellation segment on screen.
    pub pixels_per_segment: f32,
    /// The eye, looking at the cage's bounding-box centre (up +Y, 45° vertical field of view); `None`: on
    /// +Z, 1.5 bounding-box diagonals from the centre.
    pub eye: Option<[f32; 3]>,
    /// The viewport in pixels.
    pub viewport: [f32; 2],
}

/// What [`Gpu::tessellate`] does.
#[derive(Clone, Copy, Debug)]
pub struct TessellateOptions {
    /// The level L (1–64): (L+1)² vertices per patch; with `adaptive`, the maximum.
    pub level: u32,
    pub path: EvalPath,
    /// One frame of cage animation (at t = 1 s) before evaluation: the mode and its amplitude.
    pub deform: Option<(Deformation, f32)>,
    /// Per-patch screen-space levels (compute path, cages only).
    pub adaptive: Option<AdaptiveView>,
    /// Run the GPU passes this many times (for timing).
    pub repeat: u32,
}

impl Default for TessellateOptions {
    fn default() -> Self {
        TessellateOptions {
            level: 8,
            path: EvalPath::Compute,
            deform: None,
            adaptive: None,
            repeat: 1,
        }
    }
}

/// Evaluated patches.
pub struct Tessellation {
    /// Positions and unit normals, patch after patch.
    pub vertices: Vec<SurfaceVertex>,
    pub patches: u32,
    /// The uniform level, or the maximum with adaptive levels.
    pub level: u32,
    /// Per-patch levels of an adaptive tessellation (patch p holds (L_p+1)² vertices).
    pub levels: Option<Vec<u32>>,
    /// The local origin the `vertices` positions are relative to (world = position + origin, added in
    /// f64 by [`Tessellation::write_obj`]): the minimum corner of the cage or control points, so a model
    /// 10⁷ units from the world origin keeps its f32 precision (a unit cube there once came out as three
    /// x values).
    pub origin: [f64; 3],
}

impl Tessellation {
    /// The triangles (two per grid cell) over `vertices`.
    pub fn indices(&self) -> Vec<u32> {
        match &self.levels {
            Some(l) => compact_grid_indices(l),
            None => grid_indices(self.patches, self.level),
        }
    }

    /// The largest normal jump (rad) across shared patch edges (NaN for adaptive grids, whose edges the
    /// uniform matcher does not pair).
    pub fn max_normal_jump(&self, patches: &Patches) -> f64 {
        match (patches, &self.levels) {
            (_, Some(_)) => f64::NAN,
            (Patches::Beziex(_), None) => max_jump_coincident(&self.vertices, self.level),
            (Patches::Cage { topology, .. }, None) => {
                max_jump_shared_edges(topology, &self.vertices, self.level)
            }
        }
    }

    /// Writes OBJ: `v` and `vn` per vertex, the grid triangles (1-based `a//a`), a header comment (and the
    /// per-patch levels of an adaptive tessellation in a `# levels` comment), atomically.
    pub fn write_obj(&self, path: &Path) -> Result<()> {
        write_atomic(path, |w| {
            match &self.levels {
                Some(levels) => {
                    writeln!(
                        w,
                        "# gregvox tessellate --adaptive: {} patches, patch p has (L_p+1)^2 vertices",
                        levels.len()
                    )?;
                    let list: Vec<String> = levels.iter().map(|l| l.to_string()).collect();
                    writeln!(w, "# levels {}", list.join(" "))?;
                }
                None => writeln!(
                    w,
                    "# gregvox tessellate: {} patches at level {}, (level+1)^2 vertices per patch",
                    self.patches, self.level
                )?,
            }
            let o = self.origin;
            for v in &self.vertices {
                let p = [
                    v.position[0] as f64 + o[0],
                    v.position[1] as f64 + o[1],
                    v.position[2] as f64 + o[2],
                ];
                // At the origin f32's own shortest digits (the file as before); away from it, f64's.
                if o == [0.0; 3] {
                    writeln!(w, "v {} {} {}", v.position[0], v.position[1], v.position[2])?;
                } else {
                    writeln!(w, "v {} {} {}", p[0], p[1], p[2])?;
                }
            }
            for v in &self.vertices {
                writeln!(w, "vn {} {} {}", v.normal[0], v.normal[1], v.normal[2])?;
            }
            for t in self.indices().chunks(3) {
                let (a, b, c) = (t[0] + 1, t[1] + 1, t[2] + 1);
                writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
            }
            Ok(())
        })
    }
}

/// The adaptive parameters for a cage with bounding box `box_min + [0, box_size]`.
fn adaptive_params(a: &AdaptiveView, box_min: [f32; 3], box_size: [f32; 3]) -> AdaptiveParams {
    let size = glam::Vec3::from(box_size);
    let centre = glam::Vec3::from(box_min) + 0.5 * size;
    let d = size.length().max(f32::MIN_POSITIVE);
    let eye = a
        .eye
        .map_or(centre + glam::Vec3::Z * 1.5 * d, glam::Vec3::from);
    let forward = (centre - eye).normalize_or_zero();
    let up = if forward.cross(glam::Vec3::Y).length() < 1e-3 {
        glam::Vec3::Z
    } else {
        glam::Vec3::Y
    };
    let dist = (centre - eye).length();
    let proj = glam::Mat4::perspective_rh(
        45f32.to_radians(),
        a.viewport[0] / a.viewport[1],
        (1e-3 * d).max(1e-6 * dist),
        dist + 10.0 * d,
    );
    AdaptiveParams {
        view_proj: proj * glam::Mat4::look_at_rh(eye, centre, up),
        viewport: a.viewport,
        pixels_per_segment: a.pixels_per_segment,
    }
}

impl TessellateOptions {
    /// Checks the options that do not depend on the patches (before any loading or GPU work).
    pub fn validate(&self) -> Result<()> {
        let opts = self;
        let bad = |m: &str| Err(Error::Invalid(m.into()));
        if !(1..=MAX_LEVEL).contains(&opts.level) {
            return Err(Error::Invalid(format!(
            "--level {} is out of range: the tessellation level must be between 1 and {MAX_LEVEL}",
            opts.level
        )));
        }
        if opts.repeat == 0 {
            return bad("--repeat must be at least 1");
        }
        if let Some(a) = &opts.adaptive {
            if !(a.pixels_per_segment > 0.0 && a.pixels_per_segment.is_finite()) {
                return Err(Error::Invalid(format!(
                    "--adaptive {}: the pixels per segment must be a positive number",
                    a.pixels_per_segment
                )));
            }
            if opts.path != EvalPath::Compute {
                return bad("--adaptive runs on the compute path only");
            }
        }
        Ok(())
    }
}

fn check(patches: &Patches, opts: &TessellateOptions) -> Result<()> {
    opts.validate()?;
    if let Patches::Beziex(_) = patches {
        if opts.deform.is_some() {
            return Err(Error::Mesh(
                "--deform animates a cage; this is a Beziex model".into(),
            ));
        }
        if opts.adaptive.is_some() {
            return Err(Error::Mesh(
                "--adaptive tessellates ACC-2 cages; this is a Beziex model".into(),
            ));
        }
    }
    Ok(())
}

impl Gpu {
    /// Evaluates `patches` as `opts` says, recording per-pass GPU times into `profiler` (`gregory_eval`,
    /// `beziex_eval` or `vertex_pull` is the evaluation itself).
    pub fn tessellate(
        &self,
        patches: &Patches,
        opts: &TessellateOptions,
        profiler: &mut Profiler,
    ) -> Result<Tessellation> {
        check(patches, opts)?;
        let ctx = self.context();
        let level = opts.level;
        let origin = patches.local_origin();
        let done = |vertices, levels| Tessellation {
            vertices,
            patches: patches.count(),
            level,
            levels,
            origin,
        };
        let shift = |p: DVec3| p - DVec3::from(origin);
        match patches {
            Patches::Cage { topology, rest, .. } => {
                let local: Vec<DVec3> = rest.iter().map(|&p| shift(p)).collect();
                let mut surface = GregorySurface::new(ctx, topology, &local, level)?;
                if let Some(a) = &opts.adaptive {
                    // The eye is given in world coordinates.
                    let mut a = *a;
                    a.eye = a.eye.map(|e| {
                        let e = shift(DVec3::new(e[0] as f64, e[1] as f64, e[2] as f64));
                        [e.x as f32, e.y as f32, e.z as f32]
                    });
                    let p = adaptive_params(&a, surface.box_min(), surface.box_size());
                    surface.set_adaptive(ctx, Some(p))?;
                }
                let params = opts.deform.map(|(mode, amplitude)| DeformParams {
                    mode,
                    t: 1.0,
                    amplitude,
                    box_min: surface.box_min(),
                    box_size: surface.box_size(),
                });
                if opts.path == EvalPath::Vertex {
                    // Points from the same deform + W·cage chain; the vertex shader evaluates the patches.
                    let ids: Vec<u32> = topology.patch_points.iter().flatten().copied().collect();
                    let pp = ctx.upload_buffer(
                        "patch points",
                        bytemuck::cast_slice(&ids),
                        vk::BufferUsageFlags::STORAGE_BUFFER,
                    )?;
                    ctx.one_shot(|cmd| surface.record(ctx, cmd, params.as_ref(), None))?;
                    let v = vertex_pull(
                        ctx,
                        PatchKind::Gregory,
                        surface.control_points(),
                        &pp,
                        surface.patch_count(),
                        level,
                        opts.repeat,
                        profiler,
                    )?;
                    return Ok(done(v, None));
                }
                for _ in 0..opts.repeat {
                    ctx.one_shot(|cmd| {
                        surface.record(ctx, cmd, params.as_ref(), Some((&mut *profiler, 0)))
                    })?;
                    profiler.collect(ctx, 0)?;
                }
                if opts.adaptive.is_some() {
                    let (v, l) = surface.read_adaptive_grids(ctx)?;
                    return Ok(done(v, Some(l)));
                }
                Ok(done(surface.read_vertices(ctx)?, None))
            }
            Patches::Beziex(list) => {
                let nets: Vec<[f32; 4]> = list
                    .iter()
                    .flat_map(|p| {
                        let mut local = p.clone();
                        for q in local.ra.iter_mut().chain(local.rb.iter_mut()).flatten() {
                            *q = shift(*q);
                        }
                        local.to_gpu()
                    })
                    .collect();
                let n = list.len() as u32;
                let nb = ctx.upload_buffer(
                    "beziex nets",
                    bytemuck::cast_slice(&nets),
                    vk::BufferUsageFlags::STORAGE_BUFFER,
                )?;
                if opts.path == EvalPath::Vertex {
                    let dummy = ctx.upload_buffer(
                        "no patch points",
                        &[0u8; 4],
                        vk::BufferUsageFlags::STORAGE_BUFFER,
                    )?;
                    let v = vertex_pull(
                        ctx,
                        PatchKind::Beziex,
                        ControlPoints::plain(&nb),
                        &dummy,
                        n,
                        level,
                        opts.repeat,
                        profiler,
                    )?;
                    return Ok(done(v, None));
                }
                let pass = BeziexEvalPass::new(ctx)?;
                let out = ctx.create_buffer(
                    "beziex vertices",
                    vertex_count(n, level) * 32,
                    vk::BufferUsageFlags::STORAGE_BUFFER
                        | vk::BufferUsageFlags::VERTEX_BUFFER
                        | vk::BufferUsageFlags::TRANSFER_SRC,
                    MemoryLocation::GpuOnly,
                )?;
                for _ in 0..opts.repeat {
                    ctx.one_shot(|cmd| {
                        profiler.scope(ctx, cmd, 0, "beziex_eval", || {
                            pass.record(ctx, cmd, &nb, n, level, &out)
                        })
                    })?;
                    profiler.collect(ctx, 0)?;
                }
                Ok(done(ctx.read_pod(&out)?, None))
            }
        }
    }
}
