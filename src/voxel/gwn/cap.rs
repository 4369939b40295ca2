//! The closed proxy of an open mesh and the fractional term it leaves: weld, cap, ribbons.
//!
//! The identity: for any triangles X with M ∪ X closed, w_M = n − w_X, where n = w_{M∪X} is an integer
//! (a signed crossing count). gregvox chooses X small, so the rasterizer can count n for every voxel at
//! once and the hierarchy only has to bound w_X:
//! 1. **Weld** (tolerance τ): exact duplicates (−0 and +0 alike) become one vertex; then each seam — a
//!    boundary edge whose reversed twin lies within τ at both ends — is closed by joining the twins' ends
//!    (see `weld`). M' is M with the joined vertices moved onto their group's first: a soup whose seams are
//!    a hair apart becomes one piece, and dense but honest geometry is left as it is.
//! 2. **Cap**: the boundary of M' is a 1-chain (each welded edge counts its oriented uses); edges whose uses
//!    do not cancel are boundary, with multiplicity. It splits into closed loops (walked deterministically,
//!    cut as soon as the walk meets its own path); a loop of three is capped by its own reversed triangle, a
//!    longer one by a fan from its centroid (rounded to f32), a very long one run by run (`CHUNK` edges a
//!    fan, then the polygon of the runs' ends). C' closes M': M' ∪ C' is what the solid pass rasterizes.
//! 3. **Ribbons**: for each triangle T = (a, b, c) of M and its welded T' = (a', b', c'), the surface
//!    T' − T + Q_ab + Q_bc + Q_ca is closed (Q_uv the quad u, v, v', u'), so its winding number vanishes
//!    outside the hull of T ∪ T' (within τ of T). Hence w_M = w_{M'} + w_Q there, and X = C' ∪ (−Q):
//!    w_M = n_{M'∪C'} − w_X. The ribbons are thin (width ≤ the weld's largest move), so the tree bounds them
//!    by their widths ([`super::tree`]). Quads whose corners did not move vanish.
//!
//! Invariants: the weld moves no vertex farther than 2τ ([`Proxy::max_shift`]); M ∪ X is a closed chain
//! exactly (as positions), so the exact crossing count of `super::crossing` applies to it; with τ = 0 and no
//! duplicate positions nothing moves and X is the cap alone.
use crate::error::{Error, Result};
use crate::voxel::mesh::TriMesh;
use rayon::prelude::*;

/// Edges of a run of a long loop fanned on its own (see `Cap::cap_vertices`).
pub const CHUNK: usize = 16;

/// A loop of the boundary chain and its cap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CapLoop {
    /// First cap triangle of this loop in [`Cap::triangles`].
    pub first: u32,
    /// Cap triangles of the loop (1 for a loop of three, its edge count for a fan, a few more for a long
    /// loop capped run by run).
    pub count: u32,
    /// Edges of the loop.
    pub edges: u32,
    /// Its first edge in [`Cap::rim`].
    pub rim_first: u32,
}

/// The cap of a welded mesh: one triangle or a fan over every loop of its boundary chain.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cap {
    /// Apex positions, appended after the mesh's positions.
    pub apexes: Vec<[f32; 3]>,
    /// Cap triangles, indexing the mesh's positions, then the apexes.
    pub triangles: Vec<[u32; 3]>,
    pub loops: Vec<CapLoop>,
    /// Boundary edges counted with multiplicity.
    pub boundary_edges: usize,
    /// The boundary edges themselves (u → v, the welded mesh's orientation), loop after loop: the rim
    /// whose Biot–Savart integral is the cap term's gradient.
    pub rim: Vec<[u32; 2]>,
}

