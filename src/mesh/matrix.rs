//! The vertex×face mesh matrix M, its transpose (vertex→corner CSR), action maps and the half-edge→face
//! matrix E.
//!
//! Layout (all `u32`, uploadable as-is):
//! - **M** is the index buffer read column by column: corner `c` of face `f` holds vertex
//!   `corner_vertex[c]`; its value (slot, 1-based) is `c - face_start(f) + 1`. Faces are either a fixed
//!   [`FaceLayout::Stride`] (`face_start(f) = s·f`, all triangles, all quads, …) or
//!   [`FaceLayout::Offsets`] (`face_ptr`, |F| + 1 prefix sums) for mixed polygons.
//! - **Mᵀ** is [`VertexCorners`]: `ptr` (|V| + 1) and `corner` (one per corner), rows in increasing corner
//!   id (a stable counting sort), so every gather over a vertex's corners sums in a fixed order.
//! - **E** is [`HalfEdgeFace`]: the same row pointer as Mᵀ; entry `k` of row `i` is the half-edge
//!   `i → col[k]` of face `face1[k] - 1` (face + 1 so 0 never reads as a face), made by the corner
//!   `vc.corner[k]` whose next corner carries `col[k]`. Built by walking corners, no SpGEMM.
//! - Derived per-half-edge arrays (`twin`, `edge`) are CPU conveniences built once from E.
//!
//! Faces are consistently read counter-clockwise seen from outside: the face of `i → j` is on its left.
use super::obj::Mesh;
use super::sparse::SparseMatrix;
use crate::error::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// No entry / no twin.
///
/// ```
/// # use gregvox::mesh::{MeshMatrix, NONE};
/// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
/// assert_eq!(m.twins(), &[NONE; 3]); // a lone triangle: every half-edge is on the boundary
/// ```
pub const NONE: u32 = u32::MAX;

/// How faces sit in the corner array.
///
/// ```
/// # use gregvox::mesh::{MeshMatrix, FaceLayout};
/// assert_eq!(MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap().layout(), &FaceLayout::Stride(4));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FaceLayout {
    /// Every face has this many corners; face `f` owns corners `s·f .. s·f + s`.
    Stride(u32),
    /// Mixed polygons: face `f` owns corners `face_ptr[f] .. face_ptr[f + 1]` (|F| + 1 entries).
    Offsets(Vec<u32>),
}

/// An action map: slot `k` (1-based corner value of M) is replaced by `w[k]` in a product. Slot 0 is unused;
/// slots ≥ 7 all read `w[7]` (so a constant map serves any polygon). 32 bytes, `Pod`: a push constant.
///
/// ```
/// use gregvox::mesh::ActionMap;
/// let m = ActionMap::new(&[-1.0, 0.0, 1.0]); // P3 − P1
/// assert_eq!(bytemuck::bytes_of(&m).len(), 32);
/// ```
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct ActionMap {
    /// Weights by slot.
    pub w: [f32; 8],
}

impl ActionMap {
    /// The map `(1, 2, 3, …) → (a, b, c, …)` from the given slot weights (the rest 0).
    ///
    /// ```
    /// use gregvox::mesh::ActionMap;
    /// let m = ActionMap::new(&[-1.0, 1.0, 0.0]); // P2 − P1
    /// assert_eq!(m.weight(1), -1.0);
    /// assert_eq!(m.weight(2), 1.0);
    /// ```
    pub fn new(weights: &[f32]) -> Self {
        let mut w = [0.0f32; 8];
        for (k, &x) in weights.iter().take(7).enumerate() {
            w[k + 1] = x;
        }
        ActionMap { w }
    }

    /// The all-ones map `B` (pattern of M).
    ///
    /// ```
    /// assert_eq!(gregvox::mesh::ActionMap::ones().weight(12), 1.0);
    /// ```
    pub fn ones() -> Self {
        ActionMap {
            w: [0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
        }
    }

    /// The weight of 1-based slot `k`.
    ///
    /// ```
    /// assert_eq!(gregvox::mesh::ActionMap::new(&[2.0]).weight(1), 2.0);
    /// ```
    pub fn weight(&self, k: u32) -> f64 {
        self.w[(k as usize).min(7)] as f64
    }
}

/// Mᵀ as CSR: for each vertex, its corners in increasing corner id.
///
/// ```
/// # use gregvox::mesh::MeshMatrix;
/// let m = MeshMatrix::new(3, &[0, 3], vec![2, 0, 1]).unwrap();
/// let vc = m.vertex_corners();
/// assert_eq!((&vc.ptr[..], &vc.corner[..]), (&[0, 1, 2, 3][..], &[1, 2, 0][..]));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VertexCorners {
    /// Row pointers, |V| + 1.
    pub ptr: Vec<u32>,
    /// Corner ids, one per corner.
    pub corner: Vec<u32>,
}

