//! Catmull–Clark and Loop subdivision as a sparse matrix S built once from topology: `P' = S·P`.
//!
//! Invariants: S is a [`SparseMatrix<f64>`] with one row per new vertex (sorted, merged columns, weights of
//! each row summing to 1); the refined connectivity is returned beside it as a [`MeshMatrix`]. Repeated
//! refinement of a deforming cage = build the [`SubdivisionStack`] once, then one SpMV per level per frame.
//!
//! Catmull–Clark new-vertex order: `[vertex points (|V|) | face points (|F|) | edge points (|E|, edge ids
//! of the input MeshMatrix)]`. New face `c` (one per corner `c` of face `f`, so |F'| = nnz(M)) is the quad
//! `[v_c, e(c → next c), f, e(prev c → c)]`: same orientation as the input, stride 4.
//! Boundary rule "edge only": an edge with one face (or more than two: non-manifold edges are treated as
//! creases too) gets its midpoint; a vertex on exactly two such edges gets `(6P + Pa + Pb)/8`; a vertex
//! on one or more than two keeps its position (a corner); unreferenced vertices keep their position.
//! Smooth vertices: `P' = Q/n + ΣP_j/n² + (n−2)/n·P` with n = number of edges at the vertex and Q the
//! average of the incident face points.
//!
//! Loop (triangles only): new-vertex order `[even (|V|) | odd (|E|)]`; new faces of triangle `[a,b,c]` are
//! `4f..4f+4`: `[a, ab, ca]`, `[b, bc, ab]`, `[c, ca, bc]`, `[ab, bc, ca]`. Even smooth vertex
//! `(1 − nβ)P + βΣP_j` with the β of [`LoopBeta`]; boundary rules as for Catmull–Clark; odd interior
//! `3/8 (P_i + P_j) + 1/8 (P_k + P_l)`.
use super::matrix::{MeshMatrix, NONE};
use super::obj::Mesh;
use super::sparse::SparseMatrix;
use crate::error::{Error, Result};
use glam::DVec3;

/// One refinement level: the subdivision matrix and the refined topology.
///
/// ```
/// use gregvox::mesh::{MeshMatrix, catmull_clark_matrix};
/// let sub = catmull_clark_matrix(&MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap());
/// assert_eq!((sub.s.n_rows, sub.s.n_cols, sub.topology.n_verts()), (7, 3, 7));
/// ```
#[derive(Debug, Clone)]
pub struct Subdivision {
    /// `|V'| × |V|` weights: new positions = `s.spmv(old positions)`.
    pub s: SparseMatrix<f64>,
    /// The refined connectivity.
    pub topology: MeshMatrix,
}

/// Which β the Loop scheme uses for smooth even vertices of valence n.
///
/// ```
/// use gregvox::mesh::LoopBeta;
/// assert_eq!(LoopBeta::default(), LoopBeta::Warren);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LoopBeta {
    /// Warren: 3/16 for n = 3, 3/(8n) otherwise (libigl `igl::loop`).
    #[default]
    Warren,
    /// Loop's original β = (40 − (3 + 2cos(2π/n))²)/(64n) (`trimesh.remesh.subdivide_loop`).
    Loop,
}

impl LoopBeta {
    /// β for valence `n`.
    ///
    /// ```
    /// use gregvox::mesh::LoopBeta;
    /// assert_eq!(LoopBeta::Warren.beta(3), 3.0 / 16.0);
    /// assert!((LoopBeta::Loop.beta(6) - 1.0 / 16.0).abs() < 1e-15);
    /// ```
    pub fn beta(self, n: usize) -> f64 {
        let nf = n as f64;
        match self {
            LoopBeta::Warren => {
                if n == 3 {
                    3.0 / 16.0
                } else {
                    3.0 / (8.0 * nf)
                }
            }
            LoopBeta::Loop => {
                let c = 3.0 + 2.0 * (2.0 * std::f64::consts::PI / nf).cos();
                (40.0 - c * c) / (64.0 * nf)
            }
        }
    }
}

/// Collects one row: pushes (col, w), then sorts by column and merges duplicates.
struct RowBuilder {
    row_ptr: Vec<u32>,
    col: Vec<u32>,
    val: Vec<f64>,
    buf: Vec<(u32, u32, f64)>,
}

