//! Mesh reduction: one call ([`simplify`]) or a chain of levels of detail ([`simplify_lod`]), over
//! [`crate::mesh::simplify`] (the algorithm, its guarantees and its cost model are documented there).
//!
//! Invariants: the input is fan-triangulated (polygons) and never changed; the target is the first of
//! the face count, the ratio and the error bound that is reached; errors are lengths, reported absolute
//! and as a fraction of the input's bounding-box diagonal; an empty mesh or a target that is not a
//! finite non-negative number is an error naming the option.
use crate::error::{Error, Result};
use crate::mesh::simplify::{self as algo, Simplified};
use crate::mesh::Mesh;
use glam::DVec3;
use serde::Serialize;

pub use crate::mesh::simplify::Placement;

/// What to reduce to and what to keep. The reduction stops at the first target reached; with none, it
/// goes as far as the guarantees allow.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SimplifyOptions {
    /// Keep this fraction of the triangles (0 ..= 1).
    pub ratio: Option<f64>,
    /// Keep at most this many triangles.
    pub faces: Option<usize>,
    /// Stop before any collapse whose error exceeds this fraction of the bounding-box diagonal.
    pub error: Option<f64>,
    pub placement: Placement,
    /// Boundary vertices never move nor disappear.
    pub lock_border: bool,
    /// Allow collapses that change the topology (holes close, handles pinch, pieces vanish).
    pub allow_topology: bool,
    /// Remove the pieces whose bounding-box diagonal is at most this fraction of the mesh's (0: none).
    pub prune: f64,
}

/// What a reduction did (`gregvox simplify --json` prints one per level).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SimplifyReport {
    pub input_faces: usize,
    pub faces: usize,
    pub vertices: usize,
    /// The largest collapse error, a length in the mesh's units.
    pub error: f64,
    /// `error` as a fraction of the input's bounding-box diagonal.
    pub relative_error: f64,
    pub collapses: usize,
    pub passes: usize,
    pub locked_vertices: usize,
    pub pruned_faces: usize,
    pub seconds: f64,
}

/// A reduced mesh (triangles) with its report.
#[derive(Debug, Clone)]
pub struct SimplifiedMesh {
    pub mesh: Mesh,
    pub report: SimplifyReport,
    /// For every output vertex, the input vertex it stands for.
    pub source_vertex: Vec<u32>,
}

fn diagonal(p: &[DVec3]) -> f64 {
    let (lo, hi) = p.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &q| (lo.min(q), hi.max(q)),
    );
    if p.is_empty() {
        0.0
    } else {
        (hi - lo).length()
    }
}

/// The options checked, and the mesh's triangles (an error when there are none).
fn checked_triangles(mesh: &Mesh, opts: &SimplifyOptions) -> Result<Vec<[u32; 3]>> {
    let bad = |what: &str, v: f64| {
        Error::Invalid(format!(
            "simplify: {what} must be a finite number ≥ 0{}, not {v}",
            if what == "ratio" { " and ≤ 1" } else { "" }
        ))
    };
    if let Some(r) = opts.ratio {
        if !(0.0..=1.0).contains(&r) {
            return Err(bad("ratio", r));
        }
    }
    if let Some(e) = opts.error {
        if !(e.is_finite() && e >= 0.0) {
            return Err(bad("error", e));
        }
    }
    if !(opts.prune.is_finite() && (0.0..=1.0).contains(&opts.prune)) {
        return Err(bad("prune", opts.prune));
    }
    let tri = mesh.fan_triangles();
    if tri.is_empty() {
        return Err(Error::Mesh("simplify: the mesh has no faces".into()));
    }
    Ok(tri)
}

