//! The exact generalized winding number (Jacobson, Kavan & Sorkine-Hornung 2013) of any triangle soup at the
//! voxel centres, at the cost of one closed-mesh voxelization plus a small pass over the voxels near the
//! holes (`--rule gwn`).
//!
//! The idea: close the mesh M with a cap C whose boundary is the reverse of M's. M ∪ C is closed, so its
//! winding number is an integer n(p), the signed crossing count that the winding rule of depth peeling (or
//! the CPU scanline) already computes; and w_M(p) = n(p) − w_C(p). Wherever |w_C(p)| < ½, |w_M(p)| ≥ ½ exactly
//! when n(p) ≠ 0: the winding rule on M ∪ C gives the answer. Only the voxels where |w_C| may reach ½ need
//! more, and w_C involves only the cap's triangles.
//!
//! Invariants:
//! - The boundary is a 1-chain: each edge of the welded mesh (exact duplicate positions merged, which changes
//!   no triangle and so no winding number) counts its oriented uses, +1 one way and −1 the other. Edges
//!   whose uses do not cancel are boundary, with that multiplicity (inconsistent orientation and
//!   non-manifold edges included). The chain has no end points (∂∂ = 0), so it splits into closed loops,
//!   walked deterministically (sorted edges, a cycle cut off as soon as the walk meets its own path: loops
//!   stay small where several touch at one vertex). Each loop is capped by a fan from its centroid
//!   (rounded to f32, the positions' type): ∂C = −∂M whatever the loops look like.
//! - Inside is |w| ≥ ½: an inward-oriented closed mesh (w = −1 inside) is solid, as under the winding rule,
//!   and on a closed mesh there is no cap and the grid is bit for bit the winding rule's.
//! - Which voxels are looked at, in three stages that the GPU (`passes::gwn`, `glsl/gwn_*.comp`) mirrors
//!   operation for operation (same f64 operations in the same order, so both find the same voxels):
//!   1. boxes of voxels, from 32³ down to cells of [`CELL`]³ ([`LEVELS`] levels, [`SPLIT`]³ children a
//!      box, only the children of boxes not cleared looked at): a box is cleared when every cap triangle
//!      lies farther than its radius r + [`near_distance`] from its centre c and
//!      |w_C(c)| + r · Σ_edges length / (4π (d − r)²) < ½ − [`MARGIN`] (w_C is harmonic off the cap, its
//!      gradient the Biot–Savart integral over the cap's boundary, d a lower bound on the distance to the
//!      edge's fan triangle): there |w_C| < ½ and the closed grid stands;
//!   2. in the cells not cleared, every voxel centre gets w_C exactly (Van Oosterom–Strackee solid angles
//!      of the cap triangles). A voxel is listed when its centre lies within [`near_distance`] of a cap
//!      triangle (a *direct* voxel: there the rasterized crossing of the snapped cap and the analytic cap
//!      term could disagree), or else when |w_C| ≥ ½ − [`MARGIN`] (a *crossing* voxel);
//!   3. a crossing voxel is inside iff |n − w_C| ≥ ½, n the closed mesh's signed crossing count along the
//!      grid's column ([`column_windings`], the CPU scanline's own count, the integer w_{M∪C}); a direct
//!      voxel gets w_M itself, summed over every triangle of M in chunks of [`DIRECT_CHUNK`] (chunk sums
//!      added in chunk order): inside iff |w_M| ≥ ½. A cap so large that the bound is useless only makes
//!      stages 2 and 3 visit more voxels; the answer stays exact.
//! - Coordinates are local to the grid (world − origin, in f64; the centre of voxel i is (i + ½)·size), so
//!   meshes far from the origin keep their precision. Solid angles are not affine invariant: everything is
//!   evaluated in world units, never grid units.
//! - The number of listed voxels is bounded by the memory budget the caller gives ([`Error::Limit`]
//!   beyond it); nothing is allocated per voxel of the grid.
use super::cpu::column_windings;
use super::grid::{GridFrame, VoxelGrid};
use super::mesh::TriMesh;
use super::surface::{cross, dot, sub};
use crate::error::{Error, Result};
use rayon::prelude::*;
use std::collections::HashMap;

/// Edge of a cell, the smallest box of stage 1, in voxels: stage 2 evaluates the voxels of the cells
/// stage 1 could not clear.
pub const CELL: u32 = 2;
/// Children per axis of a box of stage 1. A box whose bound clears it clears its children unseen.
pub const SPLIT: u32 = 2;
/// Levels of stage 1: boxes of 32³, 16³, 8³ (bricks), 4³ and 2³ ([`CELL`]) voxels.
pub const LEVELS: u32 = 5;
/// The level whose boxes are bricks (8³), counted in [`GwnStats::bricks_evaluated`].
pub const BRICK_LEVEL: u32 = 2;
/// Triangles per chunk of the direct sum (a GPU invocation sums one chunk: lavapipe cuts longer loops).
pub const DIRECT_CHUNK: u32 = 4096;
/// Slack on the ½ threshold for the cap term and the brick bound: far above the f64 rounding of a sum of a
/// few thousand solid angles, far below any winding number a voxel centre off the surface has.
pub const MARGIN: f64 = 1e-6;
/// Bytes a listed (crossing or direct) voxel costs on the GPU method (its index and cap term; a direct
/// voxel's f64 partial sums per chunk are counted separately): the unit of the memory budget.
pub const LISTED_VOXEL_BYTES: u64 = 32;
/// 4π.
pub const FOUR_PI: f64 = 4.0 * std::f64::consts::PI;

