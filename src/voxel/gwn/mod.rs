//! The exact generalized winding number (Jacobson, Kavan & Sorkine-Hornung 2013) of any triangle soup at
//! the voxel centres, at the cost of one closed-mesh voxelization plus work that follows the mesh's open
//! parts' geometry: near-linear in voxels + triangles, whatever the number of holes, pieces or seams.
//!
//! # The rule
//! A voxel is solid iff |w(c)| ≥ ½ at its centre c (`--rule gwn`, the default), or w(c) ≥ ½
//! (`--rule gwn-positive`, libigl's convention), where w is the exact winding number of the cleaned
//! triangles (hygiene, `voxel::mesh::TriMesh::clean`: exact duplicate triangles kept once, pairs of opposite
//! orientation cancelled, zero-area triangles dropped — none of which changes w off the surface), with
//! positions as f32 in the mesh's local frame. |w| ≥ ½ makes an inward-oriented closed part solid, as the
//! winding rule does. On a mesh that is closed once exact duplicate positions are welded there is nothing
//! fractional: the grid is the winding rule's (or the positive rule's), bit for bit, and costs nothing more.
//!
//! # How
//! 1. `cap`: weld within τ ([`weld_tolerance`], max voxel edge / 512), cap the welded mesh's boundary
//!    loops, and connect each triangle to its welded self by thin ribbons: M' ∪ C' is closed and
//!    w_M = n − w_X off the surface, n = the winding number of M' ∪ C' (an integer), X = C' ∪ −ribbons.
//! 2. The solid pass rasterizes M' ∪ C' with the winding rule (CPU scanline, depth peeling or the
//!    A-buffer): n ≠ 0 for every voxel at once, exact wherever the centre lies farther than the
//!    rasterizer's snapping (1/512 voxel at 8 sub-pixel bits) from a triangle.
//! 3. `zone`: the *near zone*, every voxel within [`near_distance`] (max voxel edge / 64 at 8 sub-pixel
//!    bits) of a triangle of M or C', is set aside: there neither the rasterized count nor the bound below
//!    is trusted.
//! 4. `classify`: a tree over X (`tree`) bounds w_X over boxes of voxels, 32³ down to single voxels; where
//!    w_X lies strictly inside (k − ½, k + ½) the answer is n ≠ k (n > k for the positive rule): k = 0 keeps
//!    the rasterized bit, k ≠ 0 reads n from the scanline's crossing count (`relabel`).
//! 5. `direct`: near-zone voxels and voxels no bound labelled get the exact winding number of the closed
//!    chain M ∪ X by exact predicates (`crossing`; when the weld moved vertices, counted on M' ∪ C' and
//!    corrected by the prisms between the moved triangles and their welded selves, `welded`, so a soup's
//!    ribbons are never indexed) and w_X from the tree at the point; where even that leaves
//!    |w| within its error of ½, the plain sum of M's solid angles decides.
//!
//! # The bound
//! Every interval is rigorous (`tree` module docs): a node of X contributes its order-2 expansion with the
//! Taylor-tail truncation bound 4·I₃/D⁵ + (I₄/ρ⁴)/D²·[4t⁴/(1−t) + t⁴/(1−t)²] (t = ρ/D, Iₖ = ∫|x − x̄|ᵏ dA over
//! the node, at most A·ρᵏ: the caps' trees keep their own) plus r·2A/g³ over a ball of radius
//! r, or ± min(A/d², πW/d) (W = Σ of the altitudes on the longest edges: thin ribbons stay cheap), and exact
//! leaf triangles carry their rounding bound. A decision is taken from an interval only when it lies
//! strictly on one side of ½ (of a half-integer for the labels), so every voxel gets exactly the answer of
//! the exact winding number (up to the f64 rounding of the plain sum where the interval could not separate
//! it from ½).
//!
//! # Cost model
//! With V voxels, T triangles of M, X triangles of the fractional term (caps + ribbons), Z near-zone
//! voxels (≈ 2·(near / voxel)·surface voxels ≈ 3 % of them) and B boxes labelled:
//! - weld, cap, ribbons: O(T log T); the tree: O(X log X) time, O(X) memory; the crossing index
//!   O(T + X), or O(T + C') for a welded soup plus the columns under its moved triangles (the bunny as an
//!   unwelded soup at 256³: 63 → 16 ms, its direct voxels 68 → 55 ms, the same grid);
//! - the solid pass: as the winding rule (O(V/32 + crossings));
//! - labelling: B traversals of O(log X + nodes near the box); B is the number of boxes w_X comes within
//!   the bounds' width of a half-integer: boxes near the caps (whose size is that of the holes, not their
//!   number) and, for a soup welded by τ, the cells the ribbons cross (bounded there by their widths,
//!   then voxel by voxel on the cell's near list);
//! - direct: Z · (a bucket of the crossing index + one traversal); the plain O(T) sum only for the few
//!   voxels whose |w| is within the bounds' error of ½.
//!
//! The worst case is a soup whose pieces do not weld within τ (every triangle its own loop, X ≈ M): the
//! labels then separate interior from exterior box by box (k = ±1 inside), and every cell the surface
//! crosses is evaluated voxel by voxel: O(surface voxels · near triangles), never O(V · T).
//!
//! Not yet near-linear (measured, `gregvox bench --suite gwn`, table `gwn_worst`): a soup of long slivers
//! near a wide cap. Each ribbon is as long as its sliver, so no ribbon node's expansion converges (ρ ≈ D)
//! and their bounds, which add up in absolute value where the noise's signed values cancel, swamp the
//! margin of the voxels near the cap, where |w| is close to ½: those voxels open ribbons down to exact
//! leaves. An open tube of 20,000 segments as a noisy soup at 128³: 263 s against 0.64 s welded (2,000
//! segments: 2.0 s against 0.38 s), the same grids. Cutting the ribbons into pieces (so that their
//! expansions converge and cancel the noise) was measured and not kept: pieces of 32, 16 and 8 voxels took
//! 76, 37 and 14 s at 411 MB, 707 MB and 1.3 GB (174 MB uncut). What it needs is pieces only where a voxel
//! needs them, not stored (a ribbon as a line of dipoles, split implicitly along its length).
//!
//! # Memory and time
//! The tree, the index, the near zone and every listed voxel count against the budget
//! ([`GwnParams::budget`], `VoxelizeOptions::gwn_budget`; [`Error::Budget`] beyond it); the deadline is
//! checked for every box and every voxel of the long loops ([`Error::Timeout`]).
pub mod cap;
pub mod classify;
pub mod crossing;
pub mod direct;
pub mod edges;
pub mod kernel;
pub mod tree;
pub mod welded;
pub mod zone;

