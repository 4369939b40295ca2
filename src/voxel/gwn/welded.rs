//! The integer part of the direct voxels ([`WeldedCounts`]) and of scattered points ([`WeldedChain`],
//! `api::query`) from the welded, capped mesh M' ∪ C' instead of M ∪ X, so that a soup's hundreds of
//! thousands of ribbons are never indexed.
//!
//! The chains: X = C' − Q (`super::cap`), and for each triangle T of M with its welded T' the prism
//! P_T = T' − T + Q_ab + Q_bc + Q_ca is closed. Summed over T, M + X = M' + C' − Σ P_T, so at any point q off
//! every one of these triangles the winding numbers obey n_{M∪X}(q) = n_{M'∪C'}(q) − Σ_T n_{P_T}(q). A
//! prism's winding number vanishes outside the hull of T ∪ T', which lies within δ_T (T's largest vertex
//! move) of T; a prism whose corners did not move is T' − T with T' = T as positions, whose count is zero
//! wherever it is defined. So only the direct voxels within δ_T of a moved T carry a correction, found
//! triangle by triangle as the near zone finds its voxels (`super::zone`, columns under the triangle:
//! never the volume of its box), each the exact crossing count of the prism's at most eight triangles
//! ([`Crossings::chain_winding`]).
//!
//! The filters are those of the chains themselves: T' is part of M' when its three representatives are
//! distinct (`Proxy::closed`), a quad's triangle part of X when its three positions are
//! (`Proxy::new`), and T always part of M. A voxel lying on a triangle of M' ∪ C' (the index is built with
//! its flat triangles, so it says so) or of a prism answers `None` here, and the caller decides it by the
//! plain sum over M, as it does the voxels on M itself: such a centre lies within the weld's moves of M, and
//! M ∪ X is never indexed.
//!
//! Cost: the index holds |M'| + |C'| triangles instead of |M| + |C'| + |Q| (a soup: about 6 ribbons a
//! triangle); the corrections cost the columns under the moved triangles (each δ_T ≤ the weld's largest
//! move thick: a few centres, if any) and a binary search in the direct list per centre found.
//!
//! Memory: the budget counts M ∪ X's index; this one (|M'| + |C'| ≤ |M| + |C'| triangles) takes its place,
//! and the plain sum reads M's own triangles ([`MeshSum`]).
use super::cap::Proxy;
use super::crossing::Crossings;
use super::zone::{centre, near_triangle, unlinear};
use crate::voxel::grid::GridFrame;
use crate::voxel::mesh::TriMesh;
use rayon::prelude::*;

/// The representatives of triangle `t` when the weld moved one of its corners (bit for bit), else `None`.
fn moved_to(mesh: &TriMesh, proxy: &Proxy, t: [u32; 3]) -> Option<[u32; 3]> {
    let bits = |v: u32| mesh.positions[v as usize].map(|x| (x + 0.0).to_bits());
    let rep = t.map(|v| proxy.rep[v as usize]);
    (0..3).any(|k| bits(t[k]) != bits(rep[k])).then_some(rep)
}

/// The counts of a list of direct voxels: M' ∪ C' and, per voxel, the prisms' correction.
pub struct WeldedCounts {
    index: Crossings,
    /// Σ n_{P_T} at each voxel of the list.
    corrections: Vec<i32>,
    /// Voxels lying on a prism's triangle: decided by the caller's plain sum.
    on_prism: Vec<bool>,
}