/// A loop of the boundary chain and its cap fan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CapLoop {
    /// First cap triangle of this loop in [`Cap::triangles`].
    pub first: u32,
    /// Edges of the loop (= cap triangles).
    pub count: u32,
    /// Index of the apex in the capped mesh's positions.
    pub apex: u32,
}

/// The cap of a mesh: a fan over every loop of its boundary chain.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cap {
    /// Apex positions, appended after the mesh's positions in the capped mesh.
    pub apexes: Vec<[f32; 3]>,
    /// Cap triangles, indexing the capped mesh's positions (the mesh's, then the apexes).
    pub triangles: Vec<[u32; 3]>,
    pub loops: Vec<CapLoop>,
    /// Boundary edges counted with multiplicity (= cap triangles).
    pub boundary_edges: usize,
}

impl Cap {
    /// The cap of `mesh` (empty for a closed mesh: every welded edge's uses cancel).
    pub fn of(mesh: &TriMesh) -> Result<Cap> {
        // Weld exact duplicate positions (−0 and +0 alike) onto the lowest-numbered used vertex there: sort
        // the used vertices by position bits (sorting, not hashing: a soup has three vertices a triangle).
        let key = |v: u32| mesh.positions[v as usize].map(|x| (x + 0.0).to_bits());
        let mut used = vec![false; mesh.positions.len()];
        for t in &mesh.triangles {
            for &v in t {
                used[v as usize] = true;
            }
        }
        let mut order: Vec<u32> = (0..mesh.positions.len() as u32)
            .filter(|&v| used[v as usize])
            .collect();
        order.par_sort_unstable_by_key(|&v| (key(v), v));
        let mut rep = vec![u32::MAX; mesh.positions.len()];
        let mut run = 0;
        for (i, &v) in order.iter().enumerate() {
            if i == 0 || key(v) != key(order[i - 1]) {
                run = v;
            }
            rep[v as usize] = run;
        }
        // Net oriented uses per undirected edge: + for lo→hi, − for hi→lo (sorted, then summed per edge).
        let mut uses: Vec<(u32, u32, i64)> = Vec::with_capacity(mesh.triangles.len() * 3);
        for t in &mesh.triangles {
            for k in 0..3 {
                let (a, b) = (rep[t[k] as usize], rep[t[(k + 1) % 3] as usize]);
                if a != b {
                    uses.push(if a < b { (a, b, 1) } else { (b, a, -1) });
                }
            }
        }
        uses.par_sort_unstable_by_key(|&(a, b, _)| (a, b));
        let mut edges: Vec<(u32, u32)> = Vec::new();
        let mut i = 0;
        while i < uses.len() {
            let (lo, hi) = (uses[i].0, uses[i].1);
            let mut n = 0i64;
            while i < uses.len() && (uses[i].0, uses[i].1) == (lo, hi) {
                n += uses[i].2;
                i += 1;
            }
            let e = if n > 0 { (lo, hi) } else { (hi, lo) };
            for _ in 0..n.unsigned_abs() {
                edges.push(e);
            }
        }
        let mut cap = Cap {
            boundary_edges: edges.len(),
            ..Cap::default()
        };
        if edges.is_empty() {
            return Ok(cap);
        }
        // Deterministic walk: outgoing edges per vertex, taken from the back of a sorted list.
        edges.sort_unstable();
        let mut out: HashMap<u32, Vec<u32>> = HashMap::new();
        for &(a, b) in &edges {
            out.entry(a).or_default().push(b);
        }
        let mut starts: Vec<u32> = out.keys().copied().collect();
        starts.sort_unstable();
        let base = mesh.positions.len() as u32;
        let mut on_path: HashMap<u32, usize> = HashMap::new();
        for s in starts {
            while out.get(&s).is_some_and(|o| !o.is_empty()) {
                let mut path = vec![s];
                on_path.clear();
                on_path.insert(s, 0);
                loop {
                    let cur = *path.last().expect("path starts non-empty");
                    let Some(next) = out.get_mut(&cur).and_then(Vec::pop) else {
                        if path.len() == 1 {
                            break;
                        }
                        // ∂∂ = 0 guarantees an unused outgoing edge at every inner vertex of the path.
                        return Err(Error::Mesh(format!(
                            "internal error: the boundary chain ends at vertex {}",
                            cur + 1
                        )));
                    };
                    if let Some(&i) = on_path.get(&next) {
                        cap.push_loop(mesh, &path[i..], base);
                        for v in &path[i + 1..] {
                            on_path.remove(v);
                        }
                        path.truncate(i + 1);
                        if path.len() == 1 && out.get(&s).is_none_or(|o| o.is_empty()) {
                            break;
                        }
                    } else {
                        on_path.insert(next, path.len());
                        path.push(next);
                    }
                }
            }
        }
        debug_assert_eq!(cap.triangles.len(), cap.boundary_edges);
        Ok(cap)
    }