impl Cap {
    /// The cap of `mesh` with every vertex index replaced by `rep[v]` (the welded mesh); empty for a closed
    /// one (every welded edge's uses cancel).
    pub fn of_welded(mesh: &TriMesh, rep: &[u32]) -> Result<Cap> {
        let mut edges = boundary_chain(mesh, rep);
        let mut cap = Cap {
            boundary_edges: edges.len(),
            ..Cap::default()
        };
        if edges.is_empty() {
            return Ok(cap);
        }
        // Deterministic walk: outgoing edges per vertex (contiguous in the sorted list), taken from the back.
        edges.sort_unstable();
        let n = mesh.positions.len();
        let mut offset = vec![0u32; n + 1];
        for &(a, _) in &edges {
            offset[a as usize + 1] += 1;
        }
        for v in 0..n {
            offset[v + 1] += offset[v];
        }
        let mut left: Vec<u32> = (0..n).map(|v| offset[v + 1] - offset[v]).collect();
        let pop = |v: u32, left: &mut Vec<u32>| -> Option<u32> {
            let l = &mut left[v as usize];
            (*l > 0).then(|| {
                *l -= 1;
                edges[(offset[v as usize] + *l) as usize].1
            })
        };
        let base = n as u32;
        const OFF: u32 = u32::MAX;
        let mut on_path = vec![OFF; n];
        for s in 0..n as u32 {
            while left[s as usize] > 0 {
                let mut path = vec![s];
                on_path[s as usize] = 0;
                loop {
                    let cur = *path.last().expect("path starts non-empty");
                    let Some(next) = pop(cur, &mut left) else {
                        if path.len() == 1 {
                            break;
                        }
                        // ∂∂ = 0 guarantees an unused outgoing edge at every inner vertex of the path.
                        return Err(Error::Mesh(format!(
                            "internal error: the boundary chain ends at vertex {}",
                            cur + 1
                        )));
                    };
                    let i = on_path[next as usize];
                    if i != OFF {
                        let i = i as usize;
                        cap.push_loop(mesh, &path[i..], base);
                        for v in &path[i + 1..] {
                            on_path[*v as usize] = OFF;
                        }
                        path.truncate(i + 1);
                        if path.len() == 1 && left[s as usize] == 0 {
                            break;
                        }
                    } else {
                        on_path[next as usize] = path.len() as u32;
                        path.push(next);
                    }
                }
                on_path[s as usize] = OFF;
            }
        }
        Ok(cap)
    }

    /// Caps the loop `verts` (edges v_i → v_{i+1}, closing back to v_0): a loop of three by the reversed
    /// triangle, a loop of up to [`CHUNK`] edges by a fan of (v_{i+1}, v_i, apex) from its centroid, a longer
    /// one hierarchically (see [`Cap::cap_vertices`]).
    fn push_loop(&mut self, mesh: &TriMesh, verts: &[u32], base: u32) {
        let first = self.triangles.len() as u32;
        let rim_first = self.rim.len() as u32;
        for i in 0..verts.len() {
            self.rim.push([verts[i], verts[(i + 1) % verts.len()]]);
        }
        self.cap_vertices(mesh, verts, base);
        self.loops.push(CapLoop {
            first,
            count: self.triangles.len() as u32 - first,
            edges: verts.len() as u32,
            rim_first,
        });
    }

    /// Triangles whose boundary is the reverse of the loop `verts`. Up to [`CHUNK`] edges: a fan (or the
    /// reversed triangle). Longer: each run of [`CHUNK`] edges is closed by its chord and fanned from its own
    /// centroid, and the polygon of the runs' ends is capped the same way; the chords cancel, so the boundary
    /// is still the loop's reverse, while every triangle stays as small as its run. A million-gon's cap is
    /// then a hierarchy a tree can bound (one fan from the centroid would be a million slivers meeting at one
    /// point, near all of which every query would have to go).
    fn cap_vertices(&mut self, mesh: &TriMesh, verts: &[u32], base: u32) {
        let n = verts.len();
        if n == 3 {
            self.triangles.push([verts[0], verts[2], verts[1]]);
            return;
        }
        if n <= CHUNK {
            self.fan(mesh, verts, base);
            return;
        }
        let mut ends = Vec::with_capacity(n.div_ceil(CHUNK));
        let mut start = 0;
        while start < n {
            let end = (start + CHUNK).min(n);
            // The run v_start … v_end (v_n = v_0), closed by its chord.
            let mut run: Vec<u32> = verts[start..end].to_vec();
            run.push(verts[end % n]);
            self.fan(mesh, &run, base);
            ends.push(verts[start]);
            start = end;
        }
        if ends.len() >= 3 {
            self.cap_vertices(mesh, &ends, base);
        } else if ends.len() == 2 {
            // Two runs: their chords are the same segment both ways and cancel.
        }
    }