impl RowBuilder {
    fn new(rows: usize, nnz_hint: usize) -> Self {
        let mut row_ptr = Vec::with_capacity(rows + 1);
        row_ptr.push(0);
        RowBuilder {
            row_ptr,
            col: Vec::with_capacity(nnz_hint),
            val: Vec::with_capacity(nnz_hint),
            buf: Vec::new(),
        }
    }
    fn add(&mut self, c: u32, w: f64) {
        let seq = self.buf.len() as u32;
        self.buf.push((c, seq, w));
    }
    fn finish_row(&mut self) {
        // Sorting by (column, push order): duplicates are summed in push order, so the weights are
        // reproducible; an unstable sort on a unique key avoids the stable sort's scratch allocation.
        self.buf.sort_unstable_by_key(|e| (e.0, e.1));
        let start = self.col.len();
        for &(c, _, w) in &self.buf {
            if self.col.len() > start && *self.col.last().unwrap() == c {
                *self.val.last_mut().unwrap() += w;
            } else {
                self.col.push(c);
                self.val.push(w);
            }
        }
        self.buf.clear();
        self.row_ptr.push(self.col.len() as u32);
    }
    fn build(self, n_cols: usize) -> SparseMatrix<f64> {
        SparseMatrix {
            n_rows: (self.row_ptr.len() - 1) as u32,
            n_cols: n_cols as u32,
            row_ptr: self.row_ptr,
            col: self.col,
            val: self.val,
        }
    }
}

/// The two faces of an edge used twice, in ascending face order (as `MeshMatrix::edge_faces` lists
/// them): from the representative and its twin, or for an inconsistently oriented pair, from the general
/// edge→face matrix, built only if such an edge exists.
struct EdgeTwoFaces<'a> {
    m: &'a MeshMatrix,
    general: Option<SparseMatrix<u32>>,
}

impl<'a> EdgeTwoFaces<'a> {
    fn new(m: &'a MeshMatrix) -> Self {
        let reps = m.edge_reps();
        let twins = m.twins();
        let uses = m.edge_uses();
        let needs_general = uses
            .iter()
            .enumerate()
            .any(|(e, u)| (u.faces() == 2 && twins[reps[e] as usize] == NONE) || u.forward > 1);
        EdgeTwoFaces {
            m,
            general: needs_general.then(|| m.edge_faces()),
        }
    }
    fn get(&self, e: usize) -> [u32; 2] {
        if let Some(g) = &self.general {
            let row = g.row(e).0;
            if row.len() == 2 {
                return [row[0], row[1]];
            }
        }
        let k = self.m.edge_reps()[e] as usize;
        let t = self.m.twins()[k] as usize;
        let face1 = &self.m.half_edge_face().face1;
        let (f, g) = (face1[k] - 1, face1[t] - 1);
        [f.min(g), f.max(g)]
    }
}

/// Per vertex: the neighbours across crease edges (boundary or non-manifold), at most 3 recorded.
fn crease_neighbours(m: &MeshMatrix) -> (Vec<u32>, Vec<[u32; 2]>) {
    let uses = m.edge_uses();
    let mut count = vec![0u32; m.n_verts()];
    let mut nb = vec![[0u32; 2]; m.n_verts()];
    for (e, u) in uses.iter().enumerate() {
        if u.faces() != 2 {
            let [a, b] = m.edge_vertices(e);
            for (x, y) in [(a, b), (b, a)] {
                let k = count[x as usize];
                if k < 2 {
                    nb[x as usize][k as usize] = y;
                }
                count[x as usize] += 1;
            }
        }
    }
    (count, nb)
}

/// Vertex rows shared by both schemes when the vertex is on a crease; returns true if handled.
fn crease_vertex_row(rb: &mut RowBuilder, v: u32, count: u32, nb: [u32; 2]) -> bool {
    match count {
        0 => false,
        2 => {
            rb.add(v, 0.75);
            rb.add(nb[0], 0.125);
            rb.add(nb[1], 0.125);
            true
        }
        _ => {
            rb.add(v, 1.0);
            true
        }
    }
}

/// The Catmull–Clark subdivision matrix and refined topology of one level (any polygon mesh).
///
/// ```
/// use gregvox::mesh::{MeshMatrix, catmull_clark_matrix};
/// use glam::DVec3;
/// // one quad: 4 vertex points, 1 face point, 4 edge points; 4 quads
/// let m = MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap();
/// let sub = catmull_clark_matrix(&m);
/// assert_eq!((sub.s.n_rows, sub.topology.n_faces()), (9, 4));
/// let p = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
/// assert_eq!(sub.s.spmv(&p)[4], DVec3::new(0.5, 0.5, 0.0)); // the face point
/// ```
pub fn catmull_clark_matrix(m: &MeshMatrix) -> Subdivision {
    catmull_clark_level(m, false)
}

/// One Catmull–Clark level. `staged`: the rows read the face points as variables of their own (columns
/// `nv + f`, see [`catmull_clark`]) instead of expanding each into its face's vertices, which makes the
/// matrix linear in the mesh: expanded, every edge and vertex of an n-gon carries n weights (a 10,000-gon
/// cap alone would need 2·10⁸ entries, 1.9 GB).
/// Sdc's sharpness arithmetic (`Sdc::Crease`): ≤ 0 smooth, ≥ 10 infinite.
mod sharpness {
    pub const INFINITE: f32 = 10.0;