impl WeldedCounts {
    /// The counts at `voxels` (sorted linear indices of `frame`) for `mesh` welded and capped by `proxy`, in
    /// coordinates local to `frame.origin` (as `super::local_triangles`).
    pub fn new(mesh: &TriMesh, proxy: &Proxy, frame: &GridFrame, voxels: &[u64]) -> WeldedCounts {
        let origin = frame.origin;
        let local = |p: [f32; 3]| -> [f64; 3] { std::array::from_fn(|a| p[a] as f64 - origin[a]) };
        let closed = proxy.closed(mesh);
        let index = Crossings::with_flat_triangles(super::local_triangles(&closed, origin));
        drop(closed);
        let extent: f64 = (0..3)
            .map(|a| frame.dims[a] as f64 * frame.voxel_size[a])
            .sum();
        // Per chunk of triangles one list of hits and one scratch list of near voxels; a prism is made only
        // for a moved triangle with a direct voxel near it (most have none).
        let found: Vec<Vec<(u32, Option<i32>)>> = mesh
            .triangles
            .par_chunks(1024)
            .map(|chunk| {
                let (mut out, mut near) = (Vec::new(), Vec::new());
                for &t in chunk {
                    let Some(rep) = moved_to(mesh, proxy, t) else {
                        continue;
                    };
                    let corners = t.map(|v| local(mesh.positions[v as usize]));
                    let moved = (0..3)
                        .map(|k| {
                            let (p, q) = (corners[k], local(mesh.positions[rep[k] as usize]));
                            super::kernel::norm(std::array::from_fn(|a| q[a] - p[a]))
                        })
                        .fold(0.0f64, f64::max);
                    let scale = extent
                        + corners
                            .iter()
                            .flat_map(|p| p.iter())
                            .fold(0.0f64, |m, x| m.max(x.abs()));
                    // The hull lies within the largest move of T; the slack covers the rounding of the
                    // distances the zone's walk computes (a few ulps of the coordinates).
                    let reach = moved * (1.0 + 1e-6) + 1e-12 * scale;
                    near.clear();
                    near_triangle(&corners, frame, reach, &mut near);
                    // A sliver is walked edge by edge: a voxel counts once.
                    near.sort_unstable();
                    near.dedup_by_key(|f| f.0);
                    let mut p = None;
                    for &(id, _) in &near {
                        if let Ok(slot) = voxels.binary_search(&id) {
                            let p = p.get_or_insert_with(|| prism(mesh, t, rep, &local));
                            let q = centre(frame, unlinear(frame, id));
                            out.push((slot as u32, index.chain_winding(p, q)));
                        }
                    }
                }
                out
            })
            .collect();
        let mut corrections = vec![0i32; voxels.len()];
        let mut on_prism = vec![false; voxels.len()];
        for (slot, n) in found.into_iter().flatten() {
            match n {
                Some(n) => corrections[slot as usize] += n,
                None => on_prism[slot as usize] = true,
            }
        }
        WeldedCounts {
            index,
            corrections,
            on_prism,
        }
    }

    /// n_{M∪X} at `q`, the centre of the list's voxel `slot`; `None` when q lies on M' ∪ C' or on a prism.
    pub fn winding(&self, slot: usize, q: [f64; 3]) -> Option<i32> {
        if self.on_prism[slot] {
            return None;
        }
        self.index.winding(q).map(|n| n - self.corrections[slot])
    }

    /// Voxels that carried a correction (the tests' evidence that the prisms were counted).
    pub fn corrected(&self) -> usize {
        self.corrections.iter().filter(|&&n| n != 0).count()
    }
}

/// n_{M∪X} at arbitrary points (`api::query`, where no list of voxels is known in advance): M' ∪ C' indexed
/// with its flat triangles, and the prisms of the moved triangles found through a hash of their boxes (the
/// box of T ∪ T' holds the prism, whose count is zero outside its hull). A point on a triangle of M' ∪ C' or
/// of a prism (T itself among them) answers `None`, as [`Crossings::winding`] on M ∪ X did; the plain sum
/// ([`WeldedChain::plain_sum`]) is that index's, bit for bit.
///
/// Cost: the index of |M'| + |C'| triangles instead of |M| + |C'| + |Q| (a soup: about 6 ribbons a
/// triangle); a query adds one binary search in the boxes' cells and, for each box holding the point (a
/// point within a moved triangle's box: near the surface), the prism's eight exact crossing tests.
/// Memory: the index, the mesh (positions and triangles), 56 bytes per moved triangle and 16 per cell its
/// box covers.
pub struct WeldedChain {
    index: Crossings,
    mesh: TriMesh,
    rep: Vec<u32>,
    /// The ray axis of M ∪ X, for the plain sum.
    axis: usize,
    /// The moved triangles: index into `mesh.triangles` and the box of T ∪ T'.
    moved: Vec<(u32, [f64; 3], [f64; 3])>,
    /// (cell key, moved index), sorted; boxes over [`WIDE_CELLS`] cells are in `wide` instead.
    cells: Vec<(u64, u32)>,
    wide: Vec<u32>,
    lo: [f64; 3],
    cell: f64,
    origin: [f64; 3],
}

