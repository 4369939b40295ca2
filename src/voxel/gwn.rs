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
//!   1. bricks of [`BRICK`]³ voxels: a brick is safe when every loop's ball (centre = its apex, radius = its
//!      farthest vertex) is more than [`near_distance`] away and Σ area / (4π d²) < ½ − [`MARGIN`] (a
//!      triangle of area A at distance ≥ d subtends at most A / d²): there |w_C| < ½ and the closed grid
//!      stands;
//!   2. in the other bricks, every voxel centre gets w_C exactly (Van Oosterom–Strackee solid angles of the
//!      cap triangles). A voxel is a *direct* voxel when |w_C| ≥ ½ − [`MARGIN`], or when its centre lies
//!      within [`near_distance`] of a cap triangle (there the rasterized crossing of the snapped cap and the
//!      analytic cap term could disagree);
//!   3. a direct voxel gets w_M itself, summed over every triangle of M in chunks of [`DIRECT_CHUNK`]
//!      (chunk sums added in chunk order): inside iff |w_M| ≥ ½. A cap so large that the bound is useless
//!      only makes stages 2 and 3 visit more voxels; the answer stays exact.
//! - Coordinates are local to the grid (world − origin, in f64; the centre of voxel i is (i + ½)·size), so
//!   meshes far from the origin keep their precision. Solid angles are not affine invariant: everything is
//!   evaluated in world units, never grid units.
//! - The number of direct voxels is bounded by the memory budget the caller gives ([`Error::Limit`]
//!   beyond it); nothing is allocated per voxel of the grid.
use super::grid::{GridFrame, VoxelGrid};
use super::mesh::TriMesh;
use super::surface::{cross, dot, sub};
use crate::error::{Error, Result};
use rayon::prelude::*;
use std::collections::HashMap;

/// Edge of a brick, in voxels.
pub const BRICK: u32 = 8;
/// Triangles per chunk of the direct sum (a GPU invocation sums one chunk: lavapipe cuts longer loops).
pub const DIRECT_CHUNK: u32 = 4096;
/// Slack on the ½ threshold for the cap term and the brick bound: far above the f64 rounding of a sum of a
/// few thousand solid angles, far below any winding number a voxel centre off the surface has.
pub const MARGIN: f64 = 1e-6;
/// Bytes a direct voxel costs on the GPU method (its index, and its f64 partial sums per chunk are counted
/// separately): the unit of the memory budget.
pub const DIRECT_VOXEL_BYTES: u64 = 16;
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
        // Weld exact duplicate positions (−0 and +0 alike) onto their first vertex.
        let key = |v: u32| mesh.positions[v as usize].map(|x| (x + 0.0).to_bits());
        let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.positions.len());
        let mut rep = vec![u32::MAX; mesh.positions.len()];
        for t in &mesh.triangles {
            for &v in t {
                if rep[v as usize] == u32::MAX {
                    rep[v as usize] = *first.entry(key(v)).or_insert(v);
                }
            }
        }
        // Net oriented uses per undirected edge: + for lo→hi, − for hi→lo.
        let mut uses: HashMap<(u32, u32), i64> = HashMap::new();
        for t in &mesh.triangles {
            for k in 0..3 {
                let (a, b) = (rep[t[k] as usize], rep[t[(k + 1) % 3] as usize]);
                if a == b {
                    continue;
                }
                let (key, s) = if a < b { ((a, b), 1) } else { ((b, a), -1) };
                *uses.entry(key).or_insert(0) += s;
            }
        }
        let mut edges: Vec<(u32, u32)> = Vec::new();
        for (&(lo, hi), &n) in &uses {
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

/// A cap triangle in grid-local world coordinates (`CapTriangle` in glsl/include/gwn.glsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CapTriangle {
    /// xyz of the three corners (w unused).
    pub a: [f64; 4],
    pub b: [f64; 4],
    pub c: [f64; 4],
}

/// A loop's bounding ball and area in grid-local world coordinates (`CapBall` in glsl/include/gwn.glsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CapBall {
    /// xyz: the apex, w: the distance to the farthest loop vertex (the ball holds the whole fan).
    pub centre_radius: [f64; 4],
    /// x: the fan's area (y, z, w unused).
    pub area: [f64; 4],
}

