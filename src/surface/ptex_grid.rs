//! Tessellation per ptex face: one uniform grid on every ptex face of the cage, each grid point evaluated
//! through the ptex map ([`LimitEvaluator`]) on whichever patch holds it, whatever the patches' depths. This
//! is how a feature-adaptive layout ([`crate::surface::adaptive`]: patches of different depths side by side)
//! is tessellated crack-free: the grids follow the cage's faces, not the patches, so no patch edge meets
//! another patch's edge in the middle, and every point two grids share (on a cage edge, at a cage vertex,
//! on the spokes and centre of an n-gon) is evaluated once and copied, so the welded mesh closes bit for bit.
//!
//! Invariants:
//! - A quad is one ptex face with an `n × n` grid (u along v0→v1, v along v0→v3, rows of u inner, the
//!   contract of docs/ARCHITECTURE.md); an n-gon's sub-face i (its corner i at (0, 0), u toward the next
//!   edge's midpoint) has an `n/2 × n/2` grid, so both sides of a cage edge have `n` segments. With
//!   non-quad faces `n` is rounded up to even. Holes have no grid.
//! - Positions and normals (S_u × S_v normalized; a degenerate one taken a step inside the face) are f64
//!   evaluations; the grids' shared points are keyed by cage element and evaluated at their first
//!   occurrence. UVs are evaluated at every grid point (a seam has one value per side).
//! - Cost: one evaluation per distinct grid point (O(log depth) each, in parallel), a hash map of the
//!   boundary points: O(ptex faces · n²).
use super::evaluate::{LimitEvaluator, PtexMap};
use crate::error::{Error, Result};
use crate::mesh::Cage;
use glam::DVec3;
use std::collections::HashMap;

/// Grids of a cage's ptex faces.
#[derive(Clone, Debug, Default)]
pub struct PtexGrids {
    /// Positions, grid after grid, `(level + 1)²` each.
    pub positions: Vec<DVec3>,
    /// Unit normals beside them.
    pub normals: Vec<DVec3>,
    /// UVs beside them, when the cage has UVs.
    pub uvs: Option<Vec<[f64; 2]>>,
    /// Per grid: its level (segments per side).
    pub levels: Vec<u32>,
    /// Per grid: its ptex face.
    pub faces: Vec<u32>,
}

/// Where a grid point lies on the cage, shared by every grid that holds it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Key {
    Vertex(u32),
    /// Cage edge (a < b), `k` of the edge's segments from a.
    Edge(u32, u32, u32),
    /// Inside ptex face `f`.
    Inner(u32, u32, u32),
    /// The spoke of n-gon `face` from the midpoint of its edge `i` (corner i → i + 1), `s` steps in.
    Spoke(u32, u32, u32),
    /// The centre of n-gon `face`.
    Centre(u32),
}

/// Point `k` of `m` segments from cage vertex `p` toward `q`.
fn on_edge(p: u32, q: u32, k: u32, m: u32) -> Key {
    if k == 0 {
        Key::Vertex(p)
    } else if k == m {
        Key::Vertex(q)
    } else if p < q {
        Key::Edge(p, q, k)
    } else {
        Key::Edge(q, p, m - k)
    }
}

/// Where every grid point of every ptex face lies, before any evaluation: what [`ptex_grids`] evaluates on the
/// host and the device surface's ptex layout (`engine::gregory`) on the device.
#[derive(Clone, Debug, Default)]
pub struct GridPlan {
    /// (ptex face, u, v) of every grid point, grid after grid (`(level + 1)²` each, rows of u inner).
    pub at: Vec<(u32, f64, f64)>,
    /// Per grid point, its shared point in `unique` (points on cage vertices, edges, spokes and centres
    /// are one shared point for every grid that holds them).
    pub slot: Vec<u32>,
    /// The shared points, each at the (face, u, v) of its first occurrence.
    pub unique: Vec<(u32, f64, f64)>,
    /// Per grid: its level (segments per side).
    pub levels: Vec<u32>,
    /// Per grid: its ptex face.
    pub faces: Vec<u32>,
}

/// How many grid points [`grid_plan`] makes at `level` (holes counted: an upper bound), without making
/// them: callers refuse a level whose grids would not fit before any allocation.
pub fn grid_point_count(cage: &Cage, level: u32) -> u64 {
    let mesh = &cage.mesh;
    let nonquad = (0..mesh.n_faces()).any(|f| mesh.face(f).len() != 4);
    let m = if nonquad {
        level.div_ceil(2) as u64 * 2
    } else {
        level as u64
    };
    (0..mesh.n_faces())
        .map(|f| match mesh.face(f).len() {
            4 => (m + 1).pow(2),
            n => n as u64 * (m / 2 + 1).pow(2),
        })
        .sum()
}