    /// Caps the loop `verts` (edges v_i → v_{i+1}, closing back to v_0) with a fan of (v_{i+1}, v_i, apex).
    fn push_loop(&mut self, mesh: &TriMesh, verts: &[u32], base: u32) {
        let mut c = [0.0f64; 3];
        for &v in verts {
            for (a, ca) in c.iter_mut().enumerate() {
                *ca += mesh.positions[v as usize][a] as f64;
            }
        }
        let apex = c.map(|x| (x / verts.len() as f64) as f32);
        let apex_index = base + self.apexes.len() as u32;
        self.apexes.push(apex);
        let first = self.triangles.len() as u32;
        for i in 0..verts.len() {
            let (a, b) = (verts[i], verts[(i + 1) % verts.len()]);
            self.triangles.push([b, a, apex_index]);
        }
        self.loops.push(CapLoop {
            first,
            count: verts.len() as u32,
            apex: apex_index,
        });
    }

    /// M ∪ C: the mesh's positions then the apexes, its triangles then the cap's.
    pub fn close(&self, mesh: &TriMesh) -> TriMesh {
        let mut closed = mesh.clone();
        closed.positions.extend_from_slice(&self.apexes);
        closed.triangles.extend_from_slice(&self.triangles);
        closed
    }
}

/// A cap triangle in grid-local world coordinates (`CapTriangle` in glsl/include/gwn.glsl). A loop's fan
/// triangle is (b, a, apex) for the mesh's boundary edge a → b, so its edge a–b (here `a`–`b`) is the cap's
/// boundary edge and the other two cancel within the fan.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CapTriangle {
    /// xyz: the first corner, w: the length of the boundary edge `a`–`b`.
    pub a: [f64; 4],
    /// xyz: the second corner, w: the radius of a ball round the centroid that holds the triangle.
    pub b: [f64; 4],
    /// xyz: the third corner (w unused).
    pub c: [f64; 4],
}

/// The cap placed in a grid: what the cap-term stages read.
#[derive(Clone, Debug)]
pub struct CapTerm {
    pub triangles: Vec<CapTriangle>,
    /// [`near_distance`] of the frame.
    pub near: f64,
}

/// Distance (world units) within which a voxel centre is evaluated directly rather than trusted to the
/// rasterized cap: 1/64 of the largest voxel edge. Snapping moves a vertex by at most 1/512 of a voxel per
/// axis, and a crossing along a column is at least as far from the centre as the plane is.
pub fn near_distance(frame: &GridFrame) -> f64 {
    frame.voxel_size.iter().fold(0.0f64, |m, &h| m.max(h)) / 64.0
}

/// The position of vertex `v` of `mesh` local to `frame` (world − origin, f64).
fn local(frame: &GridFrame, p: [f32; 3]) -> [f64; 3] {
    std::array::from_fn(|a| p[a] as f64 - frame.origin[a])
}

impl CapTerm {
    /// `cap` of `mesh` (whose positions it indexes, apexes after them) placed in `frame`.
    pub fn new(cap: &Cap, mesh: &TriMesh, frame: &GridFrame) -> CapTerm {
        let n = mesh.positions.len();
        let pos = |v: u32| {
            let v = v as usize;
            local(
                frame,
                if v < n {
                    mesh.positions[v]
                } else {
                    cap.apexes[v - n]
                },
            )
        };
        let triangles: Vec<CapTriangle> = cap
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(pos);
                // A hair more than the rounded length keeps the gradient bound a bound.
                let edge = norm(sub(b, a)) * (1.0 + 1e-12);
                let mut t = CapTriangle {
                    a: [a[0], a[1], a[2], edge],
                    b: [b[0], b[1], b[2], 0.0],
                    c: [c[0], c[1], c[2], 0.0],
                };
                let m = centroid(&t);
                let radius = [a, b, c]
                    .iter()
                    .fold(0.0f64, |r, &v| r.max(norm(sub(v, m))));
                // A hair more: the ball holds the triangle despite rounding.
                t.b[3] = radius * (1.0 + 1e-12) + 1e-300;
                t
            })
            .collect();
        CapTerm {
            triangles,
            near: near_distance(frame),
        }
    }
}

/// What the cap-term stages did (`voxelize --json`: `gwn`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct GwnStats {
    /// Boundary loops capped.
    pub loops_capped: usize,
    /// Boundary edges, with multiplicity.
    pub boundary_edges: usize,
    /// Bricks (8³ voxels) whose bound did not clear them.
    pub bricks_evaluated: u64,
    /// Voxels whose cap term was evaluated (every voxel of the cells, 2³, not cleared).
    pub cap_term_voxels: u64,
    /// Voxels where |w_C| reached ½: answered from the closed mesh's signed crossing count n and the cap
    /// term, |n − w_C| ≥ ½.
    pub crossing_voxels: u64,
    /// Voxels within [`near_distance`] of a cap triangle: their winding number summed directly over the mesh.
    pub direct_voxels: u64,
    /// Crossing and direct voxels whose answer differs from the closed mesh's winding rule.
    pub flipped: u64,
}

impl GwnStats {
    /// The counts of `cap`, no stage run yet.
    pub fn of(cap: &Cap) -> GwnStats {
        GwnStats {
            loops_capped: cap.loops.len(),
            boundary_edges: cap.boundary_edges,
            ..GwnStats::default()
        }
    }
}