    pub fn is_sharp(s: f32) -> bool {
        s > 0.0
    }

    pub fn is_semi(s: f32) -> bool {
        s > 0.0 && s < INFINITE
    }

    /// One level of uniform decay (`decrementSharpness`).
    pub fn decrement(s: f32) -> f32 {
        if s <= 0.0 {
            0.0
        } else if s >= INFINITE {
            INFINITE
        } else if s > 1.0 {
            s - 1.0
        } else {
            0.0
        }
    }

    /// The child sharpness of each edge at a vertex (`SubdivideEdgeSharpnessesAroundVertex`).
    pub fn children_at_vertex(parent: &[f32], chaikin: bool) -> Vec<f32> {
        if !chaikin || parent.len() < 2 {
            return parent.iter().map(|&s| decrement(s)).collect();
        }
        let (mut sum, mut count) = (0.0f32, 0u32);
        for &s in parent {
            if is_semi(s) {
                sum += s;
                count += 1;
            }
        }
        if count == 0 {
            return parent.to_vec();
        }
        parent
            .iter()
            .map(|&p| {
                if p <= 0.0 {
                    0.0
                } else if p >= INFINITE {
                    INFINITE
                } else if count == 1 {
                    decrement(p)
                } else {
                    let other = (sum - p) / (count - 1) as f32;
                    let c = (0.75 * p + 0.25 * other) - 1.0;
                    if c > 0.0 {
                        c
                    } else {
                        0.0
                    }
                }
            })
            .collect()
    }

    /// The parent rule's weight where a vertex's rule changes (`ComputeFractionalWeightAtVertex`).
    pub fn fractional_weight(
        parent_vertex: f32,
        child_vertex: f32,
        parent: &[f32],
        child: &[f32],
        chaikin: bool,
    ) -> f32 {
        let (mut count, mut sum) = (0u32, 0.0f32);
        if is_sharp(parent_vertex) && !is_sharp(child_vertex) {
            count = 1;
            sum = parent_vertex;
        }
        for (&p, &c) in parent.iter().zip(child) {
            let transition = if chaikin {
                is_sharp(p) && !is_sharp(c)
            } else {
                is_sharp(p) && p <= 1.0
            };
            if transition {
                sum += p;
                count += 1;
            }
        }
        if count == 0 {
            return 0.0;
        }
        (sum / count as f32).min(1.0)
    }
}

/// The vertex sharpness that makes a vertex a corner exactly as long as the edges flagged `leader` among
/// `edges` (every semi-sharp edge of a cage vertex, decaying together as Sdc decays them) keep any
/// sharpness, and blend at their last transition by their fractional weight: OpenSubdiv's *dependent*
/// sharpness of a face-varying value (`CornersPlus1/2`), for a UV cage whose vertices decay by one a level.
/// 0 when the leaders never are sharp. Cost: O(levels · edges), levels ≤ ⌈largest sharpness⌉ < 10 for
/// uniform decay (Chaikin decays at least as fast).
///
/// ```
/// use gregvox::mesh::dependent_vertex_sharpness;
/// // Uniform decay of one 2.5 edge: a corner for two levels, then blended by 0.5.
/// assert_eq!(dependent_vertex_sharpness(&[2.5], &[true], false), 2.5);
/// // Chaikin with two 1.0 edges beside it: 2.5 → 1.125 → 0, the last step blended by 1 (clamped).
/// assert_eq!(dependent_vertex_sharpness(&[2.5, 1.0, 1.0], &[true, false, false], true), 2.0);
/// ```
pub fn dependent_vertex_sharpness(edges: &[f32], leader: &[bool], chaikin: bool) -> f32 {
    let led = |s: &[f32]| -> Vec<f32> {
        s.iter()
            .zip(leader)
            .filter(|(_, &l)| l)
            .map(|(&x, _)| x)
            .collect()
    };
    let mut cur = edges.to_vec();
    // Semi-sharp edges lose at least a fraction a level and are below 10: the loop ends well within 64.
    for level in 1..=64 {
        let next = sharpness::children_at_vertex(&cur, chaikin);
        let (p, c) = (led(&cur), led(&next));
        let was = p.iter().any(|&x| sharpness::is_sharp(x));
        let now = c.iter().any(|&x| sharpness::is_sharp(x));
        if was && !now {
            let w = sharpness::fractional_weight(0.0, 0.0, &p, &c, chaikin);
            return (level - 1) as f32 + w;
        }
        if !was {
            return 0.0;
        }
        cur = next;
    }
    0.0
}

