//! Tessellation as one call: a quad cage (ACC-2 Gregory patches) or Beziex patches evaluated on the GPU by
//! the compute path or the vertex-pull path, uniformly or with screen-space adaptive levels, and read back
//! in the contract order of docs/ARCHITECTURE.md (one (L+1)² grid per patch, rows of u inner).
//!
//! Invariants: every check on the input happens before any GPU work; the vertices come back exactly as the
//! GPU wrote them (the compute and vertex-pull paths agree bit for bit on the same points).
use super::{Cage, Deformation, Gpu, Mesh, Tangents};
use crate::engine::cage::{
    cage_jumps, max_jump_coincident, tagged_cage_topologies, CageJumps, UvTopology,
};
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
use std::collections::HashMap;
use std::path::Path;

/// Where patches come from.
pub enum Patches {
    /// A quad cage's ACC-2 Gregory patches (a non-quad cage refined once; `note` says so).
    Cage {
        topology: GregoryTopology,
        rest: Vec<DVec3>,
        note: Option<String>,
        /// The UV surface's layout when the cage has UVs (patch `k` is patch `k` of `topology`).
        uv: Option<Box<UvTopology>>,
    },
    /// Beziex patches (the "Beziex patch 2019" format).
    Beziex(Vec<BeziexPatch>),
    /// A cage whose uniform refinement would pass [`crate::surface::acc2::MAX_REFINED_PATCHES`] (semi-sharp
    /// features on a large cage): its feature-adaptive patches, tessellated per ptex face on the host
    /// ([`crate::surface::ptex_grid`]: crack-free where patches of different depths meet).
    Ptex {
        cage: Box<Cage>,
        evaluator: Box<crate::surface::LimitEvaluator>,
        /// The patches (for the device when the cage deforms, and to move the cage).
        adaptive: Box<crate::surface::adaptive::AdaptiveStencils>,
        note: Option<String>,
    },
}

impl Patches {
    /// The Gregory patches of a cage with the given edge-point masks.
    pub fn from_cage(cage: &Mesh, tangents: Tangents) -> Result<Patches> {
        Patches::from_tagged_cage(&Cage::from(cage.clone()), tangents)
    }

    /// The Gregory patches of a tagged cage (creases, corners, holes, boundary rule).
    pub fn from_tagged_cage(cage: &Cage, tangents: Tangents) -> Result<Patches> {
        let as_mesh_error = |e| match e {
            Error::Invalid(msg) => Error::Mesh(msg),
            e => e,
        };
        let uniform = crate::surface::acc2::uniform_patch_count(cage).map_err(as_mesh_error)?;
        if uniform > crate::surface::acc2::MAX_REFINED_PATCHES {
            crate::engine::cage::check_cage_valence(&cage.mesh).map_err(as_mesh_error)?;
            let a = crate::surface::adaptive::AdaptiveStencils::from_cage(cage, tangents)
                .map_err(as_mesh_error)?;
            let evaluator = crate::surface::LimitEvaluator::from_adaptive(cage, &a)
                .and_then(|e| e.with_uv(cage, a.levels))
                .map_err(as_mesh_error)?;
            let note = format!(
                "the cage's uniform refinement to level {} would make {uniform} patches, past {}: \
                 tessellated per ptex face (one grid a face, evaluated on the host) over its {} \
                 feature-adaptive patches",
                a.levels,
                crate::surface::acc2::MAX_REFINED_PATCHES,
                a.stencils.patch_points.len()
            );
            return Ok(Patches::Ptex {
                cage: Box::new(cage.clone()),
                evaluator: Box::new(evaluator),
                adaptive: Box::new(a),
                note: Some(note),
            });
        }
        let t = tagged_cage_topologies(cage, tangents, true).map_err(as_mesh_error)?;
        Ok(Patches::Cage {
            topology: t.topology,
            rest: t.rest,
            note: t.note,
            uv: t.uv.map(Box::new),
        })
    }