/// E as CSR: entry `k` of row `i` is half-edge `i → col[k]` of face `face1[k] - 1`; its row pointer is
/// [`VertexCorners::ptr`] and its entry `k` comes from corner `VertexCorners::corner[k]`.
///
/// ```
/// # use gregvox::mesh::MeshMatrix;
/// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
/// let e = m.half_edge_face();
/// let k = m.find(2, 1) as usize; // half-edge 2 → 1 belongs to face 1
/// assert_eq!((e.col[k], e.face1[k]), (1, 2));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HalfEdgeFace {
    /// Head vertex of each half-edge.
    pub col: Vec<u32>,
    /// Face + 1 of each half-edge.
    pub face1: Vec<u32>,
}

/// The vertex×face mesh matrix with its transpose, E, and per-half-edge twins and undirected edge ids.
///
/// ```
/// # use gregvox::mesh::MeshMatrix;
/// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
/// assert_eq!((m.n_verts(), m.n_faces(), m.n_corners(), m.n_edges()), (4, 2, 6, 5));
/// ```
#[derive(Debug, Clone)]
pub struct MeshMatrix {
    n_verts: u32,
    layout: FaceLayout,
    corner_vertex: Vec<u32>,
    corner_face: Vec<u32>,
    vc: VertexCorners,
    e: HalfEdgeFace,
    twin: Vec<u32>,
    edge: Vec<u32>,
    edge_rep: Vec<u32>,
}

impl MeshMatrix {
    /// Builds M, Mᵀ and E from a loaded mesh.
    ///
    /// ```
    /// use gregvox::mesh::{Mesh, MeshMatrix, FaceLayout};
    /// use glam::DVec3;
    /// let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::ONE];
    /// let mesh = Mesh::from_polygons(p, &[vec![0, 1, 2], vec![2, 1, 3]]).unwrap();
    /// let m = MeshMatrix::from_mesh(&mesh);
    /// assert_eq!(m.layout(), &FaceLayout::Stride(3));
    /// assert_eq!(m.n_edges(), 5);
    /// ```
    ///
    /// # Panics
    /// If `mesh` breaks the [`Mesh`] invariants, which only a hand-built `Mesh` can (the loader and
    /// [`Mesh::from_polygons`] validate); use [`MeshMatrix::new`] to get an error instead.
    pub fn from_mesh(mesh: &Mesh) -> Self {
        match Self::new(
            mesh.positions.len() as u32,
            &mesh.face_ptr,
            mesh.indices.clone(),
        ) {
            Ok(m) => m,
            Err(e) => panic!("invalid Mesh: {e}"),
        }
    }

    /// Builds the matrices from a vertex count, face offsets and corner vertices, validating indices.
    ///
    /// ```
    /// use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap();
    /// assert_eq!(m.n_faces(), 1);
    /// assert!(MeshMatrix::new(3, &[0, 4], vec![0, 1, 2, 3]).is_err());
    /// ```
    pub fn new(n_verts: u32, face_ptr: &[u32], corner_vertex: Vec<u32>) -> Result<Self> {
        if face_ptr.first() != Some(&0) || *face_ptr.last().unwrap() as usize != corner_vertex.len()
        {
            return Err(Error::Invalid(
                "face offsets do not cover the corner array".into(),
            ));
        }
        for f in 0..face_ptr.len() - 1 {
            let (a, b) = (face_ptr[f] as usize, face_ptr[f + 1] as usize);
            if b < a + 3 {
                return Err(Error::Invalid(format!(
                    "face {f} has fewer than 3 vertices"
                )));
            }
            let face = &corner_vertex[a..b];
            if let Some(&v) = face.iter().find(|&&v| v >= n_verts) {
                return Err(Error::Invalid(format!(
                    "face {f}: vertex index {v} out of range ({n_verts} vertices)"
                )));
            }
            if let Some(v) = super::obj::first_repeated(face) {
                return Err(Error::Invalid(format!("face {f}: vertex {v} repeated")));
            }
        }
        Ok(Self::from_parts_unchecked(n_verts, face_ptr, corner_vertex))
    }