/// Sdc's vertex rule.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum VertexRule {
    Smooth,
    Dart,
    Crease,
    Corner,
}

fn vertex_rule(vertex: f32, edges: &[f32]) -> VertexRule {
    if sharpness::is_sharp(vertex) {
        return VertexRule::Corner;
    }
    match edges.iter().filter(|&&s| sharpness::is_sharp(s)).count() {
        0 => VertexRule::Smooth,
        1 => VertexRule::Dart,
        2 => VertexRule::Crease,
        _ => VertexRule::Corner,
    }
}

/// A refinement level with Sdc sharpness: the subdivision matrix, the refined topology and the refined
/// sharpness of every edge (refined edge ids) and vertex.
#[derive(Debug, Clone)]
pub struct CreasedSubdivision {
    pub sub: Subdivision,
    pub edge_sharpness: Vec<f32>,
    pub vertex_sharpness: Vec<f32>,
    /// Per refined vertex, the hidden semi-sharp edges' child sharpness (see
    /// [`catmull_clark_matrix_creased_hidden`]; empty where none).
    pub hidden: Vec<Vec<f32>>,
}

/// One Catmull–Clark level with OpenSubdiv's crease rules (Sdc `Scheme<CATMARK>` with `Crease`): edge and
/// vertex sharpness per `m` edge id and vertex (boundary edges are infinitely sharp whatever is given;
/// ≥ 10 is infinite), semi-sharp features decaying by one per level (uniform) or by Chaikin's averaging
/// along a crease, and a vertex whose rule changes across the level blended by Sdc's fractional weight.
/// Returns the refined sharpness for the next level. Cost: O(corners + Σ valence²) per level (a smooth
/// vertex's row lists its ring), like [`catmull_clark_matrix`]; the levels a cage needs are bounded by its
/// largest sharpness (at most 10).
///
/// ```
/// use gregvox::mesh::{catmull_clark_matrix_creased, MeshMatrix};
/// // a 2×1 strip of quads with its middle edge semi-sharp (1.5)
/// let m = MeshMatrix::new(6, &[0, 4, 8], vec![0, 1, 4, 3, 1, 2, 5, 4]).unwrap();
/// let mid = m.half_edge_edge()[m.find(1, 4) as usize] as usize;
/// let mut s = vec![0.0f32; m.n_edges()];
/// s[mid] = 1.5;
/// let c = catmull_clark_matrix_creased(&m, &s, &[0.0; 6], false);
/// // the two halves of the middle edge keep sharpness 0.5; the next level smooths them
/// assert_eq!(c.edge_sharpness.iter().filter(|&&x| x == 0.5).count(), 2);
/// ```
pub fn catmull_clark_matrix_creased(
    m: &MeshMatrix,
    edge_sharpness: &[f32],
    vertex_sharpness: &[f32],
    chaikin: bool,
) -> CreasedSubdivision {
    catmull_clark_matrix_creased_hidden(m, edge_sharpness, vertex_sharpness, chaikin, &[])
}

