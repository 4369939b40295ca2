//! Topology queries derived from E and M: boundary, closedness, manifoldness, orientation, valence and
//! one-rings, S_v = BBᵀ, S_f = BᵀB, dual adjacency, components, Euler characteristic, genus, edge
//! collapse, and the report printed by `gregvox mesh`.
//!
//! Conventions: an undirected edge's "face count" is the number of half-edges (E entries, both
//! directions) on it: 1 = boundary, 2 = interior, > 2 = non-manifold. Two half-edges of an interior edge
//! pointing the same way = inconsistent orientation. Unreferenced vertices (no corner) take part in no
//! component, no valence and no Euler characteristic; they are counted separately. Every list is produced
//! in increasing vertex / face / E-entry order, so results are deterministic.
use super::matrix::{MeshMatrix, NONE};
use super::sparse::SparseMatrix;
use crate::error::{Error, Result};
use serde::Serialize;
use std::collections::BTreeMap;

/// Union-find with path halving; labels are handed out in order of first appearance.
pub(crate) struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    pub(crate) fn new(n: usize) -> Self {
        UnionFind {
            parent: (0..n as u32).collect(),
        }
    }
    pub(crate) fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let g = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = g;
            x = g;
        }
        x
    }
    pub(crate) fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            // The smaller root wins: the result does not depend on the union order's details.
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            self.parent[hi as usize] = lo;
        }
    }
}

/// Per undirected edge: how many faces use it, and whether two of them run the same way.
///
/// ```
/// # use gregvox::mesh::MeshMatrix;
/// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
/// assert!(m.edge_uses().iter().all(|u| u.forward == 1 && u.backward == 0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EdgeUse {
    /// Half-edges tail → head in the direction of the edge's representative.
    pub forward: u32,
    /// Half-edges in the opposite direction.
    pub backward: u32,
}

impl EdgeUse {
    /// Number of faces on the edge.
    ///
    /// ```
    /// assert_eq!(gregvox::mesh::EdgeUse { forward: 1, backward: 1 }.faces(), 2);
    /// ```
    pub fn faces(&self) -> u32 {
        self.forward + self.backward
    }
}

/// Everything `gregvox mesh --json` prints (the first ten keys are the issue's contract).
///
/// ```
/// # use gregvox::mesh::MeshMatrix;
/// let r = MeshMatrix::new(4, &[0, 3], vec![0, 1, 2]).unwrap().report();
/// assert_eq!((r.unreferenced_vertices, r.boundary_edges, r.closed), (1, 3, false));
/// let json = serde_json::to_value(&r).unwrap();
/// assert_eq!(json["valence_histogram"]["2"], 3);
/// ```
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TopologyReport {
    /// All vertices in the file, referenced or not.
    pub vertices: usize,
    /// Faces.
    pub faces: usize,
    /// Unique undirected edges.
    pub edges: usize,
    /// Edges used by exactly one face.
    pub boundary_edges: usize,
    /// Edges used by more than two faces.
    pub non_manifold_edges: usize,
    /// Edges used by two faces in the same direction.
    pub inconsistent_edges: usize,
    /// No boundary edge and no non-manifold edge.
    pub closed: bool,
    /// Connected components through shared vertices, counting only referenced vertices.
    pub components: usize,
    /// Referenced vertices − edges + faces.
    pub euler_characteristic: i64,
    /// Distinct neighbours per referenced vertex → number of such vertices (keys are decimal strings).
    pub valence_histogram: BTreeMap<String, usize>,
    /// Vertices used by at least one face.
    pub referenced_vertices: usize,
    /// Vertices used by no face (kept, zero normal).
    pub unreferenced_vertices: usize,
    /// Components through shared edges.
    pub face_components: usize,
    /// Number of boundary loops.
    pub boundary_loops: usize,
    /// Vertex counts of the boundary loops, ascending.
    pub boundary_loop_sizes: Vec<usize>,
    /// Referenced vertices whose faces form more than one fan (pinched).
    pub non_manifold_vertices: usize,
    /// E entries that repeat an earlier (row, column) pair: a non-manifold edge or inconsistent orientation.
    pub second_writes: usize,
    /// Every interior edge has opposite half-edges and no edge is non-manifold.
    pub consistently_oriented: bool,
    /// Genus from χ = 2c − 2g − b, given when the mesh is a manifold, consistently oriented surface.
    pub genus: Option<i64>,
    /// Faces by number of corners (keys are decimal strings).
    pub face_order_histogram: BTreeMap<String, usize>,
}