    /// Builds from trusted parts (produced inside this module, e.g. by subdivision).
    pub(crate) fn from_parts_unchecked(
        n_verts: u32,
        face_ptr: &[u32],
        corner_vertex: Vec<u32>,
    ) -> Self {
        let n_faces = face_ptr.len() - 1;
        let n_corners = corner_vertex.len();
        let first = if n_faces > 0 {
            face_ptr[1] - face_ptr[0]
        } else {
            3
        };
        let uniform = (0..n_faces).all(|f| face_ptr[f + 1] - face_ptr[f] == first);
        let layout = if uniform {
            FaceLayout::Stride(first)
        } else {
            FaceLayout::Offsets(face_ptr.to_vec())
        };
        // Mᵀ by a stable counting sort of corners by vertex. The scatter walks corners in increasing order
        // face by face, so E's columns (the next corner's vertex) and faces are written in the same pass
        // from sequential reads: row i of E = {(next(c), face(c) + 1) : c a corner at i}, in Mᵀ's order.
        let mut ptr = vec![0u32; n_verts as usize + 1];
        for &v in &corner_vertex {
            ptr[v as usize + 1] += 1;
        }
        for i in 0..n_verts as usize {
            ptr[i + 1] += ptr[i];
        }
        let mut fill = ptr.clone();
        let mut corner = vec![0u32; n_corners];
        let mut corner_face = vec![0u32; n_corners];
        let mut col = vec![0u32; n_corners];
        let mut face1 = vec![0u32; n_corners];
        for f in 0..n_faces {
            let (a, b) = (face_ptr[f], face_ptr[f + 1]);
            for c in a..b {
                let next = if c + 1 == b { a } else { c + 1 };
                let v = corner_vertex[c as usize] as usize;
                let pos = fill[v] as usize;
                fill[v] += 1;
                corner[pos] = c;
                col[pos] = corner_vertex[next as usize];
                face1[pos] = f as u32 + 1;
                corner_face[c as usize] = f as u32;
            }
        }
        let vc = VertexCorners { ptr, corner };
        let mut m = MeshMatrix {
            n_verts,
            layout,
            corner_vertex,
            corner_face,
            vc,
            e: HalfEdgeFace { col, face1 },
            twin: Vec::new(),
            edge: Vec::new(),
            edge_rep: Vec::new(),
        };
        // Twins and undirected edge ids. The representative of {i, j} is the first entry of row min(i, j)
        // with column max(i, j), else the first of row max with column min: it never comes after any
        // entry of its edge in storage order, so one pass numbers edges in E's row-major order.
        let mut twin = vec![NONE; n_corners];
        let mut edge = vec![NONE; n_corners];
        let mut edge_rep = Vec::new();
        let (ptr, col) = (&m.vc.ptr, &m.e.col);
        // Rows longer than this get a (row, column) → first entry map: a linear scan per half-edge is
        // quadratic in the valence (a million-gon refined once has a valence-10⁶ vertex: hours).
        const SCAN_MAX: u32 = 64;
        let mut first_of_long: std::collections::HashMap<(u32, u32), u32> = Default::default();
        for i in 0..n_verts {
            let (a, b) = (ptr[i as usize], ptr[i as usize + 1]);
            if b - a > SCAN_MAX {
                for k in a..b {
                    first_of_long.entry((i, col[k as usize])).or_insert(k);
                }
            }
        }
        // First entry of `row` with column `target` before `end` (both callers pass an `end` past that
        // first entry whenever one exists, so the map's answer is the same as the scan's).
        let first_in_row = |row: u32, target: u32, end: u32| -> u32 {
            let a = ptr[row as usize];
            if ptr[row as usize + 1] - a > SCAN_MAX {
                return first_of_long
                    .get(&(row, target))
                    .copied()
                    .filter(|&k| k < end)
                    .unwrap_or(NONE);
            }
            col[a as usize..end as usize]
                .iter()
                .position(|&c| c == target)
                .map_or(NONE, |p| a + p as u32)
        };
        for i in 0..n_verts {
            for k in ptr[i as usize]..ptr[i as usize + 1] {
                let j = col[k as usize];
                let t = first_in_row(j, i, ptr[j as usize + 1]);
                twin[k as usize] = t;
                // i > j with a twin: the twin (first j → i) is the representative; otherwise it is the
                // first i → j, at or before k in row i.
                let rep = if i > j && t != NONE {
                    t
                } else {
                    first_in_row(i, j, k + 1)
                };
                if rep == k {
                    edge[k as usize] = edge_rep.len() as u32;
                    edge_rep.push(k);
                } else {
                    edge[k as usize] = edge[rep as usize];
                }
            }
        }
        m.twin = twin;
        m.edge = edge;
        m.edge_rep = edge_rep;
        m
    }