/// [`catmull_clark_matrix_creased`] where some vertices stand for a vertex of another mesh that has more
/// edges than they do: `hidden[v]` (empty, or one list per vertex) holds the sharpness of those other edges,
/// which Chaikin's averaging at v counts as the other mesh does (a UV cage's vertex at a seam is one span
/// of its cage vertex: the seam's and the other spans' semi-sharp edges are hidden from it). They change
/// only the child sharpness of v's own edges; their own children come back in
/// [`CreasedSubdivision::hidden`] for the next level (at the vertex points, which keep v's index). Without
/// Chaikin, or with no hidden edge, nothing changes. Cost: a vertex's hidden edges join its own in the
/// O(valence) average; a UV cage has at most the cage vertex's edges hidden at each span.
pub fn catmull_clark_matrix_creased_hidden(
    m: &MeshMatrix,
    edge_sharpness: &[f32],
    vertex_sharpness: &[f32],
    chaikin: bool,
    hidden: &[Vec<f32>],
) -> CreasedSubdivision {
    use sharpness::{children_at_vertex, decrement, fractional_weight, is_sharp, INFINITE};
    let (nv, nf, ne) = (m.n_verts(), m.n_faces(), m.n_edges());
    let vc = m.vertex_corners();
    let cf = m.corner_face();
    let cv = m.corner_vertex();
    let uses = m.edge_uses();
    let entry = m.corner_entries();
    let he_edge = m.half_edge_edge();
    let twin = m.twins();
    let es: Vec<f32> = (0..ne)
        .map(|e| {
            if uses[e].faces() != 2 {
                INFINITE
            } else {
                edge_sharpness[e].max(0.0)
            }
        })
        .collect();
    // The edges at each vertex: every corner's outgoing edge, and the incoming one where it has no twin.
    let mut vedges: Vec<Vec<u32>> = vec![Vec::new(); nv];
    for c in 0..m.n_corners() {
        let v = cv[c] as usize;
        vedges[v].push(he_edge[entry[c] as usize]);
        let p = m.prev(c as u32) as usize;
        if twin[entry[p] as usize] == NONE {
            vedges[v].push(he_edge[entry[p] as usize]);
        }
    }
    let other_end = |e: u32, v: u32| {
        let [a, b] = m.edge_vertices(e as usize);
        if a == v {
            b
        } else {
            a
        }
    };
    // Child sharpness of each edge's half at each of its ends.
    let mut half = vec![[0.0f32; 2]; ne];
    let mut child_v = vec![0.0f32; nv];
    let mut rb = RowBuilder::new(nv + nf + ne, 16 * m.n_corners());
    let face_point = |rb: &mut RowBuilder, f: usize, w: f64| {
        let face = m.face(f);
        let wf = w / face.len() as f64;
        for &u in face {
            rb.add(u, wf);
        }
    };
    let mut nbrs = Vec::new();
    let mut hidden_out: Vec<Vec<f32>> = Vec::new();
    for v in 0..nv {
        let vu = v as u32;
        let pe: Vec<f32> = vedges[v].iter().map(|&e| es[e as usize]).collect();
        let ce = match hidden.get(v) {
            Some(h) if chaikin && !h.is_empty() => {
                let all: Vec<f32> = pe.iter().chain(h).copied().collect();
                let mut c = children_at_vertex(&all, true);
                let kept: Vec<f32> = c
                    .split_off(pe.len())
                    .into_iter()
                    .filter(|&x| x > 0.0)
                    .collect();
                if !kept.is_empty() {
                    if hidden_out.is_empty() {
                        hidden_out = vec![Vec::new(); nv];
                    }
                    hidden_out[v] = kept;
                }
                c
            }
            _ => children_at_vertex(&pe, chaikin),
        };
        for (k, &e) in vedges[v].iter().enumerate() {
            let [a, _] = m.edge_vertices(e as usize);
            half[e as usize][(a != vu) as usize] = ce[k];
        }
        let pvs = vertex_sharpness[v].max(0.0);
        let cvs = decrement(pvs);
        child_v[v] = cvs;
        if !m.is_referenced(v) {
            rb.add(vu, 1.0);
            rb.finish_row();
            continue;
        }
        let p_rule = vertex_rule(pvs, &pe);
        let c_rule = vertex_rule(cvs, &ce);
        // The mask of a rule, scaled by `w`.
        let mut mask = |rb: &mut RowBuilder, rule: VertexRule, edges: &[f32], w: f64| match rule {
            VertexRule::Smooth | VertexRule::Dart => {
                m.neighbours_into(v, &mut nbrs);
                let n = nbrs.len() as f64;
                let n_faces = (vc.ptr[v + 1] - vc.ptr[v]) as f64;
                rb.add(vu, w * (n - 2.0) / n);
                for &j in &nbrs {
                    rb.add(j, w / (n * n));
                }
                for k in vc.ptr[v]..vc.ptr[v + 1] {
                    let f = cf[vc.corner[k as usize] as usize] as usize;
                    face_point(rb, f, w / (n * n_faces));
                }
            }
            VertexRule::Crease => {
                rb.add(vu, w * 0.75);
                let ends: Vec<u32> = vedges[v]
                    .iter()
                    .zip(edges)
                    .filter(|(_, &s)| is_sharp(s))
                    .map(|(&e, _)| other_end(e, vu))
                    .take(2)
                    .collect();
                for x in ends {
                    rb.add(x, w * 0.125);
                }
            }
            VertexRule::Corner => rb.add(vu, w),
        };
        if matches!(p_rule, VertexRule::Smooth | VertexRule::Dart) || p_rule == c_rule {
            mask(&mut rb, p_rule, &pe, 1.0);
        } else {
            let pw = fractional_weight(pvs, cvs, &pe, &ce, chaikin) as f64;
            mask(&mut rb, p_rule, &pe, pw);
            mask(&mut rb, c_rule, &ce, 1.0 - pw);
        }
        rb.finish_row();
    }
    for f in 0..nf {
        face_point(&mut rb, f, 1.0);
        rb.finish_row();
    }
    let two_faces = EdgeTwoFaces::new(m);
    for (e, &s) in es.iter().enumerate() {
        let [a, b] = m.edge_vertices(e);
        let smooth = |rb: &mut RowBuilder, w: f64| {
            rb.add(a, 0.25 * w);
            rb.add(b, 0.25 * w);
            for f in two_faces.get(e) {
                face_point(rb, f as usize, 0.25 * w);
            }
        };
        let child_crease = is_sharp(half[e][0]) && is_sharp(half[e][1]);
        if !is_sharp(s) {
            smooth(&mut rb, 1.0);
        } else if child_crease {
            rb.add(a, 0.5);
            rb.add(b, 0.5);
        } else {
            // Sdc blends the smooth mask toward the crease mask by the parent sharpness.
            let pw = s as f64;
            rb.add(a, pw * 0.5);
            rb.add(b, pw * 0.5);
            smooth(&mut rb, 1.0 - pw);
        }
        rb.finish_row();
    }
    let s = rb.build(nv);
    let topology = quads_at_corners(m);
    let eo = (nv + nf) as u32;
    let mut edge_out = vec![0.0f32; topology.n_edges()];
    for (e, h) in half.iter().enumerate() {
        let [a, b] = m.edge_vertices(e);
        let mid = eo + e as u32;
        for (k, (x, y)) in [(a, mid), (mid, b)].into_iter().enumerate() {
            match topology.edge_id(x, y) {
                Some(child) if uses[e].faces() == 2 => edge_out[child] = h[k],
                _ => {}
            }
        }
    }
    let mut vertex_out = vec![0.0f32; topology.n_verts()];
    vertex_out[..nv].copy_from_slice(&child_v);
    if !hidden_out.is_empty() {
        hidden_out.resize(topology.n_verts(), Vec::new());
    }
    CreasedSubdivision {
        sub: Subdivision { s, topology },
        edge_sharpness: edge_out,
        vertex_sharpness: vertex_out,
        hidden: hidden_out,
    }
}