pub use cap::{Cap, CapLoop, Proxy};
pub use direct::Inside;
pub use kernel::{solid_angle, winding_number, FOUR_PI};

use super::cpu::{relabel, Region};
use super::grid::{GridFrame, VoxelGrid};
use super::mesh::TriMesh;
use crate::error::{Error, Result};
use classify::{Fractional, Limits, LISTED_BYTES};
use crossing::Crossings;
use edges::EdgeTree;
use rayon::prelude::*;
use std::sync::atomic::AtomicBool;
use tree::Tree;

/// The largest voxel edge of `frame`.
fn max_edge(frame: &GridFrame) -> f64 {
    frame.voxel_size.iter().fold(0.0f64, |m, &h| m.max(h))
}

/// The near distance for a rasterizer with `subpixel_bits` bits: max voxel edge × max(1/64, 4·2^−bits).
/// Snapping moves a vertex by at most 2^−(bits+1) of a voxel per axis, and a centre whose crossing count
/// it could change lies within twice that of a triangle; the weld adds at most [`weld_tolerance`].
pub fn near_distance(frame: &GridFrame, subpixel_bits: u32) -> f64 {
    let snap = 4.0 * 0.5f64.powi(subpixel_bits.min(30) as i32);
    max_edge(frame) * snap.max(1.0 / 64.0)
}

/// The weld tolerance τ: max voxel edge / 512.
pub fn weld_tolerance(frame: &GridFrame) -> f64 {
    max_edge(frame) / 512.0
}