    /// Loads `.gzjson`/`.json` as Beziex patches, anything else as a cage (an OBJ with its OpenSubdiv tags);
    /// errors name the file.
    pub fn load(path: &Path, tangents: Tangents) -> Result<Patches> {
        if is_beziex(path) {
            return Ok(Patches::Beziex(load_beziex(path)?));
        }
        Patches::from_tagged_cage(&super::load_cage(path)?, tangents).map_err(|e| e.for_input(path))
    }

    /// Number of patches.
    pub fn count(&self) -> u32 {
        match self {
            Patches::Cage { topology, .. } => topology.patch_points.len() as u32,
            Patches::Beziex(p) => p.len() as u32,
            Patches::Ptex { evaluator, .. } => evaluator.ptex_faces() as u32,
        }
    }

    /// What was done to the input before building patches, if anything.
    pub fn note(&self) -> Option<&str> {
        match self {
            Patches::Cage { note, .. } | Patches::Ptex { note, .. } => note.as_deref(),
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
            Patches::Ptex { cage, .. } => {
                for p in &cage.mesh.positions {
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
    /// The UVs of every vertex (a cage with UVs), from the UV surface evaluated on the same grids (the
    /// uniform ones, or the adaptive levels and snapped edge rows): OpenSubdiv's face-varying limit,
    /// discontinuous across seams.
    pub uvs: Option<Vec<[f32; 2]>>,
}

impl Tessellation {
    /// The triangles (two per grid cell) over `vertices`.
    pub fn indices(&self) -> Vec<u32> {
        match &self.levels {
            Some(l) => compact_grid_indices(l),
            None => grid_indices(self.patches, self.level),
        }
    }

    /// The largest normal jump (rad) across shared patch edges, away from a cage's singular points (NaN
    /// for adaptive grids, whose edges the uniform matcher does not pair).
    pub fn max_normal_jump(&self, patches: &Patches) -> f64 {
        match (patches, &self.levels) {
            (_, Some(_)) | (Patches::Ptex { .. }, _) => f64::NAN,
            (Patches::Beziex(_), None) => max_jump_coincident(&self.vertices, self.level),
            (Patches::Cage { .. }, None) => self.cage_jumps(patches).map_or(f64::NAN, |j| j.worst),
        }
    }

    /// A uniform cage tessellation's normal jumps: across shared edges, and at each singular point (an
    /// interior cage vertex of valence 2) with its position in the tessellation's frame (add
    /// [`Tessellation::origin`] for the world). `None` for Beziex patches and adaptive grids.
    pub fn cage_jumps(&self, patches: &Patches) -> Option<CageJumps> {
        match (patches, &self.levels) {
            (Patches::Cage { topology, .. }, None) => {
                Some(cage_jumps(topology, &self.vertices, self.level))
            }
            _ => None,
        }
    }

    /// The surface as one indexed mesh: vertices at bit-identical positions (every shared patch edge and
    /// corner of a cage, whose samples the evaluator makes equal bit for bit, and the snapped rows of an
    /// adaptive tessellation) merged into one, in order of first appearance, with the normalized mean of
    /// their normals; triangles that a merge collapsed (the snapped rows where an adaptive patch is finer
    /// than its edge) dropped. A closed cage gives a closed, watertight mesh. UVs are welded on their own
    /// (one per welded vertex and UV value, with per-triangle UV indices), so seams do not open the mesh.
    pub fn welded(&self) -> WeldedMesh {
        let mut index: HashMap<[u32; 3], u32> = HashMap::with_capacity(self.vertices.len());
        let mut remap = Vec::with_capacity(self.vertices.len());
        let mut positions = Vec::new();
        let mut sums: Vec<DVec3> = Vec::new();
        let mut first_normal: Vec<[f32; 3]> = Vec::new();
        // UVs are indexed on their own (OBJ's `f v/vt/vn`): one per (welded vertex, UV bits), so the
        // mesh stays watertight by position while a seam keeps its two UVs.
        let mut uv_index: HashMap<(u32, [u32; 2]), u32> = HashMap::new();
        let mut uv_remap = Vec::new();
        let mut uvs = Vec::new();
        for (k, v) in self.vertices.iter().enumerate() {
            let next = positions.len() as u32;
            let (position, normal) = (v.xyz(), v.normal_xyz());
            let id = *index.entry(v.position_key()).or_insert(next);
            if id == next {
                positions.push(position);
                sums.push(DVec3::ZERO);
                first_normal.push(normal);
            }
            let n = DVec3::from(normal.map(f64::from));
            if n.is_finite() {
                sums[id as usize] += n;
            }
            remap.push(id);
            if let Some(all) = &self.uvs {
                let uv = all[k];
                let next_uv = uvs.len() as u32;
                let t = *uv_index
                    .entry((id, uv.map(f32::to_bits)))
                    .or_insert(next_uv);
                if t == next_uv {
                    uvs.push(uv);
                }
                uv_remap.push(t);
            }
        }
        let normals = sums
            .iter()
            .zip(&first_normal)
            .map(|(s, first)| {
                // Opposite normals (a sheet folded onto itself) cancel: keep the first patch's normal.
                if s.length() > 1e-6 {
                    let n = s.normalize();
                    [n.x as f32, n.y as f32, n.z as f32]
                } else {
                    *first
                }
            })
            .collect();
        // The grids' own triangulation cuts every cell along (i, j)–(i+1, j+1), which leaves the corners
        // (L, 0) and (0, L) off the diagonal. At a valence-2 cage vertex two patches meet with both corner
        // cells cut between the same two edge samples, so welded that edge would have four triangles: cut
        // those two corner cells along the other diagonal, through the corner (any cut is the same surface).
        let levels: Vec<u32> = match &self.levels {
            Some(l) => l.clone(),
            None => vec![self.level; self.patches as usize],
        };
        // At level 1 one cell holds all four corners: cut it through the corners where its usual diagonal
        // is the diagonal of another level-1 cell too (the two patches at a valence-2 vertex).
        let diagonal = |a: u32, c: u32| {
            let (a, c) = (remap[a as usize], remap[c as usize]);
            (a.min(c), a.max(c))
        };
        let mut level_one_diagonals: HashMap<(u32, u32), u32> = HashMap::new();
        let mut base = 0u32;
        for &l in &levels {
            if l == 1 {
                *level_one_diagonals
                    .entry(diagonal(base, base + 3))
                    .or_default() += 1;
            }
            base += (l + 1) * (l + 1);
        }
        let mut triangles = Vec::with_capacity(self.vertices.len() * 2);
        let mut uv_triangles = Vec::new();
        let mut base = 0u32;
        for &l in &levels {
            let n = l + 1;
            for j in 0..l {
                for i in 0..l {
                    let a = base + j * n + i;
                    let (b, c, d) = (a + 1, a + n + 1, a + n);
                    let through_corner = if l == 1 {
                        level_one_diagonals[&diagonal(a, c)] > 1
                    } else {
                        (i == l - 1 && j == 0) || (i == 0 && j == l - 1)
                    };
                    let cell = if through_corner {
                        [[a, b, d], [b, c, d]]
                    } else {
                        [[a, b, c], [a, c, d]]
                    };
                    for c in cell {
                        let t = c.map(|k| remap[k as usize]);
                        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                            triangles.push(t);
                            if !uv_remap.is_empty() {
                                uv_triangles.push(c.map(|k| uv_remap[k as usize]));
                            }
                        }
                    }
                }
            }
            base += n * n;
        }
        WeldedMesh {
            positions,
            normals,
            triangles,
            uvs: self.uvs.as_ref().map(|_| WeldedUvs {
                uvs,
                triangles: uv_triangles,
            }),
        }
    }

    /// Writes OBJ atomically: `v` and `vn` per vertex (and `vt`: welded, indexed on their own), 1-based
    /// `a//a` (`a/t/a`) triangles and a header comment (with
    /// the per-patch levels of an adaptive tessellation in a `# levels` comment). `weld`: the
    /// [`Tessellation::welded`] mesh; otherwise one (L+1)² grid per patch in the contract order.
    /// Returns the numbers of vertices and triangles written.
    pub fn write_obj(&self, path: &Path, weld: bool) -> Result<(usize, usize)> {
        let welded = weld.then(|| self.welded());
        let written = match &welded {
            Some(m) => (m.positions.len(), m.triangles.len()),
            None => (self.vertices.len(), self.indices().len() / 3),
        };
        write_atomic(path, |w| {
            match &self.levels {
                Some(levels) => {
                    writeln!(
                        w,
                        "# gregvox tessellate --adaptive: {} patches, patch p at level L_p",
                        levels.len()
                    )?;
                    let list: Vec<String> = levels.iter().map(|l| l.to_string()).collect();
                    writeln!(w, "# levels {}", list.join(" "))?;
                }
                None => writeln!(
                    w,
                    "# gregvox tessellate: {} patches at level {}",
                    self.patches, self.level
                )?,
            }
            match &welded {
                Some(m) => writeln!(
                    w,
                    "# welded: {} vertices, {} triangles (shared patch edges merged; --no-weld writes one \
                     grid per patch)",
                    m.positions.len(),
                    m.triangles.len()
                )?,
                None => writeln!(
                    w,
                    "# not welded: one grid per patch, (L+1)^2 vertices each, rows of u inner"
                )?,
            }
            let o = self.origin;
            let unwelded: (Vec<[f32; 3]>, Vec<[f32; 3]>);
            let (positions, normals) = match &welded {
                Some(m) => (&m.positions, &m.normals),
                None => {
                    unwelded = self
                        .vertices
                        .iter()
                        .map(|v| (v.xyz(), v.normal_xyz()))
                        .unzip();
                    (&unwelded.0, &unwelded.1)
                }
            };
            for p in positions {
                // At the origin f32's own shortest digits (the file as before); away from it, f64's.
                if o == [0.0; 3] {
                    writeln!(w, "v {} {} {}", p[0], p[1], p[2])?;
                } else {
                    let q = [0, 1, 2].map(|k| p[k] as f64 + o[k]);
                    writeln!(w, "v {} {} {}", q[0], q[1], q[2])?;
                }
            }
            for n in normals {
                writeln!(w, "vn {} {} {}", n[0], n[1], n[2])?;
            }
            // UVs: their own list and indices (welded), or one per vertex (unwelded).
            let uvs: Option<&Vec<[f32; 2]>> = match &welded {
                Some(m) => m.uvs.as_ref().map(|u| &u.uvs),
                None => self.uvs.as_ref(),
            };
            for t in uvs.into_iter().flatten() {
                writeln!(w, "vt {} {}", t[0], t[1])?;
            }
            let with_uv = uvs.is_some();
            let mut face = |t: [u32; 3], uv: [u32; 3]| {
                let (a, b, c) = (t[0] + 1, t[1] + 1, t[2] + 1);
                if with_uv {
                    let (ta, tb, tc) = (uv[0] + 1, uv[1] + 1, uv[2] + 1);
                    writeln!(w, "f {a}/{ta}/{a} {b}/{tb}/{b} {c}/{tc}/{c}")
                } else {
                    writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")
                }
            };
            match &welded {
                Some(m) => match &m.uvs {
                    Some(u) => m
                        .triangles
                        .iter()
                        .zip(&u.triangles)
                        .try_for_each(|(t, u)| face(*t, *u))?,
                    None => m.triangles.iter().try_for_each(|t| face(*t, *t))?,
                },
                None => self.indices().chunks_exact(3).try_for_each(|t| {
                    let t = [t[0], t[1], t[2]];
                    face(t, t)
                })?,
            }
            Ok(())
        })?;
        Ok(written)
    }
}

/// A tessellation as one indexed triangle mesh ([`Tessellation::welded`]), in the local frame of
/// [`Tessellation::origin`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WeldedMesh {
    pub positions: Vec<[f32; 3]>,
    /// Unit normals, one per position.
    pub normals: Vec<[f32; 3]>,
    /// With the orientation of the patch grids.
    pub triangles: Vec<[u32; 3]>,
    /// With UVs: indexed on their own, one per welded vertex and UV value, so a seam's vertex has one UV
    /// per side while the mesh stays watertight.
    pub uvs: Option<WeldedUvs>,
}

/// The UVs of a [`WeldedMesh`]: the values and, per triangle, its corners' UV indices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WeldedUvs {
    pub uvs: Vec<[f32; 2]>,
    pub triangles: Vec<[u32; 3]>,
}

/// The adaptive parameters for a cage with bounding box `box_min + [0, box_size]`.
/// The deformation `opts` asks for (one frame at t = 1 s) over `surface`'s box.
fn deform_params(opts: &TessellateOptions, surface: &GregorySurface) -> Option<DeformParams> {
    opts.deform.map(|(mode, amplitude)| DeformParams {
        mode,
        t: 1.0,
        amplitude,
        box_min: surface.box_min(),
        box_size: surface.box_size(),
    })
}

/// The adaptive parameters `tessellate` derives from `a` for a cage whose box is (`box_min`, `box_size`):
/// a renderer that records a [`crate::api::Surface`] with them draws the grids `tessellate --adaptive`
/// writes.
pub fn adaptive_params(a: &AdaptiveView, box_min: [f32; 3], box_size: [f32; 3]) -> AdaptiveParams {
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

/// Host bytes per patch of the set-up (stencils kept on the host, their GPU copy and its staging, the
/// control points): measured at about 3 KB (a regular 187 k-quad torus peaks at 558 MB at level 1 on
/// lavapipe, whose device memory is host memory), with a margin.
const SETUP_BYTES_PER_PATCH: u128 = 3_500;
/// Host bytes per output vertex: the device buffer (32 B, host memory on a CPU device), its read-back (32 B),
/// the weld (positions, normals, sums, the index map: about 70 B) and two triangles (24 B), with a margin.
const BYTES_PER_VERTEX: u128 = 192;

/// The memory a tessellation of `patches` patches at (at most) `level` needs, in bytes.
pub fn tessellation_bytes(patches: u32, level: u32) -> u128 {
    let per_patch = (level as u128 + 1).pow(2);
    patches as u128 * (SETUP_BYTES_PER_PATCH + per_patch * BYTES_PER_VERTEX)
}

fn check(patches: &Patches, opts: &TessellateOptions) -> Result<()> {
    opts.validate()?;
    // The size guard: refuse with the estimate before any GPU work, instead of an abort half-way.
    let need = tessellation_bytes(patches.count(), opts.level);
    if let Some(free) = crate::io::host_memory_available() {
        if need > free as u128 {
            let vertices = patches.count() as u128 * (opts.level as u128 + 1).pow(2);
            return Err(Error::Invalid(format!(
                "--level {}: {} patches make about {} M vertices and need about {} MiB of memory, more \
                 than the {} MiB available (lower --level, or use --adaptive)",
                opts.level,
                patches.count(),
                (vertices / 1_000_000).max(1),
                need >> 20,
                free >> 20
            )));
        }
    }
    if let Patches::Ptex { .. } = patches {
        if opts.adaptive.is_some() || opts.path == EvalPath::Vertex {
            return Err(Error::Mesh(
                "--adaptive and --path vertex work on the uniform patch layout; this cage is past its limit \
                 and is tessellated per ptex face"
                    .into(),
            ));
        }
    }
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
            uvs: None,
        };
        let shift = |p: DVec3| p - DVec3::from(origin);
        match patches {
            Patches::Ptex {
                cage,
                evaluator,
                adaptive,
                ..
            } if opts.deform.is_some() => {
                // The cage deforms on the device: the same grids, evaluated by the ptex layout's pass after
                // the deformation and W·cage (in the local frame); the UVs, which do not move, on the host.
                let mut local = (**cage).clone();
                for p in &mut local.mesh.positions {
                    *p = shift(*p);
                }
                let map = crate::surface::PtexMap::from_tree(&local, &adaptive.tree);
                let topology = crate::engine::cage::adaptive_topology(adaptive);
                let mut surface = GregorySurface::new_ptex(ctx, &topology, &local, map, level)?;
                let params = deform_params(opts, &surface);
                for _ in 0..opts.repeat {
                    surface.evaluate(ctx, params.as_ref(), Some(&mut *profiler))?;
                }
                let levels = surface.ptex_levels().unwrap_or_default().to_vec();
                let top = levels.iter().copied().max().unwrap_or(level);
                let uniform = levels.iter().all(|&l| l == top);
                let uvs = match (evaluator.has_uv(), surface.ptex_grid_points()) {
                    (true, Some(at)) => Some(
                        evaluator
                            .evaluate_uv(at)?
                            .iter()
                            .map(|t| [t[0] as f32, t[1] as f32])
                            .collect(),
                    ),
                    _ => None,
                };
                Ok(Tessellation {
                    vertices: surface.read_vertices(ctx)?,
                    patches: levels.len() as u32,
                    level: top,
                    levels: (!uniform).then_some(levels),
                    origin,
                    uvs,
                })
            }
            Patches::Ptex {
                cage, evaluator, ..
            } => {
                let g = crate::surface::ptex_grid::ptex_grids(cage, evaluator, level)?;
                let vertices = g
                    .positions
                    .iter()
                    .zip(&g.normals)
                    .map(|(&p, n)| {
                        let p = shift(p);
                        SurfaceVertex {
                            position: [p.x as f32, p.y as f32, p.z as f32, 1.0],
                            normal: [n.x as f32, n.y as f32, n.z as f32, 0.0],
                        }
                    })
                    .collect();
                let top = g.levels.iter().copied().max().unwrap_or(level);
                let uniform = g.levels.iter().all(|&l| l == top);
                Ok(Tessellation {
                    vertices,
                    patches: g.levels.len() as u32,
                    level: top,
                    levels: (!uniform).then_some(g.levels),
                    origin,
                    uvs: g
                        .uvs
                        .map(|u| u.iter().map(|t| [t[0] as f32, t[1] as f32]).collect()),
                })
            }
            Patches::Cage {
                topology, rest, uv, ..
            } => {
                // UVs: the UV surface on the same uniform grids (deformation moves positions only); with
                // adaptive levels, on the positions' grids once they are known (below).
                let mut uv_surface = match uv {
                    Some(uv) => Some(GregorySurface::new(ctx, &uv.topology, &uv.values, level)?),
                    None => None,
                };
                let uvs: Option<Vec<[f32; 2]>> = match uv_surface.as_mut() {
                    Some(s) if opts.adaptive.is_none() => {
                        s.evaluate(ctx, None, None)?;
                        Some(
                            s.read_vertices(ctx)?
                                .iter()
                                .map(SurfaceVertex::uv)
                                .collect(),
                        )
                    }
                    _ => None,
                };
                let done = |vertices, levels| Tessellation {
                    uvs: uvs.clone(),
                    ..done(vertices, levels)
                };
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
                let params = deform_params(opts, &surface);
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
                    // The device's evaluator: the host kernel on CPU devices (GregorySurface::evaluate).
                    surface.evaluate(ctx, params.as_ref(), Some(&mut *profiler))?;
                }
                if opts.adaptive.is_some() {
                    let (v, l) = surface.read_adaptive_grids(ctx)?;
                    let uvs = match &uv_surface {
                        Some(s) => Some(
                            surface
                                .read_adaptive_grids_of(ctx, s)?
                                .iter()
                                .map(SurfaceVertex::uv)
                                .collect(),
                        ),
                        None => None,
                    };
                    return Ok(Tessellation {
                        uvs,
                        ..done(v, Some(l))
                    });
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