/// A moved triangle's box covering more cells than this goes to the list every query scans.
const WIDE_CELLS: u64 = 64;

impl WeldedChain {
    /// The chain of `mesh` welded and capped by `proxy`, in coordinates local to `origin` (as
    /// `super::local_triangles`); `axis` is M ∪ X's ray axis ([`super::crossing::ray_axis`]). `None`, before
    /// anything is indexed, when a query could have to test more than `max_bucket` prisms' boxes (many moved
    /// triangles whose boxes overlap: a noisy fan's slivers round their apex, where every point would test
    /// them all; M ∪ X's index, whose buckets follow the triangles and not their boxes, suits such a mesh).
    pub fn new(
        mesh: &TriMesh,
        proxy: &Proxy,
        origin: [f64; 3],
        axis: usize,
        max_bucket: usize,
    ) -> Option<WeldedChain> {
        let local = |p: [f32; 3]| -> [f64; 3] { std::array::from_fn(|a| p[a] as f64 - origin[a]) };
        let moved: Vec<(u32, [f64; 3], [f64; 3])> = mesh
            .triangles
            .par_iter()
            .enumerate()
            .filter_map(|(i, &t)| {
                let rep = moved_to(mesh, proxy, t)?;
                let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
                for v in t.iter().chain(&rep) {
                    let p = local(mesh.positions[*v as usize]);
                    for a in 0..3 {
                        lo[a] = lo[a].min(p[a]);
                        hi[a] = hi[a].max(p[a]);
                    }
                }
                Some((i as u32, lo, hi))
            })
            .collect();
        // Cells twice the median box's largest side (most boxes cover a few), at most 2²⁰ a side.
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        let mut sides: Vec<f64> = Vec::with_capacity(moved.len());
        for (_, l, h) in &moved {
            for a in 0..3 {
                lo[a] = lo[a].min(l[a]);
                hi[a] = hi[a].max(h[a]);
            }
            sides.push((0..3).map(|a| h[a] - l[a]).fold(0.0f64, f64::max));
        }
        let extent = (0..3).map(|a| hi[a] - lo[a]).fold(0.0f64, f64::max);
        let mid = sides.len() / 2;
        let median = if sides.is_empty() {
            0.0
        } else {
            *sides.select_nth_unstable_by(mid, f64::total_cmp).1
        };
        let cell = (2.0 * median)
            .max(extent / (1u64 << 20) as f64)
            .max(f64::MIN_POSITIVE);
        let (mut cells, mut wide) = (Vec::new(), Vec::new());
        for (j, (_, l, h)) in moved.iter().enumerate() {
            let (a, b) = (cell_of(lo, cell, *l), cell_of(lo, cell, *h));
            let count: u64 = (0..3).map(|k| (b[k] - a[k] + 1) as u64).product();
            if count > WIDE_CELLS {
                wide.push(j as u32);
                continue;
            }
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        cells.push((key([x, y, z]), j as u32));
                    }
                }
            }
        }
        cells.par_sort_unstable();
        let worst = cells.chunk_by(|a, b| a.0 == b.0).map(<[_]>::len).max();
        if worst.unwrap_or(0) + wide.len() > max_bucket {
            return None;
        }
        let index =
            Crossings::with_flat_triangles(super::local_triangles(&proxy.closed(mesh), origin));
        Some(WeldedChain {
            index,
            mesh: mesh.clone(),
            rep: proxy.rep.clone(),
            axis,
            moved,
            cells,
            wide,
            lo,
            cell,
            origin,
        })
    }

    /// n_{M∪X} at `q` (local); `None` when q lies on M' ∪ C' or on a prism.
    pub fn winding(&self, q: [f64; 3]) -> Option<i32> {
        let n = self.index.winding(q)?;
        let k = key(cell_of(self.lo, self.cell, q));
        let start = self.cells.partition_point(|&(c, _)| c < k);
        let here = self.cells[start..]
            .iter()
            .take_while(|&&(c, _)| c == k)
            .map(|&(_, j)| j);
        let mut correction = 0;
        for j in here.chain(self.wide.iter().copied()) {
            let (t, lo, hi) = self.moved[j as usize];
            if (0..3).any(|a| q[a] < lo[a] || q[a] > hi[a]) {
                continue;
            }
            let t = self.mesh.triangles[t as usize];
            let rep = t.map(|v| self.rep[v as usize]);
            let o = self.origin;
            let local = |p: [f32; 3]| -> [f64; 3] { std::array::from_fn(|a| p[a] as f64 - o[a]) };
            correction += self
                .index
                .chain_winding(&prism(&self.mesh, t, rep, &local), q)?;
        }
        Some(n - correction)
    }

    /// M's winding number at `q` (local) by the plain sum in triangle order, as M ∪ X's index sums it.
    pub fn plain_sum(&self, q: [f64; 3]) -> f64 {
        MeshSum {
            mesh: &self.mesh,
            origin: self.origin,
            axis: self.axis,
        }
        .sum(q)
    }
}