/// The grid points of every ptex face of `cage` (`map` its ptex map) at `level` segments per cage edge
/// (≥ 1; rounded up to even when the cage has non-quad faces, whose sub-faces take half).
pub fn grid_plan(cage: &Cage, map: &PtexMap, level: u32) -> Result<GridPlan> {
    if level == 0 {
        return Err(Error::Invalid(
            "the tessellation level must be at least 1".into(),
        ));
    }
    let mesh = &cage.mesh;
    let nonquad = (0..mesh.n_faces()).any(|f| mesh.face(f).len() != 4);
    let m = if nonquad {
        level.div_ceil(2) * 2
    } else {
        level
    };
    let mut out = GridPlan::default();
    let mut keys: Vec<Key> = Vec::new();
    let mut ptex = 0u32;
    for f in 0..mesh.n_faces() {
        let c = mesh.face(f);
        let n = c.len();
        let subs = if n == 4 { 1 } else { n };
        for s in 0..subs {
            let id = ptex;
            ptex += 1;
            if map.is_hole(id) {
                continue;
            }
            let g = if n == 4 { m } else { m / 2 };
            out.levels.push(g);
            out.faces.push(id);
            for j in 0..=g {
                for i in 0..=g {
                    let key = if n == 4 {
                        match (i, j) {
                            (_, 0) => on_edge(c[0], c[1], i, m),
                            (i, _) if i == g => on_edge(c[1], c[2], j, m),
                            (_, j) if j == g => on_edge(c[3], c[2], i, m),
                            (0, _) => on_edge(c[0], c[3], j, m),
                            _ => Key::Inner(id, i, j),
                        }
                    } else {
                        let (next, prev) = (c[(s + 1) % n], c[(s + n - 1) % n]);
                        match (i, j) {
                            (i, j) if i == g && j == g => Key::Centre(f as u32),
                            (_, 0) => on_edge(c[s], next, i, m),
                            (0, _) => on_edge(c[s], prev, j, m),
                            (i, _) if i == g => Key::Spoke(f as u32, s as u32, j),
                            (_, j) if j == g => Key::Spoke(f as u32, ((s + n - 1) % n) as u32, i),
                            _ => Key::Inner(id, i, j),
                        }
                    };
                    keys.push(key);
                    out.at.push((id, i as f64 / g as f64, j as f64 / g as f64));
                }
            }
        }
    }
    // Each shared point once, at its first occurrence.
    let mut first: HashMap<Key, u32> = HashMap::with_capacity(keys.len() / 2);
    let unique = &mut out.unique;
    out.slot = keys
        .iter()
        .zip(&out.at)
        .map(|(&k, &p)| {
            *first.entry(k).or_insert_with(|| {
                unique.push(p);
                unique.len() as u32 - 1
            })
        })
        .collect();
    Ok(out)
}

/// The grids of every ptex face of `cage` (`e` its evaluator) at `level` segments per cage edge (≥ 1).
///
/// ```
/// use gregvox::mesh::parse_obj_cage;
/// use gregvox::surface::{ptex_grid::ptex_grids, LimitEvaluator, Tangents};
/// let cube = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
///             f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
/// let cage = parse_obj_cage(cube, "cube.obj").unwrap();
/// let g = ptex_grids(&cage, &LimitEvaluator::new(&cage, Tangents::OpenSubdiv).unwrap(), 4).unwrap();
/// assert_eq!((g.levels, g.positions.len()), (vec![4; 6], 6 * 25));
/// // Grid 0's corner (0, 0) is cage vertex 0 in grids 0, 2 and 5: the same bits.
/// assert_eq!(g.positions[0], g.positions[2 * 25]);
/// ```
pub fn ptex_grids(cage: &Cage, e: &LimitEvaluator, level: u32) -> Result<PtexGrids> {
    let plan = grid_plan(cage, e.ptex_map(), level)?;
    let GridPlan {
        at,
        slot,
        unique,
        levels,
        faces,
    } = plan;
    let mut out = PtexGrids {
        levels,
        faces,
        ..PtexGrids::default()
    };
    let samples = e.evaluate_first_order(&unique)?;
    let mut normals: Vec<DVec3> = samples.iter().map(|s| s.du.cross(s.dv)).collect();
    // A degenerate normal (collinear tangents at a corner): the normal a step inside the face.
    let scale = |s: &super::LimitSample| (s.du.length() + s.dv.length()).powi(2);
    let nudged: Vec<(u32, f64, f64)> = unique
        .iter()
        .zip(&samples)
        .zip(&normals)
        .filter(|((_, s), n)| n.length() <= 1e-10 * scale(s))
        .map(|((&(f, u, v), _), _)| (f, u + (0.5 - u) * 1e-4, v + (0.5 - v) * 1e-4))
        .collect();
    if !nudged.is_empty() {
        let inside = e.evaluate_first_order(&nudged)?;
        let mut k = 0;
        for (n, s) in normals.iter_mut().zip(&samples) {
            if n.length() <= 1e-10 * scale(s) {
                *n = inside[k].du.cross(inside[k].dv);
                k += 1;
            }
        }
    }
    out.positions = slot.iter().map(|&k| samples[k as usize].position).collect();
    out.normals = slot
        .iter()
        .map(|&k| normals[k as usize].normalize_or_zero())
        .collect();
    if e.has_uv() {
        out.uvs = Some(e.evaluate_uv(&at)?);
    }
    Ok(out)
}