    /// First E entry of row `i` with column `j`, or [`NONE`].
    ///
    /// ```
    /// # use gregvox::mesh::{MeshMatrix, NONE};
    /// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
    /// let k = m.find(0, 1);
    /// assert_eq!(m.half_edge_face().face1[k as usize], 1); // face 0, stored +1
    /// assert_eq!(m.find(1, 0), NONE); // boundary
    /// ```
    pub fn find(&self, i: u32, j: u32) -> u32 {
        self.find_opt(i, j).unwrap_or(NONE)
    }

    /// The undirected edge id of the edge between `i` and `j` (either direction), or `None`.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
    /// assert_eq!(m.edge_id(1, 0), m.edge_id(0, 1));
    /// assert!(m.edge_id(0, 1).is_some() && MeshMatrix::new(4, &[0, 3], vec![0, 1, 2]).unwrap().edge_id(0, 3).is_none());
    /// ```
    pub fn edge_id(&self, i: u32, j: u32) -> Option<usize> {
        let k = self.find_opt(i, j).or_else(|| self.find_opt(j, i))?;
        Some(self.edge[k as usize] as usize)
    }

    fn find_opt(&self, i: u32, j: u32) -> Option<u32> {
        let (a, b) = (self.vc.ptr[i as usize], self.vc.ptr[i as usize + 1]);
        (a..b).find(|&k| self.e.col[k as usize] == j)
    }

    /// Number of vertices (rows of M), referenced or not.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// assert_eq!(MeshMatrix::new(4, &[0, 3], vec![0, 1, 2]).unwrap().n_verts(), 4);
    /// ```
    pub fn n_verts(&self) -> usize {
        self.n_verts as usize
    }

    /// Number of faces (columns of M).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// assert_eq!(MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap().n_faces(), 1);
    /// ```
    pub fn n_faces(&self) -> usize {
        match &self.layout {
            FaceLayout::Stride(s) => self.corner_vertex.len() / *s as usize,
            FaceLayout::Offsets(p) => p.len() - 1,
        }
    }

    /// Number of corners = nnz(M) = number of half-edges.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// assert_eq!(MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap().n_corners(), 4);
    /// ```
    pub fn n_corners(&self) -> usize {
        self.corner_vertex.len()
    }

    /// Number of unique undirected edges.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// assert_eq!(MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap().n_edges(), 4);
    /// ```
    pub fn n_edges(&self) -> usize {
        self.edge_rep.len()
    }

    /// The face layout (stride or offsets).
    ///
    /// ```
    /// # use gregvox::mesh::{MeshMatrix, FaceLayout};
    /// let m = MeshMatrix::new(5, &[0, 3, 7], vec![0, 1, 2, 1, 3, 4, 2]).unwrap();
    /// assert_eq!(m.layout(), &FaceLayout::Offsets(vec![0, 3, 7]));
    /// ```
    pub fn layout(&self) -> &FaceLayout {
        &self.layout
    }

    /// The corner → vertex array (the index buffer; M's row indices).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// assert_eq!(MeshMatrix::new(3, &[0, 3], vec![2, 0, 1]).unwrap().corner_vertex(), &[2, 0, 1]);
    /// ```
    pub fn corner_vertex(&self) -> &[u32] {
        &self.corner_vertex
    }

    /// The corner → face array (implicit `c / s` for a stride layout; stored for convenience).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// assert_eq!(m.corner_face(), &[0, 0, 0, 1, 1, 1]);
    /// ```
    pub fn corner_face(&self) -> &[u32] {
        &self.corner_face
    }