/// The cap placed in a grid: what the cap-term stages read.
#[derive(Clone, Debug)]
pub struct CapTerm {
    pub triangles: Vec<CapTriangle>,
    pub balls: Vec<CapBall>,
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
                CapTriangle {
                    a: [a[0], a[1], a[2], 0.0],
                    b: [b[0], b[1], b[2], 0.0],
                    c: [c[0], c[1], c[2], 0.0],
                }
            })
            .collect();
        let balls = cap
            .loops
            .iter()
            .map(|l| {
                let apex = pos(l.apex);
                let mut radius = 0.0f64;
                let mut area = 0.0f64;
                for t in &triangles[l.first as usize..(l.first + l.count) as usize] {
                    let a = [t.a[0], t.a[1], t.a[2]];
                    let b = [t.b[0], t.b[1], t.b[2]];
                    radius = radius.max(norm(sub(a, apex))).max(norm(sub(b, apex)));
                    area += 0.5 * norm(cross(sub(a, apex), sub(b, apex)));
                }
                // Rounding of the distances above: a hair more keeps the ball a bound.
                CapBall {
                    centre_radius: [apex[0], apex[1], apex[2], radius * (1.0 + 1e-12)],
                    area: [area * (1.0 + 1e-12), 0.0, 0.0, 0.0],
                }
            })
            .collect();
        CapTerm {
            triangles,
            balls,
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
    /// Bricks whose bound did not clear them.
    pub bricks_evaluated: u64,
    /// Voxels whose cap term was evaluated (every voxel of those bricks).
    pub cap_term_voxels: u64,
    /// Voxels whose winding number was summed directly over the mesh.
    pub direct_voxels: u64,
    /// Direct voxels whose answer differs from the closed mesh's winding rule.
    pub flipped: u64,
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

/// Bricks per axis.
pub fn brick_dims(frame: &GridFrame) -> [u32; 3] {
    frame.dims.map(|d| d.div_ceil(BRICK))
}

/// Stage 1: whether brick `b` needs its cap term evaluated.
pub fn brick_needs_cap_term(frame: &GridFrame, term: &CapTerm, b: [u32; 3]) -> bool {
    let lo = centre(frame, b.map(|x| x * BRICK));
    let hi = centre(
        frame,
        std::array::from_fn(|a| (b[a] * BRICK + BRICK).min(frame.dims[a]) - 1),
    );
    let c = [
        (lo[0] + hi[0]) * 0.5,
        (lo[1] + hi[1]) * 0.5,
        (lo[2] + hi[2]) * 0.5,
    ];
    let r = 0.5 * norm(sub(hi, lo));
    let mut bound = 0.0f64;
    for ball in &term.balls {
        let l = [
            ball.centre_radius[0],
            ball.centre_radius[1],
            ball.centre_radius[2],
        ];
        let d = norm(sub(c, l)) - ball.centre_radius[3] - r;
        if d <= term.near {
            return true;
        }
        bound += ball.area[0] / (FOUR_PI * d * d);
        if bound >= 0.5 - MARGIN {
            return true;
        }
    }
    false
}

/// Whether `p` lies within `near` of the plane of cap triangle `t` and inside its box grown by `near` (a
/// conservative "within `near` of the triangle"). Degenerate triangles (no area, nothing rasterized) never are.
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
    })
}

/// Stage 2: w_C at the local point `p`, and whether `p` is a direct voxel.
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
    let w = sum / FOUR_PI;
    (w, near || w.abs() >= 0.5 - MARGIN)
}

/// Stage 3, one chunk: Σ Ω over triangles `[chunk·DIRECT_CHUNK, …)` of `mesh` at the local point `p`.
pub fn direct_chunk(mesh: &TriMesh, frame: &GridFrame, p: [f64; 3], chunk: u32) -> f64 {
    let start = (chunk * DIRECT_CHUNK) as usize;
    let end = (start + DIRECT_CHUNK as usize).min(mesh.triangles.len());
    let mut sum = 0.0f64;
    for t in &mesh.triangles[start..end] {
        let [a, b, c] = t.map(|v| local(frame, mesh.positions[v as usize]));
        sum += solid_angle(p, a, b, c);
    }
    sum
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

/// Refuses `direct` voxels past `budget` bytes (their indices and per-chunk sums on the GPU; the CPU keeps the
/// same list).
pub fn check_budget(direct: u64, chunks: u32, budget: u64) -> Result<()> {
    let bytes = direct.saturating_mul(DIRECT_VOXEL_BYTES + 8 * chunks as u64);
    if bytes > budget {
        return Err(Error::Limit {
            what: format!(
                "the caps of the mesh's holes: {direct} voxels to evaluate directly ({} MiB)",
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

/// Stages 1–3 on the CPU (all cores) over `grid`, the winding rule of M ∪ C: sets every direct voxel to
/// |w_M| ≥ ½. `mesh` is M (without the cap).
pub fn resolve_cpu(
    grid: &mut VoxelGrid,
    mesh: &TriMesh,
    cap: &Cap,
    budget: u64,
) -> Result<GwnStats> {
    let frame = grid.frame;
    let mut stats = GwnStats {
        loops_capped: cap.loops.len(),
        boundary_edges: cap.boundary_edges,
        ..GwnStats::default()
    };
    if cap.triangles.is_empty() {
        return Ok(stats);
    }
    let term = CapTerm::new(cap, mesh, &frame);
    let bd = brick_dims(&frame);
    let bricks: Vec<[u32; 3]> = (0..bd[2])
        .into_par_iter()
        .flat_map_iter(|z| {
            let term = &term;
            (0..bd[1]).flat_map(move |y| {
                (0..bd[0]).filter_map(move |x| {
                    brick_needs_cap_term(&frame, term, [x, y, z]).then_some([x, y, z])
                })
            })
        })
        .collect();
    stats.bricks_evaluated = bricks.len() as u64;
    let per_brick: Vec<(u64, Vec<[u32; 3]>)> = bricks
        .par_iter()
        .map(|&b| {
            let mut n = 0;
            let mut direct = Vec::new();
            let hi: [u32; 3] = std::array::from_fn(|a| (b[a] * BRICK + BRICK).min(frame.dims[a]));
            for k in b[2] * BRICK..hi[2] {
                for j in b[1] * BRICK..hi[1] {
                    for i in b[0] * BRICK..hi[0] {
                        n += 1;
                        if cap_term_at(&term, centre(&frame, [i, j, k])).1 {
                            direct.push([i, j, k]);
                        }
                    }
                }
            }
            (n, direct)
        })
        .collect();
    stats.cap_term_voxels = per_brick.iter().map(|p| p.0).sum();
    let direct: Vec<[u32; 3]> = per_brick.into_iter().flat_map(|p| p.1).collect();
    stats.direct_voxels = direct.len() as u64;
    let chunks = direct_chunks(mesh.triangles.len());
    check_budget(stats.direct_voxels, chunks, budget)?;
    let inside: Vec<bool> = direct
        .par_iter()
        .map(|&v| {
            let p = centre(&frame, v);
            winding_from_chunks((0..chunks).map(|c| direct_chunk(mesh, &frame, p, c))).abs() >= 0.5
        })
        .collect();
    stats.flipped = apply_direct(grid, &direct, &inside);
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
}