    /// A fan of (v_{i+1}, v_i, apex) from the centroid of `verts` (rounded to f32).
    fn fan(&mut self, mesh: &TriMesh, verts: &[u32], base: u32) {
        let mut c = [0.0f64; 3];
        for &v in verts {
            let p = self.position(mesh, v);
            for (a, ca) in c.iter_mut().enumerate() {
                *ca += p[a] as f64;
            }
        }
        let apex = c.map(|x| (x / verts.len() as f64) as f32);
        let apex_index = base + self.apexes.len() as u32;
        self.apexes.push(apex);
        for i in 0..verts.len() {
            let (a, b) = (verts[i], verts[(i + 1) % verts.len()]);
            self.triangles.push([b, a, apex_index]);
        }
    }

    /// The position of index `v` of the capped mesh (the mesh's, then the apexes).
    pub fn position(&self, mesh: &TriMesh, v: u32) -> [f32; 3] {
        let n = mesh.positions.len();
        if (v as usize) < n {
            mesh.positions[v as usize]
        } else {
            self.apexes[v as usize - n]
        }
    }
}

/// The weld, the cap and the ribbons of a mesh (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct Proxy {
    /// The representative of each vertex (itself when it did not move; unused vertices map to themselves).
    pub rep: Vec<u32>,
    /// Vertices moved onto another at a different position (exact duplicates not counted).
    pub moved: usize,
    /// The largest distance a vertex moved.
    pub max_shift: f64,
    /// The weld tolerance used.
    pub tolerance: f64,
    /// The cap of the welded mesh M'.
    pub cap: Cap,
    /// Ribbon triangles, already reversed (their solid angle enters X with this orientation), indexing the
    /// mesh's positions.
    pub ribbons: Vec<[u32; 3]>,
}

impl Proxy {
    /// Welds `mesh` within `tolerance`, caps the welded mesh and builds the ribbons.
    pub fn new(mesh: &TriMesh, tolerance: f64) -> Result<Proxy> {
        let (rep, moved, max_shift) = weld(mesh, tolerance);
        let cap = Cap::of_welded(mesh, &rep)?;
        let pos = |v: u32| mesh.positions[v as usize];
        let distinct = |t: [u32; 3]| {
            let [a, b, c] = t.map(|v| pos(v).map(|x| (x + 0.0).to_bits()));
            a != b && b != c && c != a
        };
        let ribbons: Vec<[u32; 3]> = if moved == 0 {
            Vec::new()
        } else {
            mesh.triangles
                .par_iter()
                .flat_map_iter(|t| {
                    let mut out = Vec::new();
                    for k in 0..3 {
                        let (u, v) = (t[k], t[(k + 1) % 3]);
                        let (u2, v2) = (rep[u as usize], rep[v as usize]);
                        // Q = (u, v, v', u') as (u, v, v') + (u, v', u'), reversed.
                        for tri in [[u, v2, v], [u, u2, v2]] {
                            if distinct(tri) {
                                out.push(tri);
                            }
                        }
                    }
                    out
                })
                .collect()
        };
        Ok(Proxy {
            rep,
            moved,
            max_shift,
            tolerance,
            cap,
            ribbons,
        })
    }

    /// Whether the mesh is closed once welded and nothing moved: no fractional term at all.
    pub fn is_trivial(&self) -> bool {
        self.cap.triangles.is_empty() && self.ribbons.is_empty()
    }