/// The refined connectivity of one Catmull–Clark level: one quad per corner c of `m`, (vertex of c, point of
/// the edge after c, point of c's face, point of the edge before c), vertex points first, then face points,
/// then edge points.
fn quads_at_corners(m: &MeshMatrix) -> MeshMatrix {
    let (nv, nf, ne) = (m.n_verts(), m.n_faces(), m.n_edges());
    let (cf, cv) = (m.corner_face(), m.corner_vertex());
    let entry = m.corner_entries();
    let he_edge = m.half_edge_edge();
    let (fo, eo) = (nv as u32, (nv + nf) as u32);
    let mut idx = Vec::with_capacity(4 * m.n_corners());
    for c in 0..m.n_corners() as u32 {
        let f = cf[c as usize];
        let e_next = he_edge[entry[c as usize] as usize];
        let e_prev = he_edge[entry[m.prev(c) as usize] as usize];
        idx.extend_from_slice(&[cv[c as usize], eo + e_next, fo + f, eo + e_prev]);
    }
    let face_ptr: Vec<u32> = (0..=m.n_corners() as u32).map(|c| 4 * c).collect();
    MeshMatrix::from_parts_unchecked((nv + nf + ne) as u32, &face_ptr, idx)
}

fn catmull_clark_level(m: &MeshMatrix, staged: bool) -> Subdivision {
    let (nv, nf, ne) = (m.n_verts(), m.n_faces(), m.n_edges());
    let vc = m.vertex_corners();
    let cf = m.corner_face();
    let uses = m.edge_uses();
    let (ccount, cnb) = crease_neighbours(m);
    let mut rb = RowBuilder::new(nv + nf + ne, 16 * m.n_corners());
    let mut nbrs = Vec::new();
    // Vertex points.
    for v in 0..nv {
        let vu = v as u32;
        if !m.is_referenced(v) {
            rb.add(vu, 1.0);
        } else if !crease_vertex_row(&mut rb, vu, ccount[v], cnb[v]) {
            m.neighbours_into(v, &mut nbrs);
            let n = nbrs.len() as f64;
            let n_faces = (vc.ptr[v + 1] - vc.ptr[v]) as f64;
            rb.add(vu, (n - 2.0) / n);
            for &j in &nbrs {
                rb.add(j, 1.0 / (n * n));
            }
            for k in vc.ptr[v]..vc.ptr[v + 1] {
                let f = cf[vc.corner[k as usize] as usize] as usize;
                if staged {
                    rb.add((nv + f) as u32, 1.0 / (n * n_faces));
                    continue;
                }
                let face = m.face(f);
                let w = 1.0 / (n * n_faces * face.len() as f64);
                for &u in face {
                    rb.add(u, w);
                }
            }
        }
        rb.finish_row();
    }
    // Face points.
    for f in 0..nf {
        if staged {
            rb.add((nv + f) as u32, 1.0);
            rb.finish_row();
            continue;
        }
        let face = m.face(f);
        let w = 1.0 / face.len() as f64;
        for &u in face {
            rb.add(u, w);
        }
        rb.finish_row();
    }
    // Edge points.
    let two_faces = EdgeTwoFaces::new(m);
    for (e, u) in uses.iter().enumerate() {
        let [a, b] = m.edge_vertices(e);
        if u.faces() == 2 {
            rb.add(a, 0.25);
            rb.add(b, 0.25);
            for f in two_faces.get(e) {
                if staged {
                    rb.add(nv as u32 + f, 0.25);
                    continue;
                }
                let face = m.face(f as usize);
                let w = 0.25 / face.len() as f64;
                for &x in face {
                    rb.add(x, w);
                }
            }
        } else {
            rb.add(a, 0.5);
            rb.add(b, 0.5);
        }
        rb.finish_row();
    }
    let s = rb.build(if staged { nv + nf } else { nv });
    let topology = quads_at_corners(m);
    Subdivision { s, topology }
}