/// A cap whose rim is at least this many (largest) voxel edges long is bounded through its rim.
pub const LARGE_RIM: f64 = 32.0;

/// Sub-pixel bits of the CPU scanline (`voxel::cpu::SUBPIXEL` = 2⁸).
pub const CPU_SUBPIXEL_BITS: u32 = 8;

/// What the generalized winding number did (`voxelize --json`: `gwn`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct GwnStats {
    /// Boundary loops capped (of the welded mesh).
    pub loops_capped: usize,
    /// Boundary edges of the welded mesh, with multiplicity.
    pub boundary_edges: usize,
    /// Vertices the weld moved onto another within τ (exact duplicates not counted).
    pub welded_vertices: usize,
    /// Ribbon triangles (between moved triangles and their welded selves).
    pub ribbon_triangles: usize,
    /// Triangles of the fractional term X (caps and ribbons): what the tree holds.
    pub fractional_triangles: usize,
    /// Voxels within the near distance of a triangle.
    pub near_voxels: u64,
    /// Boxes and cells whose interval was computed.
    pub boxes_evaluated: u64,
    /// Voxels of cells evaluated one by one on their cell's near list.
    pub voxels_evaluated: u64,
    /// Voxels whose label was k ≠ 0 (answered from the crossing count against k).
    pub relabelled_voxels: u64,
    /// Voxels decided directly: the near zone and the voxels no box bound labelled.
    pub direct_voxels: u64,
    /// Direct voxels the first traversal left undecided (decided by opening the worst nodes).
    pub refined: u64,
    /// Voxels decided by the plain sum over the mesh.
    pub plain_sums: u64,
    /// Voxels whose answer differs from the rasterized winding rule of M' ∪ C'.
    pub flipped: u64,
}

/// How [`resolve`] runs.
#[derive(Clone, Copy, Debug)]
pub struct GwnParams {
    pub inside: Inside,
    /// The near distance ([`near_distance`] of the rasterizer that made the grid).
    pub near: f64,
    /// Bytes the tree, the index and the listed voxels may take.
    pub budget: u64,
    /// A time limit: the instant and the seconds as given.
    pub deadline: Option<(std::time::Instant, f64)>,
}