    /// M' ∪ C': the mesh's positions then the apexes; the welded triangles (those still with three distinct
    /// vertices) then the cap's. What the solid pass rasterizes.
    pub fn closed(&self, mesh: &TriMesh) -> TriMesh {
        let mut positions = mesh.positions.clone();
        positions.extend_from_slice(&self.cap.apexes);
        let mut triangles: Vec<[u32; 3]> = mesh
            .triangles
            .iter()
            .map(|t| t.map(|v| self.rep[v as usize]))
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
            .collect();
        triangles.extend_from_slice(&self.cap.triangles);
        TriMesh {
            positions,
            triangles,
        }
    }

    /// X = C' ∪ (−Q) in local f64 coordinates (`origin` subtracted): the fractional term's triangles.
    pub fn fractional(&self, mesh: &TriMesh, origin: [f64; 3]) -> Vec<[[f64; 3]; 3]> {
        let local = |p: [f32; 3]| -> [f64; 3] { std::array::from_fn(|a| p[a] as f64 - origin[a]) };
        let mut out: Vec<[[f64; 3]; 3]> = self
            .cap
            .triangles
            .iter()
            .map(|t| t.map(|v| local(self.cap.position(mesh, v))))
            .collect();
        out.par_extend(
            self.ribbons
                .par_iter()
                .map(|t| t.map(|v| local(mesh.positions[v as usize]))),
        );
        out
    }
}