/// Reduces `mesh` (see [`crate::mesh::simplify`]).
///
/// ```
/// use gregvox::api::{simplify, SimplifyOptions};
/// use gregvox::voxel::mesh::TriMesh;
/// use gregvox::mesh::Mesh;
/// let s = TriMesh::sphere([0.0; 3], 1.0, 24, 48, false);
/// let p = s.positions.iter().map(|p| glam::DVec3::from(p.map(f64::from))).collect();
/// let f: Vec<Vec<u32>> = s.triangles.iter().map(|t| t.to_vec()).collect();
/// let mesh = Mesh::from_polygons(p, &f).unwrap();
/// let out = simplify(&mesh, &SimplifyOptions { ratio: Some(0.25), ..Default::default() }).unwrap();
/// assert!(out.report.faces <= f.len() / 4);
/// assert!(gregvox::api::topology(&out.mesh).closed);
/// ```
pub fn simplify(mesh: &Mesh, opts: &SimplifyOptions) -> Result<SimplifiedMesh> {
    let tri = checked_triangles(mesh, opts)?;
    let diag = diagonal(&mesh.positions);
    let start = std::time::Instant::now();
    let mut target = 0usize;
    if let Some(r) = opts.ratio {
        target = target.max((r * tri.len() as f64).floor() as usize);
    }
    if let Some(f) = opts.faces {
        target = target.max(f);
    }
    let algo_opts = algo::SimplifyOptions {
        target_faces: target,
        max_error: opts.error.map_or(f64::INFINITY, |e| e * diag),
        placement: opts.placement,
        lock_border: opts.lock_border,
        allow_topology: opts.allow_topology,
        prune: opts.prune,
    };
    let s = algo::simplify(&mesh.positions, &tri, &algo_opts);
    Ok(package(s, tri.len(), diag, start.elapsed().as_secs_f64()))
}

fn package(s: Simplified, input_faces: usize, diag: f64, seconds: f64) -> SimplifiedMesh {
    let report = SimplifyReport {
        input_faces,
        faces: s.triangles.len(),
        vertices: s.positions.len(),
        error: s.error,
        relative_error: if diag > 0.0 { s.error / diag } else { 0.0 },
        collapses: s.collapses,
        passes: s.passes,
        locked_vertices: s.locked_vertices,
        pruned_faces: s.pruned_triangles,
        seconds,
    };
    SimplifiedMesh {
        mesh: Mesh::of_triangles(s.positions, &s.triangles),
        report,
        source_vertex: s.source_vertex,
    }
}

/// A chain of `levels` levels of detail: level 0 is the input (triangulated), each next level reduces
/// the previous one by the options' target (a ratio applies per level; a face count is reached
/// geometrically over the levels; an error bound grows linearly to the one given). Errors are reported
/// against the input's diagonal; a level's error is the sum of its chain's (the distances add up).
pub fn simplify_lod(
    mesh: &Mesh,
    opts: &SimplifyOptions,
    levels: usize,
) -> Result<Vec<SimplifiedMesh>> {
    let tri = checked_triangles(mesh, opts)?;
    if !(1..=32).contains(&levels) {
        return Err(Error::Invalid(format!(
            "simplify: --lod must be 1 ..= 32 levels, not {levels}"
        )));
    }
    // Level 0: the input itself, triangulated.
    let n = tri.len();
    let mut out = vec![SimplifiedMesh {
        mesh: Mesh::of_triangles(mesh.positions.clone(), &tri),
        report: SimplifyReport {
            input_faces: n,
            faces: n,
            vertices: mesh.positions.len(),
            error: 0.0,
            relative_error: 0.0,
            collapses: 0,
            passes: 0,
            locked_vertices: 0,
            pruned_faces: 0,
            seconds: 0.0,
        },
        source_vertex: (0..mesh.positions.len() as u32).collect(),
    }];
    let n0 = out[0].report.faces as f64;
    let diag = diagonal(&mesh.positions);
    for k in 1..levels {
        let prev = out.last().expect("level 0 exists");
        let mut level = SimplifyOptions {
            // Pieces are pruned once, on the way to level 1.
            prune: if k == 1 { opts.prune } else { 0.0 },
            ..opts.clone()
        };
        level.faces = opts.faces.map(|f| {
            let t = k as f64 / (levels - 1) as f64;
            (n0 * (f as f64 / n0).powf(t)).round() as usize
        });
        level.error = opts.error.map(|e| e * k as f64 / (levels - 1) as f64);
        let mut s = simplify(&prev.mesh, &level)?;
        s.source_vertex = s
            .source_vertex
            .iter()
            .map(|&v| prev.source_vertex[v as usize])
            .collect();
        s.report.input_faces = prev.report.faces;
        // Each level's quadrics start from the previous level: the distances add up (triangle
        // inequality), so the chain's error is the sum.
        s.report.error += prev.report.error;
        s.report.relative_error = if diag > 0.0 {
            s.report.error / diag
        } else {
            0.0
        };
        out.push(s);
    }
    Ok(out)
}