/// `triangles` cut into k² congruent triangles each (k = ⌈longest edge / `edge`⌉; their union is the
/// triangle, so their solid angles add up to its own), then `rest` as they are.
pub fn subdivide(
    triangles: &[[[f64; 3]; 3]],
    edge: f64,
    rest: &[[[f64; 3]; 3]],
) -> Vec<[[f64; 3]; 3]> {
    let mut out = Vec::with_capacity(triangles.len() + rest.len());
    for &[a, b, c] in triangles {
        let longest = [(a, b), (b, c), (c, a)]
            .iter()
            .map(|(p, q)| kernel::norm(std::array::from_fn(|i| q[i] - p[i])))
            .fold(0.0f64, f64::max);
        let k = ((longest / edge).ceil() as usize).clamp(1, 1024);
        if k == 1 {
            out.push([a, b, c]);
            continue;
        }
        let at = |i: usize, j: usize| -> [f64; 3] {
            let (u, v) = (i as f64 / k as f64, j as f64 / k as f64);
            std::array::from_fn(|x| a[x] + u * (b[x] - a[x]) + v * (c[x] - a[x]))
        };
        for i in 0..k {
            for j in 0..k - i {
                out.push([at(i, j), at(i + 1, j), at(i, j + 1)]);
                if i + j + 1 < k {
                    out.push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
        }
    }
    out.extend_from_slice(rest);
    out
}

/// `triangles` of `mesh` local to `origin` (f64 corners).
pub fn local_triangles(mesh: &TriMesh, origin: [f64; 3]) -> Vec<[[f64; 3]; 3]> {
    mesh.triangles
        .par_iter()
        .map(|t| {
            t.map(|v| std::array::from_fn(|a| mesh.positions[v as usize][a] as f64 - origin[a]))
        })
        .collect()
}

fn check_budget(what: &str, bytes: u64, budget: u64) -> Result<()> {
    if bytes > budget {
        return Err(Error::Budget {
            what: format!("{what} ({} MiB)", bytes.div_ceil(1 << 20)),
            detail: format!(
                "the generalized winding number's memory budget of {} MiB (--gwn-budget MIB, \
                 VoxelizeOptions::gwn_budget; or --rule winding, or a coarser grid)",
                budget >> 20
            ),
        });
    }
    Ok(())
}

/// The fractional term X of a mesh (its proxy's caps and ribbons) with its trees, and M's triangles, local
/// to an origin: what both the grid ([`resolve`]) and scattered points (`api::query`) evaluate.
pub struct FractionalField {
    pub fractional: Fractional,
    /// M's triangles, local.
    pub mesh: Vec<[[f64; 3]; 3]>,
    /// X's triangles, local: caps first (loop by loop), then ribbons.
    pub x: Vec<[[f64; 3]; 3]>,
    /// Bytes of the trees and of the crossing index to come (what the budget counted).
    pub fixed_bytes: u64,
}

impl FractionalField {
    /// Builds the trees of `proxy`'s fractional term for `mesh`, in coordinates local to `origin`. `h` is
    /// the length scale (the largest voxel edge): caps whose rim is [`LARGE_RIM`]·h or longer are bounded
    /// through their rim. Refuses, before building, trees past `budget` bytes.
    pub fn build(
        mesh: &TriMesh,
        proxy: &Proxy,
        origin: [f64; 3],
        h: f64,
        budget: u64,
    ) -> Result<FractionalField> {
        let x = proxy.fractional(mesh, origin);
        let m = local_triangles(mesh, origin);
        // The caps' tree holds them cut into triangles of a few voxels (a fan's long triangles would keep every
        // box near a large hole from being bounded); the crossing index keeps them whole, exactly closed.
        let caps = proxy.cap.triangles.len();
        let local = |v: u32| -> [f64; 3] {
            let p = proxy.cap.position(mesh, v);
            std::array::from_fn(|a| p[a] as f64 - origin[a])
        };
        // Large caps (rim of LARGE_RIM voxel edges or more) are bounded through their rim, small ones through
        // their area.
        let (mut small, mut large, mut rim) = (Vec::new(), Vec::new(), Vec::new());
        for (n, lp) in proxy.cap.loops.iter().enumerate() {
            let edges = &proxy.cap.rim[lp.rim_first as usize..(lp.rim_first + lp.edges) as usize];
            let length: f64 = edges
                .iter()
                .map(|e| {
                    let [p, q] = e.map(local);
                    kernel::norm(std::array::from_fn(|a| q[a] - p[a]))
                })
                .sum();
            if length >= LARGE_RIM * h {
                large.push(n);
                rim.extend(edges.iter().map(|e| e.map(local)));
            } else {
                small.push(n);
            }
        }
        let loop_triangles = |loops: &[usize]| -> usize {
            loops
                .iter()
                .map(|&n| proxy.cap.loops[n].count as usize)
                .sum()
        };
        let loop_iter = |loops: Vec<usize>| {
            let x = &x;
            loops.into_iter().flat_map(move |n| {
                let lp = proxy.cap.loops[n];
                x[lp.first as usize..(lp.first + lp.count) as usize]
                    .iter()
                    .copied()
            })
        };
        let (t, ribbons) = (mesh.triangles.len(), x.len() - caps);
        let fixed = Tree::bytes_for(loop_triangles(&small), classify::CAP_LEAF)
            + Tree::bytes_for(loop_triangles(&large), classify::LARGE_LEAF)
            + Tree::bytes_for(ribbons, tree::LEAF)
            + rim.len() as u64 * 120
            + (t + x.len()) as u64 * 96;
        check_budget(
            &format!(
                "the fractional term's trees and the crossing index: {} triangles of caps and ribbons, {t} of the \
                 mesh",
                x.len()
            ),
            fixed,
            budget,
        )?;
        let ((caps_tree, large_tree), (rim_tree, ribbons_tree)) = rayon::join(
            || {
                rayon::join(
                    || Tree::build_with(loop_iter(small), classify::CAP_LEAF),
                    || Tree::build_with(loop_iter(large), classify::LARGE_LEAF),
                )
            },
            || rayon::join(|| EdgeTree::build(&rim), || Tree::build(&x[caps..])),
        );
        drop(rim);
        let fractional = Fractional {
            caps: caps_tree,
            large: large_tree,
            rim: rim_tree,
            ribbons: ribbons_tree,
        };
        Ok(FractionalField {
            fractional,
            mesh: m,
            x,
            fixed_bytes: fixed,
        })
    }
}

/// Turns `grid`, the winding rule (or, for [`Inside::Positive`], the positive rule) of `closed` = M' ∪ C'
/// rasterized along its bit axis, into the generalized winding number's decision for `mesh` = M
/// ([`GwnStats`] says what it took).
pub fn resolve(
    grid: &mut VoxelGrid,
    mesh: &TriMesh,
    closed: &TriMesh,
    proxy: &Proxy,
    params: &GwnParams,
) -> Result<GwnStats> {
    let frame = grid.frame;
    let mut stats = GwnStats {
        loops_capped: proxy.cap.loops.len(),
        boundary_edges: proxy.cap.boundary_edges,
        welded_vertices: proxy.moved,
        ribbon_triangles: proxy.ribbons.len(),
        ..GwnStats::default()
    };
    if proxy.is_trivial() {
        return Ok(stats);
    }
    let expired = AtomicBool::new(false);
    let limits = |listed: u64| Limits {
        deadline: params.deadline.map(|d| d.0),
        seconds: params.deadline.map_or(0.0, |d| d.1),
        max_listed: (params.budget / LISTED_BYTES).saturating_sub(listed),
        expired: &expired,
    };
    let timing = std::env::var_os("GREGVOX_GWN_TIMES").is_some();
    let mut clock = std::time::Instant::now();
    let mut lap = |what: &str| {
        if timing {
            let peak = std::fs::read_to_string("/proc/self/status")
                .ok()
                .and_then(|s| s.lines().find(|l| l.starts_with("VmHWM")).map(String::from))
                .unwrap_or_default();
            eprintln!(
                "gwn: {what} {:.1} ms ({peak})",
                clock.elapsed().as_secs_f64() * 1e3
            );
        }
        clock = std::time::Instant::now();
    };
    lap("start");
    let FractionalField {
        fractional,
        mesh: mut m,
        x,
        fixed_bytes: fixed,
    } = FractionalField::build(mesh, proxy, frame.origin, max_edge(&frame), params.budget)?;
    stats.fractional_triangles = x.len();
    let t = mesh.triangles.len();
    lap("trees");
    // The near zone: within `near` of M or of the cap. The ribbons lie within the weld's moves of M, so the
    // labels' distance `nu` below allows for them, and a voxel lying on one is found by its crossing count
    // (`welded`: on a prism or on M' ∪ C'), which sends it to the plain sum as the on-surface list
    // does (walking a soup's ribbons here cost 19 of its 23 ms at 256³).
    let caps = proxy.cap.triangles.len();
    let (zone, on_surface) = zone::near_voxels(&[&m, &x[..caps]], &frame, params.near);
    stats.near_voxels = zone.len() as u64;
    lap("near zone");
    check_budget(
        &format!("{} voxels near the surface to decide directly", zone.len()),
        fixed + zone.len() as u64 * LISTED_BYTES,
        params.budget,
    )?;
    if limits(0).expired() {
        return Err(Error::Timeout {
            seconds: params.deadline.map_or(0.0, |d| d.1),
            stage: "finding the voxels near the surface".into(),
        });
    }
    let nu = params.near - proxy.max_shift;
    let labels = classify::classify(&frame, &fractional, nu, &zone, &limits(zone.len() as u64))?;
    lap("labels");
    stats.boxes_evaluated = labels.boxes_evaluated;
    stats.voxels_evaluated = labels.voxels_evaluated;
    // Labels k ≠ 0: the crossing count against k.
    let mut regions: Vec<Region> = labels.boxes.clone();
    regions.extend(
        labels
            .voxels
            .iter()
            .map(|&(v, k)| (v, [v[0] + 1, v[1] + 1, v[2] + 1], k)),
    );
    stats.relabelled_voxels = regions
        .iter()
        .map(|(lo, hi, _)| (0..3).map(|a| (hi[a] - lo[a]) as u64).product::<u64>())
        .sum();
    let positive = params.inside == Inside::Positive;
    stats.flipped += relabel(closed, grid, &regions, positive);
    drop(regions);
    lap("relabel");
    // The direct voxels: the zone and what no label settled.
    let mut direct = zone;
    direct.extend_from_slice(&labels.undecided);
    direct.par_sort_unstable();
    direct.dedup();
    stats.direct_voxels = direct.len() as u64;
    check_budget(
        &format!("{} voxels to decide directly", direct.len()),
        fixed + direct.len() as u64 * LISTED_BYTES,
        params.budget,
    )?;
    // The crossing index takes M ∪ X whole; M's triangles, first, are also the plain sum's. A weld that
    // moved vertices put its ribbons into X (a soup: about six a triangle): the direct voxels then read the
    // welded, capped mesh and the prisms of the moved triangles (`welded`), M ∪ X is never indexed, and a
    // voxel lying on one of those surfaces goes to the plain sum over M, summed in the frame M ∪ X's index
    // would have held it in (the same rounding).
    let counting = if proxy.ribbons.is_empty() {
        let mut chain = std::mem::take(&mut m);
        chain.extend_from_slice(&x);
        Counting::Whole(Crossings::new(chain))
    } else {
        // The budget counted M ∪ X's index (in `fixed`); the welded one (|M'| + |C'| triangles) takes its
        // place, and the plain sum reads M's triangles from the mesh.
        let axis = crossing::ray_axis(&[&m, &x]);
        drop((m, x));
        Counting::Welded(
            welded::WeldedCounts::new(mesh, proxy, &frame, &direct),
            welded::MeshSum {
                mesh,
                origin: frame.origin,
                axis,
            },
        )
    };
    lap("crossing index");
    let count = |slot: usize, q: [f64; 3]| match &counting {
        Counting::Whole(e) => e.winding(q),
        Counting::Welded(w, _) => w.winding(slot, q),
    };
    let plain_sum = |q: [f64; 3]| match &counting {
        Counting::Whole(e) => e.plain_sum(q, t),
        Counting::Welded(_, p) => p.sum(q),
    };
    let (answers, counts) = direct::decide(
        &frame,
        &direct,
        &fractional,
        &count,
        &plain_sum,
        &on_surface,
        params.inside,
        &limits(direct.len() as u64),
    )?;
    lap("direct");
    stats.refined = counts.refined;
    stats.plain_sums = counts.plain_sums;
    for (&id, &solid) in direct.iter().zip(&answers) {
        let [i, j, k] = zone::unlinear(&frame, id);
        if grid.get(i, j, k) != solid {
            grid.set(i, j, k, solid);
            stats.flipped += 1;
        }
    }
    Ok(stats)
}

/// How the direct voxels get their integer part and their plain sums.
enum Counting<'a> {
    /// M ∪ X indexed whole (M's triangles first: the plain sum's).
    Whole(Crossings),
    /// A welded soup: M' ∪ C' and the prisms, and M alone for the plain sum.
    Welded(welded::WeldedCounts, welded::MeshSum<'a>),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voxel::cpu::{column_windings, voxelize_cpu, FillRule};
    use crate::voxel::grid::Axis;

    #[test]
    fn the_column_winding_is_the_scanlines_crossing_count() {
        // Two overlapping cubes, one inward: windings 0, 1, −1 and 2 show up.
        let mut mesh = TriMesh::cube([0.0; 3], 1.0);
        let mut inner = TriMesh::cube([0.25; 3], 0.5);
        for t in &mut inner.triangles {
            t.swap(1, 2);
        }
        mesh.append(&inner);
        mesh.append(&TriMesh::cube([0.5; 3], 1.0));
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
                let p = frame.centre(v[0], v[1], v[2]);
                let w = winding_number(&mesh, p);
                if (w - w.round()).abs() < 1e-6 {
                    assert_eq!(n, w.round() as i32, "{axis:?} {v:?}");
                }
                seen.insert(n);
            }
            assert!(seen.contains(&2) && seen.contains(&0), "{seen:?}");
        }
    }
}