    /// Mᵀ (vertex → corners).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// assert_eq!(m.vertex_corners().ptr, vec![0, 1, 3, 5, 6]);
    /// assert_eq!(m.vertex_corners().corner, vec![0, 1, 4, 2, 3, 5]);
    /// ```
    pub fn vertex_corners(&self) -> &VertexCorners {
        &self.vc
    }

    /// E (half-edge → face), sharing Mᵀ's row pointer.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
    /// assert_eq!(m.half_edge_face().col, vec![1, 2, 0]); // 0→1, 1→2, 2→0
    /// ```
    pub fn half_edge_face(&self) -> &HalfEdgeFace {
        &self.e
    }

    /// Per E entry: the E entry of the opposite half-edge, or [`NONE`] on a boundary.
    ///
    /// ```
    /// # use gregvox::mesh::{MeshMatrix, NONE};
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// let k = m.find(1, 2);
    /// assert_eq!(m.twins()[k as usize], m.find(2, 1));
    /// assert_eq!(m.twins()[m.find(0, 1) as usize], NONE);
    /// ```
    pub fn twins(&self) -> &[u32] {
        &self.twin
    }

    /// Per E entry: its undirected edge id (numbered in E's row-major order of representatives).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// assert_eq!(m.half_edge_edge()[m.find(1, 2) as usize], m.half_edge_edge()[m.find(2, 1) as usize]);
    /// ```
    pub fn half_edge_edge(&self) -> &[u32] {
        &self.edge
    }

    /// Endpoints of undirected edge `e`, as its representative half-edge `[tail, head]`: `tail < head`
    /// whenever a half-edge runs that way, else (a boundary edge running high → low) `tail > head`.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
    /// assert_eq!(m.edge_vertices(0), [0, 1]);
    /// assert_eq!(m.edge_vertices(2), [2, 0]);
    /// ```
    pub fn edge_vertices(&self, e: usize) -> [u32; 2] {
        let k = self.edge_rep[e];
        [self.entry_row(k), self.e.col[k as usize]]
    }

    /// The representative E entry of each undirected edge.
    pub(crate) fn edge_reps(&self) -> &[u32] {
        &self.edge_rep
    }

    /// Row (tail vertex) of E entry `k`.
    pub(crate) fn entry_row(&self, k: u32) -> u32 {
        self.corner_vertex[self.vc.corner[k as usize] as usize]
    }

    /// First corner of face `f`.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(5, &[0, 3, 7], vec![0, 1, 2, 1, 3, 4, 2]).unwrap();
    /// assert_eq!(m.face_start(1), 3);
    /// ```
    pub fn face_start(&self, f: usize) -> u32 {
        match &self.layout {
            FaceLayout::Stride(s) => s * f as u32,
            FaceLayout::Offsets(p) => p[f],
        }
    }

    /// Number of corners (vertices) of face `f` (column count of M).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(5, &[0, 3, 7], vec![0, 1, 2, 1, 3, 4, 2]).unwrap();
    /// assert_eq!(m.face_len(1), 4);
    /// ```
    pub fn face_len(&self, f: usize) -> u32 {
        match &self.layout {
            FaceLayout::Stride(s) => *s,
            FaceLayout::Offsets(p) => p[f + 1] - p[f],
        }
    }

    /// The vertices of face `f` in winding order.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(5, &[0, 3, 7], vec![0, 1, 2, 1, 3, 4, 2]).unwrap();
    /// assert_eq!(m.face(1), &[1, 3, 4, 2]);
    /// ```
    pub fn face(&self, f: usize) -> &[u32] {
        let a = self.face_start(f) as usize;
        &self.corner_vertex[a..a + self.face_len(f) as usize]
    }

    /// The face offsets, |F| + 1 prefix sums (materialised for a stride layout).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// assert_eq!(MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap().face_ptr(), vec![0, 3, 6]);
    /// ```
    pub fn face_ptr(&self) -> Vec<u32> {
        (0..=self.n_faces()).map(|f| self.face_start(f)).collect()
    }

    /// M's value at corner `c`: its 1-based slot in its face.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// assert_eq!(m.slot(4), 2);
    /// ```
    pub fn slot(&self, c: u32) -> u32 {
        c - self.face_start(self.corner_face[c as usize] as usize) + 1
    }