// ---- f64 kernels, mirrored operation for operation by glsl/include/gwn.glsl ----

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// atan on f64 (Cephes' `atan`: range reduction to |x| ≤ 0.66, then a 4/5 rational), written out so that the
/// GPU, whose GLSL has no double-precision atan, computes the very same value.
// The constants are Cephes' text, digit for digit (the GLSL copy parses the same text to the same f64).
#[allow(clippy::excessive_precision)]
pub fn atan_f64(x: f64) -> f64 {
    const P: [f64; 5] = [
        -8.750_608_600_031_904_122_785e-1,
        -1.615_753_718_733_365_076_637e1,
        -7.500_855_792_314_704_667_340e1,
        -1.228_866_684_490_136_173_410e2,
        -6.485_021_904_942_025_371_773e1,
    ];
    const Q: [f64; 5] = [
        2.485_846_490_142_306_297_962e1,
        1.650_270_098_316_988_542_046e2,
        4.328_810_604_912_902_668_951e2,
        4.853_903_996_359_136_964_868e2,
        1.945_506_571_482_613_964_425e2,
    ];
    const MOREBITS: f64 = 6.123_233_995_736_765_886_130e-17;
    const T3P8: f64 = 2.414_213_562_373_095_048_80;
    let negative = x < 0.0;
    let mut x = x.abs();
    let (y0, more) = if x > T3P8 {
        x = -1.0 / x;
        (std::f64::consts::FRAC_PI_2, MOREBITS)
    } else if x <= 0.66 {
        (0.0, 0.0)
    } else {
        x = (x - 1.0) / (x + 1.0);
        (std::f64::consts::FRAC_PI_4, 0.5 * MOREBITS)
    };
    let z = x * x;
    let p = (((P[0] * z + P[1]) * z + P[2]) * z + P[3]) * z + P[4];
    let q = ((((z + Q[0]) * z + Q[1]) * z + Q[2]) * z + Q[3]) * z + Q[4];
    let r = z * p / q;
    let r = x * r + x;
    let y = y0 + (r + more);
    if negative {
        -y
    } else {
        y
    }
}

/// atan2 on f64 from [`atan_f64`].
pub fn atan2_f64(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI};
    if x > 0.0 {
        atan_f64(y / x)
    } else if x < 0.0 {
        if y >= 0.0 {
            atan_f64(y / x) + PI
        } else {
            atan_f64(y / x) - PI
        }
    } else if y > 0.0 {
        FRAC_PI_2
    } else if y < 0.0 {
        -FRAC_PI_2
    } else {
        0.0
    }
}

/// The signed solid angle of triangle (a, b, c) seen from `p` (Van Oosterom & Strackee 1983): positive
/// when p sees the triangle counter-clockwise (p behind an outward face).
pub fn solid_angle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let (a, b, c) = (sub(a, p), sub(b, p), sub(c, p));
    let (la, lb, lc) = (norm(a), norm(b), norm(c));
    let det = dot(a, cross(b, c));
    let den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    2.0 * atan2_f64(det, den)
}

/// The local centre of voxel `ijk`: (i + ½)·size per axis.
pub fn centre(frame: &GridFrame, ijk: [u32; 3]) -> [f64; 3] {
    std::array::from_fn(|a| (ijk[a] as f64 + 0.5) * frame.voxel_size[a])
}