impl MeshMatrix {
    /// Face usage of every undirected edge, indexed by edge id.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// let uses = m.edge_uses();
    /// assert_eq!(uses.iter().filter(|u| u.faces() == 2).count(), 1);
    /// ```
    pub fn edge_uses(&self) -> Vec<EdgeUse> {
        let mut uses = vec![EdgeUse::default(); self.n_edges()];
        let reps = self.edge_reps();
        let col = &self.half_edge_face().col;
        for (k, &e) in self.half_edge_edge().iter().enumerate() {
            let rep = reps[e as usize] as usize;
            if col[k] == col[rep] {
                uses[e as usize].forward += 1;
            } else {
                uses[e as usize].backward += 1;
            }
        }
        uses
    }

    /// E entries of the boundary half-edges (`E[i,j] ≠ 0`, `E[j,i] = 0`), in E order.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
    /// assert_eq!(m.boundary_half_edges().len(), 3);
    /// ```
    pub fn boundary_half_edges(&self) -> Vec<u32> {
        (0..self.n_corners() as u32)
            .filter(|&k| self.twins()[k as usize] == NONE)
            .collect()
    }

    /// Boundary loops as vertex lists, each following its half-edges (face on the left). From each
    /// boundary half-edge i → j the loop goes on along the next boundary half-edge of the same wedge at j
    /// (turning round j through the faces across j's interior edges), so loops that touch at a pinched
    /// vertex are walked as separate loops rather than as one figure eight. Where that turn cannot be
    /// made (a non-manifold edge in the way), the first unused boundary half-edge out of j in E order is
    /// taken.
    ///
    /// Cost: O(corners). Each boundary half-edge's turn walks the faces of one wedge, and each wedge is
    /// entered by one boundary half-edge, so a 100,000-gon's fan vertex (one wedge of 99,998 faces) is
    /// walked once; the fallback scans one row of E. The attacks, a star of triangles touching only at
    /// their apex and a fan-triangulated 100,000-gon, are in `tests/mesh_topology.rs`.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// assert_eq!(m.boundary_loops(), vec![vec![0, 1, 3, 2]]);
    /// // Two triangles touching at vertex 0 only: two loops through it, not one of six edges.
    /// let bowtie = MeshMatrix::new(5, &[0, 3, 6], vec![0, 1, 2, 0, 3, 4]).unwrap();
    /// assert_eq!(bowtie.boundary_loops().len(), 2);
    /// ```
    pub fn boundary_loops(&self) -> Vec<Vec<u32>> {
        let twins = self.twins();
        let col = &self.half_edge_face().col;
        let vc = self.vertex_corners();
        let ptr = &vc.ptr;
        let mut entry_of_corner = vec![NONE; self.n_corners()];
        for (k, &c) in vc.corner.iter().enumerate() {
            entry_of_corner[c as usize] = k as u32;
        }
        // The boundary half-edge that follows entry `k` (i → j) in its wedge at j, if the turn round j
        // reaches one: from the face of `k`, the half-edge out of j, then across each interior edge to
        // the next face's half-edge out of j. At most the valence of j turns (a non-manifold edge's twin
        // pairing could cycle).
        let turn = |k: usize| -> Option<usize> {
            let j = col[k] as usize;
            let mut h = entry_of_corner[self.next(vc.corner[k]) as usize] as usize;
            for _ in 0..=(ptr[j + 1] - ptr[j]) {
                let t = twins[h];
                if t == NONE {
                    return Some(h);
                }
                h = entry_of_corner[self.next(vc.corner[t as usize]) as usize] as usize;
            }
            None
        };
        let mut used = vec![false; self.n_corners()];
        let mut loops = Vec::new();
        for start in 0..self.n_corners() {
            if twins[start] != NONE || used[start] {
                continue;
            }
            let mut lp = Vec::new();
            let mut k = start;
            loop {
                used[k] = true;
                lp.push(self.entry_row(k as u32));
                let j = col[k] as usize;
                // A used half-edge next in the wedge closes the loop (it is where the loop began).
                let next = match turn(k) {
                    Some(h) => (!used[h]).then_some(h),
                    None => (ptr[j]..ptr[j + 1])
                        .map(|x| x as usize)
                        .find(|&x| twins[x] == NONE && !used[x]),
                };
                match next {
                    Some(n) => k = n,
                    None => break,
                }
            }
            loops.push(lp);
        }
        loops
    }