/// The weld: (representative per vertex, vertices moved to another position, largest move).
///
/// First exact duplicates (position bits, −0 = +0) become one vertex. Then only *seams* are closed: a
/// boundary edge a → b of that mesh whose reverse twin d → c lies within `tolerance` at both ends
/// (|a − c| ≤ τ, |b − d| ≤ τ) has its ends joined (a with c, b with d). Legitimately dense geometry — a
/// million-gon's rim, fine tessellation — has no reversed twins and is left alone. A joined vertex moves onto
/// the lowest-numbered vertex of its group, and only if that lies within 2τ (else it stays where it is).
fn weld(mesh: &TriMesh, tolerance: f64) -> (Vec<u32>, usize, f64) {
    let n = mesh.positions.len();
    let mut used = vec![false; n];
    for t in &mesh.triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let key = |v: u32| mesh.positions[v as usize].map(|x| (x + 0.0).to_bits());
    let mut order: Vec<u32> = (0..n as u32).filter(|&v| used[v as usize]).collect();
    order.par_sort_unstable_by_key(|&v| (key(v), v));
    let mut rep: Vec<u32> = (0..n as u32).collect();
    let mut run = 0;
    for (i, &v) in order.iter().enumerate() {
        if i == 0 || key(v) != key(order[i - 1]) {
            run = v;
        }
        rep[v as usize] = run;
    }
    if tolerance <= 0.0 {
        return (rep, 0, 0.0);
    }
    // Boundary edges of the exactly welded mesh, each directed as its net uses say.
    let boundary = boundary_chain(mesh, &rep);
    if boundary.is_empty() {
        return (rep, 0, 0.0);
    }
    let p = |v: u32| mesh.positions[v as usize].map(|x| x as f64);
    let near = |a: u32, b: u32| {
        let (x, y) = (p(a), p(b));
        (x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2) + (x[2] - y[2]).powi(2)
            <= tolerance * tolerance
    };
    // Edges bucketed by the cell (edge 16τ) of their midpoint: twins' midpoints lie within τ of each other, so
    // a twin is in the same cell or across a face the midpoint lies within τ (a sixteenth of a cell) of.
    let size = 16.0 * tolerance;
    let midpoint = |e: &(u32, u32)| -> [f64; 3] {
        let (a, b) = (p(e.0), p(e.1));
        std::array::from_fn(|k| (a[k] + b[k]) * 0.5 / size)
    };
    let mut keyed: Vec<([i64; 3], u32)> = boundary
        .par_iter()
        .enumerate()
        .map(|(i, e)| (midpoint(e).map(|x| x.floor() as i64), i as u32))
        .collect();
    keyed.par_sort_unstable();
    // The cells' runs in `keyed`: an edge's own cell is its run, a neighbour cell a binary search of the runs.
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (at, k) in keyed.iter().enumerate() {
        if at == 0 || k.0 != keyed[at - 1].0 {
            runs.push((at, at + 1));
        } else if let Some(run) = runs.last_mut() {
            run.1 = at + 1;
        }
    }
    let run_at = |key: [i64; 3]| -> &[([i64; 3], u32)] {
        let r = runs.partition_point(|&(start, _)| keyed[start].0 < key);
        match runs.get(r) {
            Some(&(start, end)) if keyed[start].0 == key => &keyed[start..end],
            _ => &[],
        }
    };
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            let up = parent[parent[v as usize] as usize];
            parent[v as usize] = up;
            v = up;
        }
        v
    }
    let union = |parent: &mut Vec<u32>, a: u32, b: u32| {
        let (ra, rb) = (find(parent, a), find(parent, b));
        if ra != rb {
            let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
            parent[hi as usize] = lo;
        }
    };
    // The twins, found in parallel in the cells' order (neighbouring searches share cache lines; a list per
    // chunk of runs rather than per edge), then joined.
    let twins: Vec<Vec<(u32, u32)>> = runs
        .par_chunks(1024)
        .map(|chunk| {
            let mut found = Vec::new();
            for &(start, end) in chunk {
                let own = &keyed[start..end];
                for &(c, i) in own {
                    let e = boundary[i as usize];
                    let m = midpoint(&e);
                    // Per axis: this cell, and the neighbour across a face within τ.
                    let reach = |k: usize| -> [i64; 2] {
                        let f = m[k] - c[k] as f64;
                        if f < 1.0 / 16.0 {
                            [0, -1]
                        } else if f > 15.0 / 16.0 {
                            [0, 1]
                        } else {
                            [0, 0]
                        }
                    };
                    let (rx, ry, rz) = (reach(0), reach(1), reach(2));
                    let mut seen: [[i64; 3]; 8] = [[i64::MIN; 3]; 8];
                    let mut count = 0;
                    for dz in rz {
                        for dy in ry {
                            for dx in rx {
                                let key = [c[0] + dx, c[1] + dy, c[2] + dz];
                                if seen[..count].contains(&key) {
                                    continue;
                                }
                                seen[count] = key;
                                count += 1;
                                let run = if key == c { own } else { run_at(key) };
                                for &(_, j) in run {
                                    let f = boundary[j as usize];
                                    if j != i && near(e.0, f.1) && near(e.1, f.0) {
                                        found.push((e.0, f.1));
                                        found.push((e.1, f.0));
                                    }
                                }
                            }
                        }
                    }
                }
            }
            found
        })
        .collect();
    for (a, b) in twins.into_iter().flatten() {
        union(&mut parent, a, b);
    }
    let (mut moved, mut max_shift) = (0usize, 0.0f64);
    for v in 0..n as u32 {
        let r = rep[v as usize];
        let root = find(&mut parent, r);
        if root == r {
            continue;
        }
        let d = {
            let (x, y) = (p(v), p(root));
            ((x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2) + (x[2] - y[2]).powi(2)).sqrt()
        };
        if d <= 2.0 * tolerance {
            rep[v as usize] = root;
            if d > 0.0 {
                moved += 1;
                max_shift = max_shift.max(d);
            }
        }
    }
    (rep, moved, max_shift)
}