/// The squared distance from `p` to the segment a–b.
fn segment_distance2(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let (ab, ap) = (sub(b, a), sub(p, a));
    let l2 = dot(ab, ab);
    let t = if l2 > 0.0 {
        (dot(ap, ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = [a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]];
    let d = sub(p, q);
    dot(d, d)
}

/// The distance from `p` to cap triangle `t` (to its plane where p projects inside it, else to its nearest
/// edge; a degenerate triangle is its edges).
pub fn triangle_distance(p: [f64; 3], t: &CapTriangle) -> f64 {
    let (a, b, c) = (
        [t.a[0], t.a[1], t.a[2]],
        [t.b[0], t.b[1], t.b[2]],
        [t.c[0], t.c[1], t.c[2]],
    );
    let n = cross(sub(b, a), sub(c, a));
    let nn = dot(n, n);
    if nn > 0.0
        && dot(cross(sub(b, a), sub(p, a)), n) >= 0.0
        && dot(cross(sub(c, b), sub(p, b)), n) >= 0.0
        && dot(cross(sub(a, c), sub(p, c)), n) >= 0.0
    {
        return dot(n, sub(p, a)).abs() / nn.sqrt();
    }
    segment_distance2(p, a, b)
        .min(segment_distance2(p, b, c))
        .min(segment_distance2(p, c, a))
        .sqrt()
}

/// Stage 1: whether the voxels `[lo, hi)` (a box of [`level_edge`]³) need their cap term evaluated. With c
/// the centre of their centres and r the farthest centre's distance from it, they do not when every cap triangle lies farther than r + `near` from c (no centre is near the cap, and w_C is
/// smooth over the ball) and |w_C(c)| + r · sup|∇w_C| < ½ − [`MARGIN`], where ∇w_C is the Biot–Savart
/// integral over the cap's boundary: |∇w_C| ≤ Σ_edges length / (4π (d − r)²), d ≥ the distance from c to
/// the edge's fan triangle.
pub fn box_needs_cap_term(frame: &GridFrame, term: &CapTerm, lo: [u32; 3], hi: [u32; 3]) -> bool {
    let a = centre(frame, lo);
    let b = centre(frame, [hi[0] - 1, hi[1] - 1, hi[2] - 1]);
    let c = [
        (a[0] + b[0]) * 0.5,
        (a[1] + b[1]) * 0.5,
        (a[2] + b[2]) * 0.5,
    ];
    let r = 0.5 * norm(sub(b, a));
    // A lower bound on each triangle's distance beyond r: its ball's where the ball lies farther than four
    // radii (the bound then loses at most a factor 2.25 on a term that small), else the exact one. First
    // any triangle too near (no solid angle spent on a box that fails by distance)...
    let gap = |t: &CapTriangle| {
        let g = ball_distance(c, t) - r;
        if g <= 4.0 * t.b[3] + term.near {
            triangle_distance(c, t) - r
        } else {
            g
        }
    };
    let mut gaps = Vec::with_capacity(term.triangles.len());
    for t in &term.triangles {
        let g = gap(t);
        if g <= term.near {
            return true;
        }
        gaps.push(g);
    }
    // ... then the bound (the GPU recomputes the same gaps).
    let mut sum = 0.0f64;
    let mut gradient = 0.0f64;
    for (t, &g) in term.triangles.iter().zip(&gaps) {
        sum += solid_angle(
            c,
            [t.a[0], t.a[1], t.a[2]],
            [t.b[0], t.b[1], t.b[2]],
            [t.c[0], t.c[1], t.c[2]],
        );
        gradient += t.a[3] / (g * g);
    }
    (sum.abs() + r * gradient) / FOUR_PI >= 0.5 - MARGIN
}

/// The centroid of cap triangle `t`.
fn centroid(t: &CapTriangle) -> [f64; 3] {
    std::array::from_fn(|k| (t.a[k] + t.b[k] + t.c[k]) / 3.0)
}

/// A lower bound on the distance from `p` to cap triangle `t`: to the ball round its centroid that holds it
/// (radius in `b[3]`).
fn ball_distance(p: [f64; 3], t: &CapTriangle) -> f64 {
    norm(sub(p, centroid(t))) - t.b[3]
}

/// The voxels `[lo, hi)` of box `b` of edge `edge` voxels, clipped to the grid.
pub fn box_range(frame: &GridFrame, b: [u32; 3], edge: u32) -> ([u32; 3], [u32; 3]) {
    (
        b.map(|x| x * edge),
        std::array::from_fn(|a| (b[a] * edge + edge).min(frame.dims[a])),
    )
}

/// Edge, in voxels, of the boxes of stage 1's `level` (0: the coarsest, `LEVELS − 1`: cells).
pub fn level_edge(level: u32) -> u32 {
    CELL * SPLIT.pow(LEVELS - 1 - level)
}

/// Boxes per axis at stage 1's `level`.
pub fn level_dims(frame: &GridFrame, level: u32) -> [u32; 3] {
    let e = level_edge(level);
    frame.dims.map(|d| d.div_ceil(e))
}

/// The children (boxes of `level` + 1) of box `b` of `level` that lie in the grid, in (z, y, x) order.
pub fn children(frame: &GridFrame, level: u32, b: [u32; 3]) -> impl Iterator<Item = [u32; 3]> {
    let cd = level_dims(frame, level + 1);
    (0..SPLIT * SPLIT * SPLIT).filter_map(move |s| {
        let c = [
            b[0] * SPLIT + s % SPLIT,
            b[1] * SPLIT + (s / SPLIT) % SPLIT,
            b[2] * SPLIT + s / (SPLIT * SPLIT),
        ];
        (0..3).all(|a| c[a] < cd[a]).then_some(c)
    })
}

/// Stage 1 on the CPU: the cells whose cap term is needed, in (z, y, x) order, and how many bricks were
/// needed on the way (what the GPU's box passes list, one a level).
pub fn needed_cells(frame: &GridFrame, term: &CapTerm) -> (u64, Vec<[u32; 3]>) {
    let needed = |level: u32, b: [u32; 3]| {
        let (lo, hi) = box_range(frame, b, level_edge(level));
        box_needs_cap_term(frame, term, lo, hi)
    };
    let cd = level_dims(frame, 0);
    let mut boxes: Vec<[u32; 3]> = (0..cd[2] * cd[1] * cd[0])
        .into_par_iter()
        .map(|g| [g % cd[0], (g / cd[0]) % cd[1], g / (cd[0] * cd[1])])
        .filter(|&b| needed(0, b))
        .collect();
    let mut bricks = 0;
    for level in 1..LEVELS {
        boxes = boxes
            .par_iter()
            .flat_map_iter(|&b| children(frame, level - 1, b).filter(move |&c| needed(level, c)))
            .collect();
        if level == BRICK_LEVEL {
            bricks = boxes.len() as u64;
        }
    }
    boxes.sort_unstable_by_key(|b| [b[2], b[1], b[0]]);
    (bricks, boxes)
}

/// Whether `p` lies within `near` of cap triangle `t` (its plane and its box grown by `near` first, a cheap
/// rejection, then the exact distance). Degenerate triangles (no area, nothing rasterized) never are.
fn near_triangle(p: [f64; 3], t: &CapTriangle, near: f64) -> bool {
    let (a, b, c) = (
        [t.a[0], t.a[1], t.a[2]],
        [t.b[0], t.b[1], t.b[2]],
        [t.c[0], t.c[1], t.c[2]],
    );
    let n = cross(sub(b, a), sub(c, a));
    let nn = dot(n, n);
    if nn == 0.0 {
        return false;
    }
    let s = dot(n, sub(p, a));
    if s * s >= near * near * nn {
        return false;
    }
    (0..3).all(|k| {
        let lo = a[k].min(b[k]).min(c[k]) - near;
        let hi = a[k].max(b[k]).max(c[k]) + near;
        p[k] >= lo && p[k] <= hi
    }) && triangle_distance(p, t) <= near
}

/// Stage 2: w_C at the local point `p`, and whether `p` lies within `near` of a cap triangle (a direct
/// voxel).
pub fn cap_term_at(term: &CapTerm, p: [f64; 3]) -> (f64, bool) {
    let mut sum = 0.0f64;
    let mut near = false;
    for t in &term.triangles {
        sum += solid_angle(
            p,
            [t.a[0], t.a[1], t.a[2]],
            [t.b[0], t.b[1], t.b[2]],
            [t.c[0], t.c[1], t.c[2]],
        );
        near = near || near_triangle(p, t, term.near);
    }
    (sum / FOUR_PI, near)
}

/// M's triangles local to `frame` in f64 (p − origin per corner), what stage 3 sums: the GPU makes the same
/// values from the f32 vertices.
pub fn local_triangles(mesh: &TriMesh, frame: &GridFrame) -> Vec<[[f64; 3]; 3]> {
    mesh.triangles
        .par_iter()
        .map(|t| t.map(|v| local(frame, mesh.positions[v as usize])))
        .collect()
}

/// Stage 3, one chunk: Σ Ω over triangles `[chunk·DIRECT_CHUNK, …)` of `triangles` ([`local_triangles`]) at
/// the local point `p`.
pub fn direct_chunk(triangles: &[[[f64; 3]; 3]], p: [f64; 3], chunk: u32) -> f64 {
    let start = (chunk * DIRECT_CHUNK) as usize;
    let end = (start + DIRECT_CHUNK as usize).min(triangles.len());
    let mut sum = 0.0f64;
    for &[a, b, c] in &triangles[start..end] {
        sum += solid_angle(p, a, b, c);
    }
    sum
}

/// Stage 3 for direct voxels on the CPU (all cores): |w_M| ≥ ½ at each centre, the chunk sums added in
/// chunk order.
pub fn direct_inside(mesh: &TriMesh, frame: &GridFrame, voxels: &[[u32; 3]]) -> Vec<bool> {
    if voxels.is_empty() {
        return Vec::new();
    }
    let triangles = local_triangles(mesh, frame);
    let chunks = direct_chunks(triangles.len());
    voxels
        .par_iter()
        .map(|&v| {
            let p = centre(frame, v);
            winding_from_chunks((0..chunks).map(|c| direct_chunk(&triangles, p, c))).abs() >= 0.5
        })
        .collect()
}

/// Chunks of the direct sum for `triangles`.
pub fn direct_chunks(triangles: usize) -> u32 {
    (triangles as u64).div_ceil(DIRECT_CHUNK as u64) as u32
}

/// The winding number from chunk sums (added in chunk order, as the GPU's are read back).
pub fn winding_from_chunks(chunks: impl IntoIterator<Item = f64>) -> f64 {
    let mut sum = 0.0f64;
    for c in chunks {
        sum += c;
    }
    sum / FOUR_PI
}

/// Refuses stage 2's list past `budget` bytes: `listed` voxels (crossing and direct, [`LISTED_VOXEL_BYTES`]
/// each) and the per-chunk f64 sums of the `direct` ones (the GPU's buffers; the CPU keeps the same lists).
pub fn check_budget(listed: u64, direct: u64, chunks: u32, budget: u64) -> Result<()> {
    let bytes = listed
        .saturating_mul(LISTED_VOXEL_BYTES)
        .saturating_add(direct.saturating_mul(8 * chunks as u64));
    if bytes > budget {
        return Err(Error::Limit {
            what: format!(
                "the caps of the mesh's holes: {listed} voxels to resolve, {direct} of them by a direct sum \
                 ({} MiB)",
                bytes >> 20
            ),
            detail: format!(
                "the generalized winding number's memory budget is {} MiB (use --rule winding, or a \
                 coarser grid)",
                budget >> 20
            ),
        });
    }
    Ok(())
}

/// A voxel stage 2 singled out: the cap term reached ½ (`direct` false: answered from the crossing count),
/// or its centre is near the cap (`direct`: summed over the mesh).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Listed {
    pub voxel: [u32; 3],
    pub w_cap: f64,
    pub direct: bool,
}

/// Stage 3 for the crossing voxels of `listed` (sorted (z, y, x)): |n − w_C| ≥ ½ with n the closed mesh's
/// crossing count along the grid's bit axis ([`column_windings`]). Returns the voxels and answers, and
/// counts them into `stats`.
pub fn resolve_crossings(
    grid: &VoxelGrid,
    closed: &TriMesh,
    listed: &[Listed],
    stats: &mut GwnStats,
) -> (Vec<[u32; 3]>, Vec<bool>) {
    let crossing: Vec<&Listed> = listed.iter().filter(|l| !l.direct).collect();
    stats.crossing_voxels = crossing.len() as u64;
    let voxels: Vec<[u32; 3]> = crossing.iter().map(|l| l.voxel).collect();
    let n = column_windings(closed, &grid.frame, grid.bit_axis, &voxels);
    let inside = crossing
        .iter()
        .zip(&n)
        .map(|(l, &n)| (n as f64 - l.w_cap).abs() >= 0.5)
        .collect();
    (voxels, inside)
}

/// Stages 1–3 on the CPU (all cores) over `grid`, the winding rule of `closed` = M ∪ C: sets every crossing
/// and direct voxel to |w_M| ≥ ½. `mesh` is M (without the cap).
pub fn resolve_cpu(
    grid: &mut VoxelGrid,
    mesh: &TriMesh,
    closed: &TriMesh,
    cap: &Cap,
    budget: u64,
) -> Result<GwnStats> {
    let frame = grid.frame;
    let mut stats = GwnStats::of(cap);
    if cap.triangles.is_empty() {
        return Ok(stats);
    }
    let term = CapTerm::new(cap, mesh, &frame);
    let (bricks, cells) = needed_cells(&frame, &term);
    stats.bricks_evaluated = bricks;
    let per_cell: Vec<(u64, Vec<Listed>)> = cells
        .par_iter()
        .map(|&b| {
            let mut n = 0;
            let mut listed = Vec::new();
            let (lo, hi) = box_range(&frame, b, CELL);
            for k in lo[2]..hi[2] {
                for j in lo[1]..hi[1] {
                    for i in lo[0]..hi[0] {
                        n += 1;
                        let (w_cap, near) = cap_term_at(&term, centre(&frame, [i, j, k]));
                        if near || w_cap.abs() >= 0.5 - MARGIN {
                            listed.push(Listed {
                                voxel: [i, j, k],
                                w_cap,
                                direct: near,
                            });
                        }
                    }
                }
            }
            (n, listed)
        })
        .collect();
    stats.cap_term_voxels = per_cell.iter().map(|p| p.0).sum();
    let mut listed: Vec<Listed> = per_cell.into_iter().flat_map(|p| p.1).collect();
    listed.sort_unstable_by_key(|l| [l.voxel[2], l.voxel[1], l.voxel[0]]);
    let direct: Vec<[u32; 3]> = listed
        .iter()
        .filter(|l| l.direct)
        .map(|l| l.voxel)
        .collect();
    stats.direct_voxels = direct.len() as u64;
    let chunks = direct_chunks(mesh.triangles.len());
    check_budget(listed.len() as u64, stats.direct_voxels, chunks, budget)?;
    let (crossing, crossing_inside) = resolve_crossings(grid, closed, &listed, &mut stats);
    let inside = direct_inside(mesh, &frame, &direct);
    stats.flipped =
        apply_direct(grid, &crossing, &crossing_inside) + apply_direct(grid, &direct, &inside);
    Ok(stats)
}

/// Sets the direct voxels to their answers; returns how many changed.
pub fn apply_direct(grid: &mut VoxelGrid, direct: &[[u32; 3]], inside: &[bool]) -> u64 {
    let mut flipped = 0;
    for (&[i, j, k], &v) in direct.iter().zip(inside) {
        if grid.get(i, j, k) != v {
            flipped += 1;
            grid.set(i, j, k, v);
        }
    }
    flipped
}

/// The exact generalized winding number of `mesh` at world point `p`, by the plain sum (a reference for
/// tests and small inputs: O(triangles)).
pub fn winding_number(mesh: &TriMesh, p: [f64; 3]) -> f64 {
    let mut sum = 0.0;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| mesh.positions[v as usize].map(|x| x as f64));
        sum += solid_angle(p, a, b, c);
    }
    sum / FOUR_PI
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan_matches_the_standard_library_to_an_ulp_or_two() {
        let mut worst = 0.0f64;
        for i in -20000..=20000 {
            let x = (i as f64 / 1000.0).powi(3);
            let (a, b) = (atan_f64(x), x.atan());
            worst = worst.max(((a - b) / b.abs().max(1e-300)).abs());
        }
        assert!(worst < 4.0 * f64::EPSILON, "relative error {worst:e}");
        for (y, x) in [
            (1.0, -1.0),
            (-1.0, -1.0),
            (0.0, -1.0),
            (2.0, 0.0),
            (-2.0, 0.0),
            (0.0, 0.0),
        ] {
            assert!(
                (atan2_f64(y, x) - f64::atan2(y, x)).abs() < 1e-15,
                "atan2({y}, {x})"
            );
        }
    }

    #[test]
    fn a_closed_cube_has_no_cap_and_a_winding_number_of_one_inside() {
        let cube = TriMesh::cube([0.0; 3], 1.0);
        let cap = Cap::of(&cube).unwrap();
        assert!(cap.loops.is_empty() && cap.triangles.is_empty());
        assert!((winding_number(&cube, [0.5, 0.4, 0.3]) - 1.0).abs() < 1e-12);
        assert!(winding_number(&cube, [1.5, 0.4, 0.3]).abs() < 1e-12);
    }

    #[test]
    fn an_open_cube_capped_is_closed_and_the_cap_term_completes_the_mesh() {
        let mut open = TriMesh::cube([0.0; 3], 1.0);
        open.triangles.truncate(10); // one face removed
        let cap = Cap::of(&open).unwrap();
        assert_eq!((cap.loops.len(), cap.boundary_edges), (1, 4));
        assert!(Cap::of(&cap.close(&open)).unwrap().triangles.is_empty());
        // w_M + w_C = w_{M∪C}: an integer.
        let closed = cap.close(&open);
        let p = [0.3, 0.6, 0.2];
        let (wm, wc) = (
            winding_number(&open, p),
            winding_number(&closed, p) - winding_number(&open, p),
        );
        assert!(((wm + wc) - 1.0).abs() < 1e-12 && wc.abs() > 0.01);
    }

    #[test]
    fn soups_are_welded_and_inconsistent_orientation_counts_twice() {
        // A closed cube as a soup: every triangle its own three vertices, so no cap.
        let cube = TriMesh::cube([0.0; 3], 1.0);
        let mut soup = TriMesh::default();
        for t in &cube.triangles {
            let n = soup.positions.len() as u32;
            soup.positions.extend(t.map(|v| cube.positions[v as usize]));
            soup.triangles.push([n, n + 1, n + 2]);
        }
        assert!(Cap::of(&soup).unwrap().triangles.is_empty());
        // Flip one face (two triangles): its four outer edges are now used twice the same way, its diagonal
        // cancels: a boundary chain of 4 edges of multiplicity 2.
        let mut flipped = cube.clone();
        for t in &mut flipped.triangles[..2] {
            t.swap(1, 2);
        }
        let cap = Cap::of(&flipped).unwrap();
        assert_eq!(cap.boundary_edges, 8);
        assert!(Cap::of(&cap.close(&flipped)).unwrap().triangles.is_empty());
    }
    #[test]
    fn a_cleared_box_holds_no_voxel_the_cap_term_would_list() {
        // A cube with its top face removed: a square hole, capped by a fan; the grid reaches past the mesh.
        let mut open = TriMesh::cube([0.0; 3], 1.0);
        open.triangles.truncate(10);
        let cap = Cap::of(&open).unwrap();
        let frame = GridFrame::from_points(&[[-0.6, -0.6, -0.6], [1.6, 1.6, 1.6]], 40).unwrap();
        let term = CapTerm::new(&cap, &open, &frame);
        let (mut cleared, mut needed) = (0, 0);
        for level in 0..LEVELS {
            let d = level_dims(&frame, level);
            for z in 0..d[2] {
                for y in 0..d[1] {
                    for x in 0..d[0] {
                        let (lo, hi) = box_range(&frame, [x, y, z], level_edge(level));
                        if box_needs_cap_term(&frame, &term, lo, hi) {
                            needed += 1;
                            continue;
                        }
                        cleared += 1;
                        for k in lo[2]..hi[2] {
                            for j in lo[1]..hi[1] {
                                for i in lo[0]..hi[0] {
                                    let (w, near) = cap_term_at(&term, centre(&frame, [i, j, k]));
                                    assert!(
                                        !near && w.abs() < 0.5 - MARGIN,
                                        "level {level} box {x},{y},{z}: voxel {i},{j},{k} w_C = {w}"
                                    );
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(
            cleared > 0 && needed > 0,
            "{cleared} cleared, {needed} needed"
        );
        // The cells stage 1 keeps are a small part of the grid.
        let (_, cells) = needed_cells(&frame, &term);
        let total = level_dims(&frame, LEVELS - 1).iter().product::<u32>() as usize;
        assert!(cells.len() * 4 < total, "{} of {total} cells", cells.len());
    }

    #[test]
    fn the_column_winding_is_the_scanlines_crossing_count() {
        use crate::voxel::cpu::{voxelize_cpu, FillRule};
        use crate::voxel::grid::Axis;
        // Two overlapping cubes, one inward: windings 0, 1, −1 and 2 show up.
        let mut mesh = TriMesh::cube([0.0; 3], 1.0);
        let mut inner = TriMesh::cube([0.25; 3], 0.5);
        for t in &mut inner.triangles {
            t.swap(1, 2);
        }
        let mut other = TriMesh::cube([0.5; 3], 1.0);
        for m in [&mut inner, &mut other] {
            let n = mesh.positions.len() as u32;
            mesh.positions.extend_from_slice(&m.positions);
            mesh.triangles
                .extend(m.triangles.iter().map(|t| t.map(|v| v + n)));
        }
        let frame = GridFrame::from_points(&mesh.positions, 16).unwrap();
        for axis in Axis::ALL {
            let grid = voxelize_cpu(&mesh, &frame, axis, FillRule::Winding);
            let voxels: Vec<[u32; 3]> = (0..16u32.pow(3))
                .map(|g| [g % 16, (g / 16) % 16, g / 256])
                .collect();
            let n = column_windings(&mesh, &frame, axis, &voxels);
            let mut seen = std::collections::BTreeSet::new();
            for (v, &n) in voxels.iter().zip(&n) {
                assert_eq!(grid.get(v[0], v[1], v[2]), n != 0, "{axis:?} {v:?}: {n}");
                let p = centre(&frame, *v).map(|x| x as f32);
                let world: [f64; 3] = std::array::from_fn(|a| p[a] as f64 + frame.origin[a]);
                let w = winding_number(&mesh, world);
                if (w - w.round()).abs() < 1e-6 {
                    assert_eq!(n, w.round() as i32, "{axis:?} {v:?}");
                }
                seen.insert(n);
            }
            assert!(seen.contains(&2) && seen.contains(&0), "{seen:?}");
        }
    }
}