/// The cell of `p` in the grid of cells of side `cell` from `lo`.
fn cell_of(lo: [f64; 3], cell: f64, p: [f64; 3]) -> [u32; 3] {
    std::array::from_fn(|a| {
        let c = ((p[a] - lo[a]) / cell).floor();
        c.clamp(0.0, ((1u32 << 21) - 1) as f64) as u32
    })
}

/// A cell's key: 21 bits an axis.
fn key(c: [u32; 3]) -> u64 {
    (c[0] as u64) | (c[1] as u64) << 21 | (c[2] as u64) << 42
}

/// The plain sum over a mesh's own triangles without a copy of them: each triangle in the local f64 frame
/// (as `super::local_triangles`) and permuted as a [`Crossings`] with ray axis `axis` holds it, so the sum
/// is that index's [`Crossings::plain_sum`], rounding included.
pub struct MeshSum<'a> {
    pub mesh: &'a TriMesh,
    pub origin: [f64; 3],
    pub axis: usize,
}

impl MeshSum<'_> {
    /// The winding number at `q` (local) by the plain sum in triangle order.
    pub fn sum(&self, q: [f64; 3]) -> f64 {
        let (a, origin) = (self.axis, self.origin);
        let permute = |p: [f64; 3]| [p[(a + 1) % 3], p[(a + 2) % 3], p[a]];
        let corner = |v: u32| -> [f64; 3] {
            let p = self.mesh.positions[v as usize];
            permute(std::array::from_fn(|k| p[k] as f64 - origin[k]))
        };
        let q = permute(q);
        let mut sum = 0.0;
        for t in &self.mesh.triangles {
            sum += super::kernel::solid_angle(q, corner(t[0]), corner(t[1]), corner(t[2]));
        }
        sum / super::kernel::FOUR_PI
    }
}