/// The boundary chain of `mesh` with vertices replaced by `rep`: each undirected edge whose oriented uses do
/// not cancel, directed as the net uses, repeated by their count.
fn boundary_chain(mesh: &TriMesh, rep: &[u32]) -> Vec<(u32, u32)> {
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
    edges
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voxel::gwn::kernel::{winding_number, winding_sum, FOUR_PI};

    fn soup_of(mesh: &TriMesh, noise: f32) -> TriMesh {
        let mut soup = TriMesh::default();
        let mut s = 1u64;
        for t in &mesh.triangles {
            let n = soup.positions.len() as u32;
            for &v in t {
                let p = mesh.positions[v as usize];
                soup.positions.push(p.map(|x| {
                    s = s
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    x + noise * (((s >> 33) as f32 / (1u64 << 31) as f32) - 0.5)
                }));
            }
            soup.triangles.push([n, n + 1, n + 2]);
        }
        soup
    }

    #[test]
    fn a_closed_cube_needs_no_proxy_and_an_open_one_is_capped() {
        let cube = TriMesh::cube([0.0; 3], 1.0);
        assert!(Proxy::new(&cube, 0.0).unwrap().is_trivial());
        let mut open = cube.clone();
        open.triangles.truncate(10); // one face removed
        let p = Proxy::new(&open, 0.0).unwrap();
        assert_eq!((p.cap.loops.len(), p.cap.boundary_edges), (1, 4));
        assert!(p.ribbons.is_empty());
        assert!(Proxy::new(&p.closed(&open), 0.0).unwrap().is_trivial());
    }

    #[test]
    fn soups_weld_and_inconsistent_orientation_counts_twice() {
        let cube = TriMesh::cube([0.0; 3], 1.0);
        let soup = soup_of(&cube, 0.0);
        let p = Proxy::new(&soup, 0.0).unwrap();
        assert!(p.is_trivial() && p.moved == 0);
        // Flip one face: its four outer edges are used twice the same way, the diagonal cancels.
        let mut flipped = cube.clone();
        for t in &mut flipped.triangles[..2] {
            t.swap(1, 2);
        }
        let p = Proxy::new(&flipped, 0.0).unwrap();
        assert_eq!(p.cap.boundary_edges, 8);
        assert!(Proxy::new(&p.closed(&flipped), 0.0).unwrap().is_trivial());
    }

    #[test]
    fn a_noisy_soup_welds_within_the_tolerance_and_the_identity_holds() {
        // A sphere as a soup with 1e-4 noise: welded at 1e-3 it is closed; w_M = n − w_X off the surface.
        let sphere = TriMesh::sphere([0.0; 3], 1.0, 8, 12, false);
        let soup = soup_of(&sphere, 1e-4);
        let p = Proxy::new(&soup, 1e-3).unwrap();
        assert!(
            p.cap.triangles.is_empty(),
            "{} cap triangles",
            p.cap.triangles.len()
        );
        assert!(p.moved > 0 && p.max_shift <= 1e-3 && !p.ribbons.is_empty());
        let x = p.fractional(&soup, [0.0; 3]);
        for (q, n) in [
            ([0.1, 0.2, 0.3], 1.0),
            ([1.5, 0.0, 0.2], 0.0),
            ([0.0, 0.0, 0.9], 1.0),
        ] {
            let w_m = winding_number(&soup, q);
            let w_x = winding_sum(&x, q);
            assert!(
                (w_m - (n - w_x)).abs() < 1e-9,
                "{q:?}: {w_m} vs {n} − {w_x}"
            );
            assert!(w_x.abs() < 1e-2 && (w_m - n).abs() < 1e-2);
            let closed = p.closed(&soup);
            assert!((winding_number(&closed, q) - n).abs() < 1e-9);
        }
        let _ = FOUR_PI;
    }

    #[test]
    fn an_open_noisy_soup_gets_a_cap_and_ribbons_and_the_identity_holds() {
        let mut sphere = TriMesh::sphere([0.0; 3], 1.0, 8, 12, false);
        sphere.triangles.retain(|t| t.iter().all(|&v| v != 0)); // a hole at the south pole
        let soup = soup_of(&sphere, 1e-4);
        let p = Proxy::new(&soup, 1e-3).unwrap();
        assert_eq!(p.cap.loops.len(), 1);
        let closed = p.closed(&soup);
        let x = p.fractional(&soup, [0.0; 3]);
        for q in [
            [0.1, 0.2, 0.3],
            [0.0, 0.0, -0.95],
            [0.0, 0.1, -1.05],
            [2.0, 0.0, 0.0],
        ] {
            let n = winding_number(&closed, q);
            assert!((n - n.round()).abs() < 1e-9, "{q:?}: n = {n}");
            let (w_m, w_x) = (winding_number(&soup, q), winding_sum(&x, q));
            assert!((w_m - (n.round() - w_x)).abs() < 1e-9, "{q:?}");
        }
    }
}