    /// No boundary edge and no non-manifold edge (pattern of E symmetric, every edge used twice).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// // a tetrahedron
    /// let t = MeshMatrix::new(4, &[0, 3, 6, 9, 12], vec![0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2]).unwrap();
    /// assert!(t.is_closed());
    /// ```
    pub fn is_closed(&self) -> bool {
        self.edge_uses().iter().all(|u| u.faces() == 2)
    }

    /// E entries that repeat an earlier column in their row (the "second writes" of the seed).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// // two triangles with the same winding on edge 0→1
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 0, 1, 3]).unwrap();
    /// assert_eq!(m.second_writes(), 1);
    /// ```
    pub fn second_writes(&self) -> usize {
        let ptr = &self.vertex_corners().ptr;
        let col = &self.half_edge_face().col;
        let mut n = 0;
        for i in 0..self.n_verts() {
            let row = &col[ptr[i] as usize..ptr[i + 1] as usize];
            for (a, c) in row.iter().enumerate() {
                if row[..a].contains(c) {
                    n += 1;
                }
            }
        }
        n
    }

    /// Number of fans (groups of faces connected through edges at the vertex) around vertex `v`;
    /// 0 for an unreferenced vertex, > 1 for a pinched vertex.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// // two triangles touching only at vertex 0
    /// let m = MeshMatrix::new(5, &[0, 3, 6], vec![0, 1, 2, 0, 3, 4]).unwrap();
    /// assert_eq!(m.fans(0), 2);
    /// assert_eq!(m.fans(1), 1);
    /// ```
    pub fn fans(&self, v: usize) -> usize {
        let vc = self.vertex_corners();
        let corners = &vc.corner[vc.ptr[v] as usize..vc.ptr[v + 1] as usize];
        let cv = self.corner_vertex();
        let nb: Vec<[u32; 2]> = corners
            .iter()
            .map(|&c| [cv[self.next(c) as usize], cv[self.prev(c) as usize]])
            .collect();
        // Two corners are in one fan when they share a neighbour vertex: union each corner with the first
        // corner seen at each of its two neighbours. Linear in the valence (a pairwise test was quadratic:
        // 48 s for the 100,001-valence apex of a fan-triangulated 100,000-gon).
        let mut uf = UnionFind::new(corners.len());
        let mut first_at: std::collections::HashMap<u32, u32> =
            std::collections::HashMap::with_capacity(2 * nb.len());
        for (a, pair) in nb.iter().enumerate() {
            for &x in pair {
                match first_at.entry(x) {
                    std::collections::hash_map::Entry::Occupied(e) => uf.union(a as u32, *e.get()),
                    std::collections::hash_map::Entry::Vacant(e) => {
                        e.insert(a as u32);
                    }
                }
            }
        }
        (0..nb.len() as u32).filter(|&a| uf.find(a) == a).count()
    }

    /// Referenced vertices whose incident faces form more than one fan (pinched / non-manifold vertices).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(5, &[0, 3, 6], vec![0, 1, 2, 0, 3, 4]).unwrap();
    /// assert_eq!(m.non_manifold_vertices(), vec![0]);
    /// ```
    pub fn non_manifold_vertices(&self) -> Vec<u32> {
        (0..self.n_verts())
            .filter(|&v| self.fans(v) > 1)
            .map(|v| v as u32)
            .collect()
    }

    /// Distinct neighbours of `v` through edges (pattern of E + Eᵀ), ascending.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap();
    /// assert_eq!(m.neighbours(0), vec![1, 3]); // not the diagonal 2
    /// ```
    pub fn neighbours(&self, v: usize) -> Vec<u32> {
        let mut out = Vec::new();
        self.neighbours_into(v, &mut out);
        out
    }

    /// [`MeshMatrix::neighbours`] into a reused buffer (cleared first).
    pub(crate) fn neighbours_into(&self, v: usize, out: &mut Vec<u32>) {
        let vc = self.vertex_corners();
        let cv = self.corner_vertex();
        out.clear();
        for k in vc.ptr[v]..vc.ptr[v + 1] {
            let c = vc.corner[k as usize];
            out.push(cv[self.next(c) as usize]);
            out.push(cv[self.prev(c) as usize]);
        }
        out.sort_unstable();
        out.dedup();
    }

    /// Valence (number of distinct edge neighbours) of `v`.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// assert_eq!(m.valence(1), 3);
    /// ```
    pub fn valence(&self, v: usize) -> usize {
        self.neighbours(v).len()
    }

    /// The ordered (counter-clockwise) one-ring of `v`: walk E from a neighbour `j`, to the vertex before
    /// `v` in face E[v, j], and on. A boundary vertex starts at the neighbour whose half-edge into `v` is
    /// missing, so the whole fan is listed. A pinched vertex yields the fan of its first boundary/corner only.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// // a fan of 4 triangles around vertex 0, CCW
    /// let m = MeshMatrix::new(5, &[0, 3, 6, 9, 12], vec![0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 1]).unwrap();
    /// assert_eq!(m.one_ring(0), vec![1, 2, 3, 4]);
    /// let open = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 0, 2, 3]).unwrap();
    /// assert_eq!(open.one_ring(0), vec![1, 2, 3]);
    /// ```
    pub fn one_ring(&self, v: usize) -> Vec<u32> {
        let vc = self.vertex_corners();
        let (a, b) = (vc.ptr[v], vc.ptr[v + 1]);
        if a == b {
            return Vec::new();
        }
        let twins = self.twins();
        let col = &self.half_edge_face().col;
        let start = (a..b).find(|&k| twins[k as usize] == NONE).unwrap_or(a);
        let cv = self.corner_vertex();
        let mut ring = vec![col[start as usize]];
        let mut visited = vec![start];
        let mut k = start;
        loop {
            let c = vc.corner[k as usize];
            let nxt = cv[self.prev(c) as usize];
            let kk = self.find(v as u32, nxt);
            if kk == start {
                break;
            }
            ring.push(nxt);
            // A missing half-edge ends an open fan; a revisit (possible only around non-manifold or
            // inconsistently oriented edges) ends the walk too, so it always terminates.
            if kk == NONE || visited.contains(&kk) {
                break;
            }
            visited.push(kk);
            k = kk;
        }
        ring
    }

    /// The vertex adjacency pattern(E + Eᵀ), |V|×|V|, values 1, sorted columns.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
    /// assert_eq!(m.vertex_adjacency().nnz(), 6);
    /// ```
    pub fn vertex_adjacency(&self) -> SparseMatrix<u32> {
        let mut row_ptr = vec![0u32];
        let mut col = Vec::new();
        for v in 0..self.n_verts() {
            col.extend(self.neighbours(v));
            row_ptr.push(col.len() as u32);
        }
        let val = vec![1u32; col.len()];
        SparseMatrix {
            n_rows: self.n_verts() as u32,
            n_cols: self.n_verts() as u32,
            row_ptr,
            col,
            val,
        }
    }

    /// S_v = B·Bᵀ: diagonal = faces per vertex, off-diagonal = faces containing both vertices (for
    /// polygons this also counts diagonal pairs).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// let s = m.s_v();
    /// assert_eq!((s.get(1, 1), s.get(1, 2), s.get(0, 1)), (Some(2), Some(2), Some(1)));
    /// ```
    pub fn s_v(&self) -> SparseMatrix<u32> {
        let vc = self.vertex_corners();
        let cf = self.corner_face();
        self.count_product(self.n_verts(), self.n_verts(), |v, out| {
            for k in vc.ptr[v]..vc.ptr[v + 1] {
                let f = cf[vc.corner[k as usize] as usize] as usize;
                out.extend_from_slice(self.face(f));
            }
        })
    }

    /// S_f = Bᵀ·B: diagonal = face order, off-diagonal = shared vertices.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// let s = m.s_f();
    /// assert_eq!((s.get(0, 0), s.get(0, 1)), (Some(3), Some(2)));
    /// ```
    pub fn s_f(&self) -> SparseMatrix<u32> {
        let vc = self.vertex_corners();
        let cf = self.corner_face();
        self.count_product(self.n_faces(), self.n_faces(), |f, out| {
            for &v in self.face(f) {
                for k in vc.ptr[v as usize]..vc.ptr[v as usize + 1] {
                    out.push(cf[vc.corner[k as usize] as usize]);
                }
            }
        })
    }

    /// Rows of counts: row `r` counts how often each column appears in `gather(r)`.
    fn count_product(
        &self,
        n_rows: usize,
        n_cols: usize,
        gather: impl Fn(usize, &mut Vec<u32>),
    ) -> SparseMatrix<u32> {
        let mut row_ptr = vec![0u32];
        let mut col = Vec::new();
        let mut val = Vec::new();
        let mut buf = Vec::new();
        for r in 0..n_rows {
            buf.clear();
            gather(r, &mut buf);
            buf.sort_unstable();
            for &c in &buf {
                if col.len() > *row_ptr.last().unwrap() as usize && *col.last().unwrap() == c {
                    *val.last_mut().unwrap() += 1;
                } else {
                    col.push(c);
                    val.push(1u32);
                }
            }
            row_ptr.push(col.len() as u32);
        }
        SparseMatrix {
            n_rows: n_rows as u32,
            n_cols: n_cols as u32,
            row_ptr,
            col,
            val,
        }
    }

    /// The dual adjacency A_d from E: faces `f ≠ g` are adjacent iff they share an undirected edge (so
    /// quads sharing only a diagonal pair are not adjacent; all faces of a non-manifold edge are).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// let a = m.dual_adjacency();
    /// assert_eq!(a.row(0).0, &[1]);
    /// ```
    pub fn dual_adjacency(&self) -> SparseMatrix<u32> {
        let edges = self.edge_faces();
        let mut row_ptr = vec![0u32];
        let mut col = Vec::new();
        let mut buf = Vec::new();
        let entry = self.corner_entries();
        let he_edge = self.half_edge_edge();
        for f in 0..self.n_faces() {
            buf.clear();
            let a = self.face_start(f);
            for c in a..a + self.face_len(f) {
                let e = he_edge[entry[c as usize] as usize] as usize;
                buf.extend(edges.row(e).0.iter().filter(|&&g| g as usize != f));
            }
            buf.sort_unstable();
            buf.dedup();
            col.extend_from_slice(&buf);
            row_ptr.push(col.len() as u32);
        }
        let val = vec![1u32; col.len()];
        SparseMatrix {
            n_rows: self.n_faces() as u32,
            n_cols: self.n_faces() as u32,
            row_ptr,
            col,
            val,
        }
    }

    /// Edge → faces (|E|×|F|, value = number of half-edges of that face on the edge, always 1 for valid
    /// faces), sorted columns.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// assert_eq!(m.edge_faces().row_ptr.last(), Some(&6));
    /// ```
    pub fn edge_faces(&self) -> SparseMatrix<u32> {
        let he_edge = self.half_edge_edge();
        let face1 = &self.half_edge_face().face1;
        let trip: Vec<(u32, u32, u32)> = (0..self.n_corners())
            .map(|k| (he_edge[k], face1[k] - 1, 1u32))
            .collect();
        SparseMatrix::from_triplets(
            self.n_edges() as u32,
            self.n_faces() as u32,
            &trip,
            |a, b| a + b,
        )
    }

    /// Corner → E entry (the inverse of `vertex_corners().corner`).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
    /// let inv = m.corner_entries();
    /// assert!((0..3).all(|c| m.vertex_corners().corner[inv[c] as usize] == c as u32));
    /// ```
    pub fn corner_entries(&self) -> Vec<u32> {
        let mut inv = vec![0u32; self.n_corners()];
        for (k, &c) in self.vertex_corners().corner.iter().enumerate() {
            inv[c as usize] = k as u32;
        }
        inv
    }

    /// Vertex-graph components over referenced vertices: `(count, label per vertex)`, labels in order of
    /// first vertex, [`NONE`] for unreferenced vertices.
    ///
    /// ```
    /// # use gregvox::mesh::{MeshMatrix, NONE};
    /// let m = MeshMatrix::new(7, &[0, 3, 6], vec![0, 1, 2, 3, 4, 5]).unwrap();
    /// let (n, labels) = m.vertex_components();
    /// assert_eq!(n, 2);
    /// assert_eq!(labels[6], NONE);
    /// ```
    pub fn vertex_components(&self) -> (usize, Vec<u32>) {
        let mut uf = UnionFind::new(self.n_verts());
        for f in 0..self.n_faces() {
            let face = self.face(f);
            for w in face.windows(2) {
                uf.union(w[0], w[1]);
            }
        }
        let mut label = vec![NONE; self.n_verts()];
        let mut root_label = vec![NONE; self.n_verts()];
        let mut n = 0u32;
        for (v, l) in label.iter_mut().enumerate() {
            if !self.is_referenced(v) {
                continue;
            }
            let r = uf.find(v as u32) as usize;
            if root_label[r] == NONE {
                root_label[r] = n;
                n += 1;
            }
            *l = root_label[r];
        }
        (n as usize, label)
    }

    /// Face components through shared edges (= `igl::facet_components`): `(count, label per face)`.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// // two triangles sharing only vertex 0: one vertex component, two face components
    /// let m = MeshMatrix::new(5, &[0, 3, 6], vec![0, 1, 2, 0, 3, 4]).unwrap();
    /// assert_eq!(m.face_components().0, 2);
    /// assert_eq!(m.vertex_components().0, 1);
    /// ```
    pub fn face_components(&self) -> (usize, Vec<u32>) {
        let mut uf = UnionFind::new(self.n_faces());
        let face1 = &self.half_edge_face().face1;
        let reps = self.edge_reps();
        for (k, &e) in self.half_edge_edge().iter().enumerate() {
            let r = reps[e as usize] as usize;
            uf.union(face1[k] - 1, face1[r] - 1);
        }
        let mut label = vec![NONE; self.n_faces()];
        let mut root_label = vec![NONE; self.n_faces()];
        let mut n = 0u32;
        for (f, l) in label.iter_mut().enumerate() {
            let r = uf.find(f as u32) as usize;
            if root_label[r] == NONE {
                root_label[r] = n;
                n += 1;
            }
            *l = root_label[r];
        }
        (n as usize, label)
    }

    /// Number of vertices used by at least one face.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// assert_eq!(MeshMatrix::new(5, &[0, 3], vec![0, 1, 2]).unwrap().referenced_vertices(), 3);
    /// ```
    pub fn referenced_vertices(&self) -> usize {
        (0..self.n_verts())
            .filter(|&v| self.is_referenced(v))
            .count()
    }

    /// χ = referenced vertices − edges + faces.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let t = MeshMatrix::new(4, &[0, 3, 6, 9, 12], vec![0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2]).unwrap();
    /// assert_eq!(t.euler_characteristic(), 2);
    /// ```
    pub fn euler_characteristic(&self) -> i64 {
        self.referenced_vertices() as i64 - self.n_edges() as i64 + self.n_faces() as i64
    }

    /// Genus from χ = 2c − 2g − b (c face components, b boundary loops), when the mesh is an
    /// edge-manifold, vertex-manifold, consistently oriented surface; `None` otherwise.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let t = MeshMatrix::new(4, &[0, 3, 6, 9, 12], vec![0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2]).unwrap();
    /// assert_eq!(t.genus(), Some(0));
    /// ```
    pub fn genus(&self) -> Option<i64> {
        let uses = self.edge_uses();
        if uses
            .iter()
            .any(|u| u.faces() > 2 || u.forward > 1 || u.backward > 1)
        {
            return None;
        }
        if !self.non_manifold_vertices().is_empty() {
            return None;
        }
        let c = self.face_components().0 as i64;
        let b = self.boundary_loops().len() as i64;
        let twice = 2 * c - b - self.euler_characteristic();
        (twice % 2 == 0).then_some(twice / 2)
    }

    /// Collapses edge `remove → keep` as a topology update: `B' = K·B` done as `row_id = newid[row_id]` over
    /// the index buffer (multiplying M's values would sum slots and lose orientation). Vertex `remove`
    /// disappears (ids above it shift down by one); a face loses the repeated corner; faces left with
    /// fewer than 3 corners are deleted. Returns the new matrix and the old → new vertex map.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let t = MeshMatrix::new(4, &[0, 3, 6, 9, 12], vec![0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2]).unwrap();
    /// let (c, map) = t.collapse_edge(0, 1).unwrap();
    /// assert_eq!((c.n_verts(), c.n_faces(), map), (3, 2, vec![0, 0, 1, 2]));
    /// assert!(t.collapse_edge(0, 0).is_err());
    /// ```
    pub fn collapse_edge(&self, keep: u32, remove: u32) -> Result<(MeshMatrix, Vec<u32>)> {
        let n = self.n_verts() as u32;
        if keep >= n || remove >= n || keep == remove {
            return Err(Error::Invalid(format!(
                "cannot collapse edge {remove} → {keep}"
            )));
        }
        if self.find(keep, remove) == NONE && self.find(remove, keep) == NONE {
            return Err(Error::Invalid(format!("{remove} – {keep} is not an edge")));
        }
        let shift = |v: u32| if v > remove { v - 1 } else { v };
        let map: Vec<u32> = (0..n)
            .map(|v| if v == remove { shift(keep) } else { shift(v) })
            .collect();
        let mut face_ptr = vec![0u32];
        let mut idx = Vec::with_capacity(self.n_corners());
        for f in 0..self.n_faces() {
            let start = idx.len();
            for &v in self.face(f) {
                let nv = map[v as usize];
                if !idx[start..].contains(&nv) {
                    idx.push(nv);
                }
            }
            if idx.len() - start < 3 {
                idx.truncate(start);
            } else {
                face_ptr.push(idx.len() as u32);
            }
        }
        let m = MeshMatrix::new(n - 1, &face_ptr, idx)?;
        Ok((m, map))
    }
    /// (boundary edges, non-manifold edges): the part of [`MeshMatrix::report`] that says whether the mesh
    /// is closed, without the rest of the report (components, loops, fans), which costs more than a small
    /// voxelization.
    pub fn edge_counts(&self) -> (usize, usize) {
        open_edge_counts(&self.edge_uses())
    }

    /// The topology report (see [`TopologyReport`]).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let t = MeshMatrix::new(4, &[0, 3, 6, 9, 12], vec![0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2]).unwrap();
    /// let r = t.report();
    /// assert!(r.closed);
    /// assert_eq!((r.edges, r.euler_characteristic, r.valence_histogram["3"]), (6, 2, 4));
    /// ```
    pub fn report(&self) -> TopologyReport {
        let uses = self.edge_uses();
        let (boundary_edges, non_manifold_edges) = open_edge_counts(&uses);
        let inconsistent_edges = uses
            .iter()
            .filter(|u| u.faces() == 2 && (u.forward == 2 || u.backward == 2))
            .count();
        let mut valence_histogram: BTreeMap<u32, usize> = BTreeMap::new();
        for v in 0..self.n_verts() {
            if self.is_referenced(v) {
                *valence_histogram.entry(self.valence(v) as u32).or_default() += 1;
            }
        }
        let mut order: BTreeMap<u32, usize> = BTreeMap::new();
        for f in 0..self.n_faces() {
            *order.entry(self.face_len(f)).or_default() += 1;
        }
        let loops = self.boundary_loops();
        let mut sizes: Vec<usize> = loops.iter().map(|l| l.len()).collect();
        sizes.sort_unstable();
        let referenced = self.referenced_vertices();
        let consistently_oriented = uses
            .iter()
            .all(|u| u.faces() <= 2 && u.forward <= 1 && u.backward <= 1);
        TopologyReport {
            vertices: self.n_verts(),
            faces: self.n_faces(),
            edges: self.n_edges(),
            boundary_edges,
            non_manifold_edges,
            inconsistent_edges,
            closed: boundary_edges == 0 && non_manifold_edges == 0,
            components: self.vertex_components().0,
            euler_characteristic: self.euler_characteristic(),
            valence_histogram: valence_histogram
                .into_iter()
                .map(|(k, v)| (k.to_string(), v))
                .collect(),
            referenced_vertices: referenced,
            unreferenced_vertices: self.n_verts() - referenced,
            face_components: self.face_components().0,
            boundary_loops: loops.len(),
            boundary_loop_sizes: sizes,
            non_manifold_vertices: self.non_manifold_vertices().len(),
            second_writes: self.second_writes(),
            consistently_oriented,
            genus: self.genus(),
            face_order_histogram: order.into_iter().map(|(k, v)| (k.to_string(), v)).collect(),
        }
    }
}

/// (edges used by one face, edges used by more than two).
fn open_edge_counts(uses: &[EdgeUse]) -> (usize, usize) {
    (
        uses.iter().filter(|u| u.faces() == 1).count(),
        uses.iter().filter(|u| u.faces() > 2).count(),
    )
}