    /// The next corner in the same face (winding order).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// assert_eq!((m.next(2), m.next(3)), (0, 4));
    /// ```
    pub fn next(&self, c: u32) -> u32 {
        let f = self.corner_face[c as usize] as usize;
        let (a, n) = (self.face_start(f), self.face_len(f));
        if c + 1 == a + n {
            a
        } else {
            c + 1
        }
    }

    /// The previous corner in the same face.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// assert_eq!((m.prev(0), m.prev(4)), (2, 3));
    /// ```
    pub fn prev(&self, c: u32) -> u32 {
        let f = self.corner_face[c as usize] as usize;
        let (a, n) = (self.face_start(f), self.face_len(f));
        if c == a {
            a + n - 1
        } else {
            c - 1
        }
    }

    /// Is vertex `v` used by at least one face?
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(4, &[0, 3], vec![0, 1, 2]).unwrap();
    /// assert!(m.is_referenced(2) && !m.is_referenced(3));
    /// ```
    pub fn is_referenced(&self, v: usize) -> bool {
        self.vc.ptr[v + 1] > self.vc.ptr[v]
    }

    /// Transposed mapped SpMV, one result per face: `y[f] = Σ_k map(k) · x[v_k(f)]`.
    ///
    /// ```
    /// # use gregvox::mesh::{MeshMatrix, ActionMap}; use glam::DVec3;
    /// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
    /// let p = [DVec3::ZERO, DVec3::X, DVec3::Y];
    /// assert_eq!(m.apply_transposed(&ActionMap::new(&[-1.0, 1.0, 0.0]), &p), vec![DVec3::X]); // P2 − P1
    /// ```
    pub fn apply_transposed(&self, map: &ActionMap, x: &[DVec3]) -> Vec<DVec3> {
        (0..self.n_faces())
            .map(|f| {
                let mut acc = DVec3::ZERO;
                for (k, &v) in self.face(f).iter().enumerate() {
                    acc += map.weight(k as u32 + 1) * x[v as usize];
                }
                acc
            })
            .collect()
    }

    /// Plain mapped SpMV, one result per vertex (a gather over Mᵀ in corner order):
    /// `z[v] = Σ_{f ∋ v} map(pos_f(v)) · y[f]`.
    ///
    /// ```
    /// # use gregvox::mesh::{MeshMatrix, ActionMap}; use glam::DVec3;
    /// let m = MeshMatrix::new(4, &[0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// let z = m.apply(&ActionMap::ones(), &[DVec3::X, DVec3::Y]);
    /// assert_eq!(z[1], DVec3::new(1.0, 1.0, 0.0)); // vertex 1 is in both faces
    /// ```
    pub fn apply(&self, map: &ActionMap, y: &[DVec3]) -> Vec<DVec3> {
        (0..self.n_verts())
            .map(|v| {
                let mut acc = DVec3::ZERO;
                for k in self.vc.ptr[v]..self.vc.ptr[v + 1] {
                    let c = self.vc.corner[k as usize];
                    acc += map.weight(self.slot(c)) * y[self.corner_face[c as usize] as usize];
                }
                acc
            })
            .collect()
    }

    /// M itself as a CSR matrix (rows = vertices, columns = faces, values = slots), for cross-checks.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// let m = MeshMatrix::new(3, &[0, 3], vec![2, 0, 1]).unwrap();
    /// assert_eq!(m.to_sparse().get(2, 0), Some(1));
    /// ```
    pub fn to_sparse(&self) -> SparseMatrix<u32> {
        let val: Vec<u32> = self.vc.corner.iter().map(|&c| self.slot(c)).collect();
        let col: Vec<u32> = self
            .vc
            .corner
            .iter()
            .map(|&c| self.corner_face[c as usize])
            .collect();
        SparseMatrix {
            n_rows: self.n_verts,
            n_cols: self.n_faces() as u32,
            row_ptr: self.vc.ptr.clone(),
            col,
            val,
        }
    }

    /// The faces as a [`Mesh`] with the given positions (e.g. after subdivision).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix; use glam::DVec3;
    /// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
    /// let mesh = m.to_mesh(vec![DVec3::ZERO, DVec3::X, DVec3::Y]);
    /// assert_eq!(mesh.face(0), &[0, 1, 2]);
    /// ```
    pub fn to_mesh(&self, positions: Vec<DVec3>) -> Mesh {
        Mesh {
            positions,
            face_ptr: self.face_ptr(),
            indices: self.corner_vertex.clone(),
        }
    }
}