/// P_T = T' − T + Q_ab + Q_bc + Q_ca for T = `t` and its representatives `rep`, as the chains hold them.
fn prism(
    mesh: &TriMesh,
    t: [u32; 3],
    rep: [u32; 3],
    local: &impl Fn([f32; 3]) -> [f64; 3],
) -> Vec<[[f64; 3]; 3]> {
    let pos = |v: u32| mesh.positions[v as usize];
    let distinct = |tri: [u32; 3]| {
        let [a, b, c] = tri.map(|v| pos(v).map(|x| (x + 0.0).to_bits()));
        a != b && b != c && c != a
    };
    let corners = |tri: [u32; 3]| tri.map(|v| local(pos(v)));
    let mut out = Vec::with_capacity(8);
    if rep[0] != rep[1] && rep[1] != rep[2] && rep[2] != rep[0] {
        out.push(corners(rep));
    }
    out.push(corners([t[0], t[2], t[1]]));
    for k in 0..3 {
        let (u, v) = (t[k], t[(k + 1) % 3]);
        let (u2, v2) = (rep[k], rep[(k + 1) % 3]);
        // X holds −Q as (u, v', v) and (u, u', v'), when their positions are distinct: Q is their reverse.
        for (x, kept) in [([u, v, v2], [u, v2, v]), ([u, v2, u2], [u, u2, v2])] {
            if distinct(kept) {
                out.push(corners(x));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voxel::gwn::zone::near_voxels;
    use crate::voxel::stress;

    /// A noisy soup of a sphere with holes, welded with moves of a tenth of a voxel: many centres lie inside
    /// the prisms between a moved triangle and its welded self, where M' ∪ C' alone counts wrong.
    fn broken_soup() -> (TriMesh, Proxy, GridFrame) {
        let sphere = TriMesh::sphere([0.0; 3], 1.0, 24, 32, false);
        let holed = stress::with_holes(&sphere, 0.1, 7);
        let soup = stress::soup(&holed, 2e-3, 11);
        let proxy = Proxy::new(&soup, 1e-2).unwrap();
        assert!(proxy.moved > 0 && !proxy.ribbons.is_empty() && !proxy.cap.loops.is_empty());
        let frame = GridFrame {
            dims: [110; 3],
            origin: [-1.1; 3],
            voxel_size: [0.02; 3],
        };
        (soup, proxy, frame)
    }

    #[test]
    fn the_welded_counts_are_the_whole_chains_at_every_voxel_near_the_surface_inside_the_prisms_too(
    ) {
        let (soup, proxy, frame) = broken_soup();
        let m = crate::voxel::gwn::local_triangles(&soup, frame.origin);
        let x = proxy.fractional(&soup, frame.origin);
        let mut chain = m.clone();
        chain.extend_from_slice(&x);
        let whole = Crossings::new(chain);
        // Every centre within a quarter voxel of the mesh: the prisms (moves up to ~3.5e-3) lie far inside.
        let (voxels, _) = near_voxels(&[&m, &x], &frame, 0.005);
        let welded = WeldedCounts::new(&soup, &proxy, &frame, &voxels);
        let (mut agreed, mut on) = (0, 0);
        for (slot, &id) in voxels.iter().enumerate() {
            let q = centre(&frame, unlinear(&frame, id));
            match (welded.winding(slot, q), whole.winding(q)) {
                (Some(a), Some(b)) => {
                    assert_eq!(a, b, "voxel {id}");
                    agreed += 1;
                }
                // Off M ∪ X the whole chain always answers; on it the welded counts must not.
                (Some(a), None) => {
                    panic!("voxel {id} lies on M ∪ X, yet the welded counts say {a}")
                }
                (None, _) => on += 1,
            }
        }
        assert!(agreed > 1000, "{agreed} voxels compared");
        // The prisms mattered: without their corrections these voxels would have been counted wrong.
        assert!(welded.corrected() > 20, "{} corrected", welded.corrected());
        assert!(on < agreed / 100, "{on} voxels left to the whole chain");
    }

    #[test]
    fn the_welded_chain_counts_scattered_points_as_the_whole_chain_does_and_its_plain_sum_is_the_same(
    ) {
        // The query's form: no list of voxels, the prisms found through their boxes' cells.
        let (soup, proxy, frame) = broken_soup();
        let m = crate::voxel::gwn::local_triangles(&soup, frame.origin);
        let x = proxy.fractional(&soup, frame.origin);
        let axis = super::super::crossing::ray_axis(&[&m, &x]);
        let mut all = m.clone();
        all.extend_from_slice(&x);
        let whole = Crossings::with_flat_triangles(all);
        let chain = WeldedChain::new(&soup, &proxy, frame.origin, axis, 256).unwrap();
        let (voxels, _) = near_voxels(&[&m, &x], &frame, 0.005);
        let (mut agreed, mut corrected, mut on) = (0, 0, 0);
        for &id in &voxels {
            let q = centre(&frame, unlinear(&frame, id));
            match (chain.winding(q), whole.winding(q)) {
                (Some(a), Some(b)) => {
                    assert_eq!(a, b, "voxel {id}");
                    agreed += 1;
                    corrected += usize::from(chain.index.winding(q) != Some(a));
                }
                (Some(a), None) => panic!("voxel {id} lies on M ∪ X, yet the chain says {a}"),
                (None, _) => on += 1,
            }
        }
        assert!(
            agreed > 1000 && corrected > 20,
            "{agreed} agreed, {corrected} corrected"
        );
        assert!(on < agreed / 100, "{on} on a surface");
        // Points on M itself (its corners, which rounding cannot move off it): never counted.
        for t in m.iter().step_by(7) {
            for q in *t {
                assert_eq!(whole.winding(q), None);
                assert_eq!(chain.winding(q), None, "{q:?}");
            }
        }
        for id in (0..110u64.pow(3)).step_by(9973) {
            let q = centre(&frame, unlinear(&frame, id));
            assert_eq!(
                chain.plain_sum(q).to_bits(),
                whole.plain_sum(q, m.len()).to_bits()
            );
        }
    }

    #[test]
    fn a_noisy_fans_overlapping_boxes_refuse_the_welded_chain_before_indexing() {
        // Two 2,000-gons fanned from one vertex, every sliver its own vertices moved by 1e-7: round the
        // apexes every sliver's box holds the points, so each would test thousands of prisms.
        let soup = stress::soup(&stress::polygon_prism(2000), 1e-7, 3);
        let proxy = Proxy::new(&soup, 1e-5).unwrap();
        assert!(proxy.moved > 0);
        let m = crate::voxel::gwn::local_triangles(&soup, [0.0; 3]);
        let x = proxy.fractional(&soup, [0.0; 3]);
        let axis = super::super::crossing::ray_axis(&[&m, &x]);
        assert!(WeldedChain::new(&soup, &proxy, [0.0; 3], axis, 256).is_none());
        assert!(WeldedChain::new(&soup, &proxy, [0.0; 3], axis, usize::MAX).is_some());
    }

    #[test]
    fn the_plain_sum_over_the_mesh_is_the_whole_indexs_bit_for_bit() {
        // The direct voxels on a welded surface or a prism go to the plain sum over M without M ∪ X's index:
        // it must be that index's sum to the last bit (the same frame, the same order), or a centre whose
        // |w| rounds to ½ would change side.
        let (soup, proxy, frame) = broken_soup();
        let m = crate::voxel::gwn::local_triangles(&soup, frame.origin);
        let x = proxy.fractional(&soup, frame.origin);
        let axis = super::super::crossing::ray_axis(&[&m, &x]);
        let mut chain = m.clone();
        chain.extend_from_slice(&x);
        let whole = Crossings::new(chain);
        let sum = MeshSum {
            mesh: &soup,
            origin: frame.origin,
            axis,
        };
        for id in (0..110u64.pow(3)).step_by(9973) {
            let q = centre(&frame, unlinear(&frame, id));
            let (a, b) = (sum.sum(q), whole.plain_sum(q, m.len()));
            assert_eq!(a.to_bits(), b.to_bits(), "voxel {id}: {a} against {b}");
        }
    }

    #[test]
    fn a_prism_is_closed_and_counts_one_inside_its_hull() {
        // One triangle whose corners all moved up by 0.01 onto a welded copy: the prism between them.
        let mesh = TriMesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 0.01],
                [1.0, 0.0, 0.01],
                [0.0, 1.0, 0.01],
            ],
            triangles: vec![[0, 1, 2], [3, 4, 5]],
        };
        let local = |p: [f32; 3]| p.map(|x| x as f64);
        let p = prism(&mesh, [0, 1, 2], [3, 4, 5], &local);
        assert_eq!(p.len(), 8);
        let index = Crossings::new(vec![[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]);
        for (q, want) in [
            ([0.2, 0.2, 0.005], Some(1)),
            ([0.2, 0.2, 0.02], Some(0)),
            ([0.2, 0.2, -0.005], Some(0)),
            ([0.8, 0.8, 0.005], Some(0)),
            ([0.2, 0.2, 0.0], None),
            ([0.0, 0.5, 0.005], None),
        ] {
            assert_eq!(index.chain_winding(&p, q), want, "{q:?}");
        }
    }
}