/// The Loop subdivision matrix and refined topology of one level; the mesh must be all triangles.
///
/// ```
/// use gregvox::mesh::{MeshMatrix, loop_matrix, LoopBeta};
/// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
/// let sub = loop_matrix(&m, LoopBeta::Warren).unwrap();
/// assert_eq!((sub.s.n_rows, sub.topology.n_faces()), (6, 4));
/// assert!(loop_matrix(&MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap(), LoopBeta::Loop).is_err());
/// ```
pub fn loop_matrix(m: &MeshMatrix, beta: LoopBeta) -> Result<Subdivision> {
    if (0..m.n_faces()).any(|f| m.face_len(f) != 3) {
        return Err(Error::Invalid(
            "Loop subdivision needs a triangle mesh (use Catmull–Clark for polygons)".into(),
        ));
    }
    let (nv, ne) = (m.n_verts(), m.n_edges());
    let uses = m.edge_uses();
    let (ccount, cnb) = crease_neighbours(m);
    let mut rb = RowBuilder::new(nv + ne, 7 * nv + 4 * ne);
    let mut nbrs = Vec::new();
    for v in 0..nv {
        let vu = v as u32;
        if !m.is_referenced(v) {
            rb.add(vu, 1.0);
        } else if !crease_vertex_row(&mut rb, vu, ccount[v], cnb[v]) {
            m.neighbours_into(v, &mut nbrs);
            let b = beta.beta(nbrs.len());
            rb.add(vu, 1.0 - nbrs.len() as f64 * b);
            for &j in &nbrs {
                rb.add(j, b);
            }
        }
        rb.finish_row();
    }
    let two_faces = EdgeTwoFaces::new(m);
    for (e, u) in uses.iter().enumerate() {
        let [a, b] = m.edge_vertices(e);
        if u.faces() == 2 {
            rb.add(a, 0.375);
            rb.add(b, 0.375);
            for f in two_faces.get(e) {
                let opp = m
                    .face(f as usize)
                    .iter()
                    .copied()
                    .find(|&x| x != a && x != b)
                    .expect("a triangle has a third vertex");
                rb.add(opp, 0.125);
            }
        } else {
            rb.add(a, 0.5);
            rb.add(b, 0.5);
        }
        rb.finish_row();
    }
    let s = rb.build(nv);
    let entry = m.corner_entries();
    let he_edge = m.half_edge_edge();
    let cv = m.corner_vertex();
    let mut idx = Vec::with_capacity(12 * m.n_faces());
    for f in 0..m.n_faces() as u32 {
        let c0 = 3 * f;
        let (a, b, c) = (cv[c0 as usize], cv[c0 as usize + 1], cv[c0 as usize + 2]);
        let e = |corner: u32| nv as u32 + he_edge[entry[corner as usize] as usize];
        let (ab, bc, ca) = (e(c0), e(c0 + 1), e(c0 + 2));
        idx.extend_from_slice(&[a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca]);
    }
    let face_ptr: Vec<u32> = (0..=4 * m.n_faces() as u32).map(|f| 3 * f).collect();
    let topology = MeshMatrix::from_parts_unchecked((nv + ne) as u32, &face_ptr, idx);
    Ok(Subdivision { s, topology })
}

/// Several levels of one scheme, built once: per frame, refine a deforming cage with one SpMV per level.
///
/// ```
/// use gregvox::mesh::{MeshMatrix, SubdivisionStack};
/// let stack = SubdivisionStack::catmull_clark(&MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap(), 2);
/// assert_eq!(stack.levels.len(), 2);
/// ```
#[derive(Debug, Clone)]
pub struct SubdivisionStack {
    /// The levels, coarse to fine.
    pub levels: Vec<Subdivision>,
}

impl SubdivisionStack {
    /// `levels` Catmull–Clark levels of `m`.
    ///
    /// ```
    /// use gregvox::mesh::{MeshMatrix, SubdivisionStack};
    /// use glam::DVec3;
    /// let m = MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap();
    /// let stack = SubdivisionStack::catmull_clark(&m, 2);
    /// let p = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
    /// assert_eq!(stack.apply(&p).len(), stack.finest().n_verts());
    /// assert_eq!(stack.finest().n_faces(), 16);
    /// ```
    pub fn catmull_clark(m: &MeshMatrix, levels: u32) -> Self {
        let mut out: Vec<Subdivision> = Vec::new();
        for _ in 0..levels {
            let sub = catmull_clark_matrix(out.last().map(|l| &l.topology).unwrap_or(m));
            out.push(sub);
        }
        SubdivisionStack { levels: out }
    }

    /// New positions after all levels: one SpMV per level.
    ///
    /// ```
    /// use gregvox::mesh::{MeshMatrix, SubdivisionStack};
    /// use glam::DVec3;
    /// let m = MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap();
    /// let stack = SubdivisionStack::catmull_clark(&m, 1);
    /// let p = stack.apply(&[DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
    /// assert_eq!(p[4], DVec3::new(0.5, 0.5, 0.0)); // the face point follows the vertex points
    /// ```
    pub fn apply(&self, cage: &[DVec3]) -> Vec<DVec3> {
        let mut p = cage.to_vec();
        for l in &self.levels {
            p = l.s.spmv(&p);
        }
        p
    }

    /// The finest topology (panics if the stack has no level).
    ///
    /// ```
    /// use gregvox::mesh::{MeshMatrix, SubdivisionStack};
    /// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
    /// assert_eq!(SubdivisionStack::catmull_clark(&m, 1).finest().n_faces(), 3);
    /// ```
    pub fn finest(&self) -> &MeshMatrix {
        &self
            .levels
            .last()
            .expect("a stack with at least one level")
            .topology
    }
}

/// Catmull–Clark subdivision of a mesh, `levels` times (0 levels returns a copy).
///
/// ```
/// use gregvox::mesh::{Mesh, catmull_clark};
/// use glam::DVec3;
/// let p = vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
/// let m = Mesh::from_polygons(p, &[vec![0, 1, 2, 3]]).unwrap();
/// assert_eq!(catmull_clark(&m, 2).n_faces(), 16);
/// ```
pub fn catmull_clark(mesh: &Mesh, levels: u32) -> Mesh {
    let mut m = MeshMatrix::from_mesh(mesh);
    let mut p = mesh.positions.clone();
    for _ in 0..levels {
        // Staged, linear in the mesh whatever its polygon sizes: the face points first (each face's
        // average), then every new point from the old points and the face points.
        let sub = catmull_clark_level(&m, true);
        let face_points: Vec<DVec3> = (0..m.n_faces())
            .map(|f| {
                let face = m.face(f);
                face.iter().map(|&u| p[u as usize]).sum::<DVec3>() / face.len() as f64
            })
            .collect();
        p.extend(face_points);
        p = sub.s.spmv(&p);
        m = sub.topology;
    }
    m.to_mesh(p)
}

/// Loop subdivision of a triangle mesh, `levels` times.
///
/// ```
/// use gregvox::mesh::{Mesh, loop_subdivide, LoopBeta};
/// use glam::DVec3;
/// let m = Mesh::from_polygons(vec![DVec3::ZERO, DVec3::X, DVec3::Y], &[vec![0, 1, 2]]).unwrap();
/// assert_eq!(loop_subdivide(&m, 1, LoopBeta::Warren).unwrap().n_faces(), 4);
/// ```
pub fn loop_subdivide(mesh: &Mesh, levels: u32, beta: LoopBeta) -> Result<Mesh> {
    let mut m = MeshMatrix::from_mesh(mesh);
    let mut p = mesh.positions.clone();
    for _ in 0..levels {
        let sub = loop_matrix(&m, beta)?;
        p = sub.s.spmv(&p);
        m = sub.topology;
    }
    Ok(m.to_mesh(p))
}

/// Distance-free check used by tests: the weights of every row of S sum to one (affine invariance).
///
/// ```
/// use gregvox::mesh::{MeshMatrix, catmull_clark_matrix, rows_sum_to_one};
/// let m = MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap();
/// assert!(rows_sum_to_one(&catmull_clark_matrix(&m).s, 1e-14));
/// ```
pub fn rows_sum_to_one(s: &SparseMatrix<f64>, tol: f64) -> bool {
    (0..s.n_rows as usize).all(|r| (s.row(r).1.iter().sum::<f64>() - 1.0).abs() <= tol)
}
