//! ACC-2 (Loop–Schaefer–Ni–Castaño 2009) as OpenSubdiv 3.5 builds it at isolation 0: one bicubic Gregory
//! patch per cage quad, as a sparse stencil matrix over the cage vertices (docs/notes/gregory.md §3–4).
//!
//! Invariants:
//! - Patch `k` is cage face `k`; patch corner `i` is face vertex `i` (u along v0→v1, v along v0→v3), and
//!   each patch lists its 20 points in OpenSubdiv GREGORY_BASIS order (`5i + [P, Ep, Em, Fp, Fm]`).
//! - `w` holds **shared point rows** (OpenSubdiv `shareEndCapPatchPoints`), in this order:
//!   1. rows `0 .. n_verts`: the corner (limit) point P of cage vertex `v` is row `v` (an unreferenced
//!      vertex has an empty row);
//!   2. rows `n_verts + c` for every corner `c` of the quad cage (c = 4·face + slot): the edge point at the
//!      corner's vertex pointing along the half-edge `c` (toward the next vertex of the face);
//!   3. one row per boundary half-edge without twin (in corner order): the edge point at its *head* pointing
//!      back along it (no half-edge exists in that direction);
//!   4. face points, patch by patch, corner by corner: Fp then Fm, or a single row used by both when they
//!      are equal by construction (regular or copied face points).
//!
//!   Hence two patches sharing an edge reference the same rows for its 4 boundary points, and W·cage
//!   gives them bit-identical values in any precision (docs/notes/gregory.md §4.2).
//! - Every row's weights sum to 1 (affine invariance), so translating the cage translates every point.
//! - Regular faces (every corner interior valence 4, boundary with 2 faces, or a boundary corner with 1 face
//!   — OpenSubdiv's legacy sharp-corner REGULAR patches) give the Bézier form of the bicubic B-spline patch:
//!   f+ = f−, and one row per face-point pair.
//!
//! Cost: O(Σ valence²) per cage level (every corner's ring makes rows of its vertex's ring size), so a
//! vertex of valence n costs n² (the engine refuses valence above 64: `engine::cage::MAX_CAGE_VALENCE`).
//! [`GregoryStencils::from_cage`] refines uniformly to the isolation level L first: corners·4^(L−1)
//! patches, each level's matrix composed into W. Its attacking input is a deep semi-sharp crease on a large
//! cage (a 64² grid with sharpness 9.5 would make ~10⁹ patches): refused before any work past
//! [`MAX_REFINED_PATCHES`] (tests/surface_creases.rs).
use super::features::{Features, VertexTags};
use crate::error::{Error, Result};
use crate::geom::gregory::PatchF64;
use crate::mesh::{
    catmull_clark_matrix, catmull_clark_matrix_creased_hidden, Cage, Mesh, MeshMatrix,
    SparseMatrix, NONE,
};
use glam::DVec3;
use std::f64::consts::PI;

/// Which edge-point (tangent) masks irregular interior corners use (docs/notes/gregory.md §3.3, §3.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Tangents {
    /// OpenSubdiv's `CatmarkLimits` masks (λ_n / σ_n); matches OpenSubdiv's GREGORY_BASIS points.
    #[default]
    OpenSubdiv,
    /// The exact Catmull–Clark limit-tangent mask (Sdc, ACC-1): Ep = P + q/3. EV normals lie on the true
    /// limit tangent plane; boundary corners keep OpenSubdiv's masks.
    Exact,
}

/// The most patches a cage refined for semi-sharp features may make (each costs about 2 KiB of stencils;
/// 2²⁰ patches is a few GiB at the composition of the levels' matrices).
pub const MAX_REFINED_PATCHES: u64 = 1 << 20;

/// One point row under construction: (cage vertex, weight) pairs, duplicates summed later.
type Row = Vec<(u32, f64)>;

/// The ACC-2 stencil matrix of an all-quad cage: `w · cage` = every distinct control point, and
/// `patch_points[k][j]` = the row of control point `j` (GREGORY_BASIS order) of patch `k`.
///
/// ```
/// use gregvox::mesh::{parse_obj, MeshMatrix};
/// use gregvox::surface::{GregoryStencils, Tangents};
/// let cube = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
///             f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
/// let mesh = parse_obj(cube, "cube.obj").unwrap();
/// let s = GregoryStencils::new(&MeshMatrix::from_mesh(&mesh), Tangents::OpenSubdiv).unwrap();
/// assert_eq!(s.patch_points.len(), 6);
/// // 8 P rows, 24 edge-point rows, 6 × 4 × 2 face-point rows
/// assert_eq!(s.w.n_rows, 8 + 24 + 48);
/// let patches = s.patches_f64(&mesh.positions).unwrap();
/// let corner = patches[0].eval(0.0, 0.0).0;
/// assert!((corner - patches[2].eval(0.0, 0.0).0).length() < 1e-15); // same vertex 0, same P row
/// ```
#[derive(Debug, Clone)]
pub struct GregoryStencils {
    /// Shared point rows over the cage vertices (row order in the module doc).
    pub w: SparseMatrix<f64>,
    /// Per patch (= cage face), the `w` row of each of its 20 GREGORY_BASIS points.
    pub patch_points: Vec<[u32; 20]>,
    /// Per patch: true if it is a regular (B-spline) patch, false if a Gregory end cap in OpenSubdiv.
    pub regular: Vec<bool>,
    /// Per patch, its cage face: every face but the holes, in order (patch k is face k without holes).
    pub patch_face: Vec<u32>,
}

/// The stencils of an arbitrary polygon cage, with what was done to make it all-quad.
#[derive(Debug, Clone)]
pub struct CageStencils {
    /// Stencils whose columns are the *input* cage vertices (a Catmull–Clark step, if any, is folded
    /// into `w`), so `stencils.points(&input_positions)` works either way.
    pub stencils: GregoryStencils,
    /// The all-quad mesh whose faces are the patches (the input, or its Catmull–Clark refinement).
    pub quad_mesh: Mesh,
    /// `Some(message)` if the cage had non-quad faces and was refined once; print it.
    pub note: Option<String>,
    /// Catmull–Clark levels applied before building patches: 0 (an all-quad cage), 1 (non-quad faces),
    /// ⌈s⌉ for semi-sharp features of sharpness up to s.
    pub levels: u32,
}

/// Per patch corner: the CCW one-ring of its vertex (docs/notes/gregory.md §3.1) in OpenSubdiv's layout —
/// or, where infinitely sharp edges cut the ring, the span of faces between them that holds the patch face
/// (OpenSubdiv's `VSpan`, `PatchBuilder::GetIrregularPatchCornerSpans`): a span is a boundary ring.
#[derive(Debug, Clone)]
struct Ring {
    v: u32,
    /// e_0, d_0, e_1, d_1, …: interior 2n points; boundary 2F + 1 (ends with e_F).
    pts: Vec<u32>,
    boundary: bool,
    /// Number of faces around the vertex (in the span).
    faces: usize,
    /// Index of the patch face in the ring (its Ep edge is ring edge `face_in_ring`).
    face_in_ring: usize,
    /// A sharp corner (OpenSubdiv's `_sharp` span): P = v, edge points on the face's edges.
    sharp: bool,
}

impl Ring {
    /// The placeholder of a corner whose vertex no selected patch reads.
    fn unused(v: u32) -> Ring {
        Ring {
            v,
            pts: Vec::new(),
            boundary: false,
            faces: 0,
            face_in_ring: 0,
            sharp: false,
        }
    }

    fn valence(&self) -> usize {
        self.faces + self.boundary as usize
    }
    fn e(&self, j: usize) -> u32 {
        self.pts[2 * j]
    }
    fn d(&self, j: usize) -> u32 {
        self.pts[2 * j + 1]
    }
    /// OpenSubdiv's "regular" corner: not sharp, interior with 4 faces or boundary with 2.
    fn is_regular(&self) -> bool {
        (self.faces << self.boundary as usize) == 4 && !self.sharp
    }
    /// The corner cosine c_i of the face-point formula (docs/notes/gregory.md §3.4): 0 for regular corners,
    /// cos(π/F) on a boundary with F faces, cos(2π/n) inside (n = 2 gives −1).
    fn cos(&self) -> f64 {
        if self.is_regular() {
            0.0
        } else if self.boundary {
            (PI / self.faces as f64).cos()
        } else {
            (2.0 * PI / self.faces as f64).cos()
        }
    }
}

/// Twin corner of every corner (the corner whose half-edge runs the other way), or `NONE`.
pub(crate) fn twin_corners(m: &MeshMatrix) -> Vec<u32> {
    let vc = m.vertex_corners();
    let mut entry_of_corner = vec![0u32; m.n_corners()];
    for (k, &c) in vc.corner.iter().enumerate() {
        entry_of_corner[c as usize] = k as u32;
    }
    let tw = m.twins();
    (0..m.n_corners())
        .map(|c| {
            let t = tw[entry_of_corner[c] as usize];
            if t == NONE {
                NONE
            } else {
                vc.corner[t as usize]
            }
        })
        .collect()
}

/// The ring of corner `c` (vertex v = corner_vertex[c]), walking faces around v through twins; where
/// `cut`, a half-edge `h` with `sharp_he[h]` ends the walk as a boundary would (the span of the face).
fn ring_of(m: &MeshMatrix, twin: &[u32], sharp_he: &[bool], cut: bool, c: u32) -> Result<Ring> {
    let cv = m.corner_vertex();
    let v = cv[c as usize];
    let twin = |h: u32| -> u32 {
        if cut && sharp_he[h as usize] {
            NONE
        } else {
            twin[h as usize]
        }
    };
    let limit = m.n_corners() + 1;
    // Walk backward (clockwise) to the first face of a boundary fan: the previous face holds e_0 → v,
    // i.e. the twin of this corner's half-edge; the corner at v there is next(twin).
    let mut start = c;
    let mut boundary = false;
    let mut steps = 0;
    loop {
        let t = twin(start);
        if t == NONE {
            boundary = true;
            break;
        }
        let prev_face_corner = m.next(t);
        if prev_face_corner == c {
            break; // closed fan
        }
        start = prev_face_corner;
        steps += 1;
        if steps > limit {
            return Err(Error::Invalid(format!(
                "vertex {v}: its faces do not form a fan"
            )));
        }
    }
    if !boundary {
        start = c; // interior: the ring starts in the patch face
    }
    let mut pts = Vec::new();
    let mut k = start;
    let mut face_in_ring = usize::MAX;
    let mut faces = 0;
    loop {
        if k == c {
            face_in_ring = faces;
        }
        pts.push(cv[m.next(k) as usize]);
        pts.push(cv[m.next(m.next(k)) as usize]);
        faces += 1;
        let back = m.prev(k); // half-edge e_{j+1} → v
        let t = twin(back);
        if t == NONE {
            if !boundary {
                return Err(Error::Invalid(format!("vertex {v}: inconsistent fan")));
            }
            pts.push(cv[back as usize]);
            break;
        }
        if t == start && !boundary {
            break;
        }
        k = t;
        if faces > limit {
            return Err(Error::Invalid(format!(
                "vertex {v}: its faces do not form a fan"
            )));
        }
    }
    if face_in_ring == usize::MAX {
        return Err(Error::Invalid(format!(
            "vertex {v}: the patch face is not in its own fan (non-manifold vertex)"
        )));
    }
    Ok(Ring {
        v,
        pts,
        boundary,
        faces,
        face_in_ring,
        sharp: false,
    })
}

/// Limit position P (docs/notes/gregory.md §3.2, §3.6).
fn p_row(r: &Ring) -> Row {
    if r.sharp {
        // Sharp corners, and (OpenSubdiv's legacy approxSmoothCornerWithSharp) a smooth boundary corner
        // with one face, in REGULAR and GREGORY_BASIS patches alike: P = v (checked on
        // catmark_gregory_test0).
        return vec![(r.v, 1.0)];
    }
    if r.boundary {
        let last = r.pts[r.pts.len() - 1];
        return vec![(r.v, 4.0 / 6.0), (r.e(0), 1.0 / 6.0), (last, 1.0 / 6.0)];
    }
    let n = r.faces as f64;
    let mut row = vec![(r.v, n / (n + 5.0))];
    let pc = 1.0 / (n * (n + 5.0));
    for j in 0..r.faces {
        row.push((r.e(j), 4.0 * pc));
        row.push((r.d(j), pc));
    }
    row
}

/// OpenSubdiv's tangent scale σ_n = 1/(n·λ_n) (`computeCoefficient`; its table has 0 for n = 2).
fn sigma(n: usize) -> f64 {
    if n <= 2 {
        return 0.0;
    }
    let nf = n as f64;
    let c = (2.0 * PI / nf).cos();
    16.0 / nf / ((c + 5.0) + ((c + 9.0) * (c + 1.0)).sqrt())
}

fn add_scaled(dst: &mut Row, src: &Row, s: f64) {
    dst.extend(src.iter().map(|&(c, w)| (c, w * s)));
}

/// The edge point at the ring's vertex toward ring edge `j` (e_j).
fn e_row(r: &Ring, j: usize, tangents: Tangents) -> Row {
    let v = r.v;
    if r.sharp {
        // GregoryConverter::computeIrregularEdgePoints, the sharp case: along the face's edges.
        return vec![(v, 2.0 / 3.0), (r.e(j), 1.0 / 3.0)];
    }
    if r.boundary {
        let f = r.faces;
        if j == 0 || j == f {
            // boundary edge: (2v + e)/3
            return vec![(v, 2.0 / 3.0), (r.e(j), 1.0 / 3.0)];
        }
        if f == 2 {
            // regular boundary corner, interior edge j = 1 (assignRegularEdgePoints)
            return vec![
                (v, 4.0 / 9.0),
                (r.e(1), 2.0 / 9.0),
                (r.e(0), 1.0 / 9.0),
                (r.e(2), 1.0 / 9.0),
                (r.d(0), 1.0 / 18.0),
                (r.d(1), 1.0 / 18.0),
            ];
        }
        // irregular boundary corner (CatmarkLimits::ComputeBoundaryPointWeights)
        let k = f as f64;
        let theta = PI / k;
        let (c, s) = (theta.cos(), theta.sin());
        let div = 1.0 / (3.0 * k + c);
        let gamma = -4.0 * s * div;
        let alpha0 = -((1.0 + 2.0 * c) * (1.0 + c).sqrt()) * div / (1.0 - c).sqrt();
        let beta0 = s * div;
        let last = r.e(f);
        let ang = theta * j as f64;
        let (ca, sa) = (ang.cos(), ang.sin());
        let mut row = p_row(r);
        let t = sa / 3.0;
        row.push((v, gamma * t));
        row.push((r.e(0), alpha0 * t));
        row.push((r.d(0), beta0 * t));
        row.push((last, alpha0 * t));
        for i in 1..f {
            let (si, si1) = ((theta * i as f64).sin(), (theta * (i + 1) as f64).sin());
            row.push((r.e(i), 4.0 * si * div * t));
            row.push((r.d(i), (si + si1) * div * t));
        }
        row.push((r.e(0), ca / 6.0));
        row.push((last, -ca / 6.0));
        return row;
    }
    let n = r.faces;
    if n == 4 {
        // regular interior corner: B-spline → Bézier edge point
        return vec![
            (v, 4.0 / 9.0),
            (r.e(j), 2.0 / 9.0),
            (r.e((j + 1) % 4), 1.0 / 9.0),
            (r.e((j + 3) % 4), 1.0 / 9.0),
            (r.d(j), 1.0 / 18.0),
            (r.d((j + 3) % 4), 1.0 / 18.0),
        ];
    }
    let nf = n as f64;
    let mut row = p_row(r);
    match tangents {
        Tangents::OpenSubdiv => {
            // T(j) = σ/(n+5) Σ_i cos(2π(i−j)/n) [e_{i−1} + 2e_i + e_{i+1} + ½(d_{i−1} + d_i)]
            let tc = sigma(n) * 0.5 / (nf + 5.0);
            for i in 0..n {
                let w = tc * (2.0 * PI * (i as f64 - j as f64) / nf).cos();
                let (ip, inx) = ((i + n - 1) % n, (i + 1) % n);
                row.push((r.e(ip), 2.0 * w));
                row.push((r.d(ip), w));
                row.push((r.e(i), 4.0 * w));
                row.push((r.d(i), w));
                row.push((r.e(inx), 2.0 * w));
            }
        }
        Tangents::Exact => {
            // q = (2/n) Σ_i [(1 − s·cos(π/n))·cos(2π(i−j)/n)·m_i + 2s·cos((2π(i−j)+π)/n)·c_i], Ep = P + q/3,
            // m_i = (v + e_i)/2, c_i = (v + e_i + d_i + e_{i+1})/4.
            let cpn = (PI / nf).cos();
            let s = 1.0 / (4.0 + cpn * cpn).sqrt();
            for i in 0..n {
                let a =
                    (2.0 / nf) * (1.0 - s * cpn) * (2.0 * PI * (i as f64 - j as f64) / nf).cos()
                        / 3.0;
                let b = (2.0 / nf) * 2.0 * s * ((2.0 * PI * (i as f64 - j as f64) + PI) / nf).cos()
                    / 3.0;
                row.push((v, a * 0.5 + b * 0.25));
                row.push((r.e(i), a * 0.5 + b * 0.25));
                row.push((r.d(i), b * 0.25));
                row.push((r.e((i + 1) % n), b * 0.25));
            }
        }
    }
    row
}

/// Sums duplicate columns and drops exact zeros, sorted by column (deterministic row content).
fn compact(mut row: Row) -> Row {
    // A stable sort keeps each column's terms in input order, so the sums are the ones a per-column
    // accumulator in input order gives (bit for bit).
    row.sort_by_key(|&(c, _)| c);
    let mut out: Row = Vec::with_capacity(row.len());
    for (c, w) in row {
        match out.last_mut() {
            Some((last, sum)) if *last == c => *sum += w,
            _ => out.push((c, w)),
        }
    }
    out.retain(|&(_, w)| w != 0.0);
    out
}

impl GregoryStencils {
    /// Builds the stencils of an all-quad, manifold, consistently oriented cage.
    ///
    /// Errors (`Error::Invalid`): no faces, a non-quad face, a non-manifold edge or vertex, inconsistent
    /// orientation.
    ///
    /// ```
    /// use gregvox::mesh::MeshMatrix;
    /// use gregvox::surface::{GregoryStencils, Tangents};
    /// let tri = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
    /// assert!(GregoryStencils::new(&tri, Tangents::OpenSubdiv).is_err()); // not a quad
    /// let quad = MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap();
    /// let s = GregoryStencils::new(&quad, Tangents::OpenSubdiv).unwrap();
    /// assert!(s.regular[0]); // one quad, four 1-face corners: a (sharp-cornered) B-spline patch
    /// ```
    pub fn new(m: &MeshMatrix, tangents: Tangents) -> Result<Self> {
        Self::with_features(m, &Features::none(m), tangents)
    }

    /// [`GregoryStencils::new`] with infinitely sharp creases and corners and holes ([`Features`]): as
    /// OpenSubdiv builds them at isolation 0 with `useInfSharpPatch` — sharp edges cut each vertex's ring
    /// into spans that follow the boundary rules, sharp corners interpolate their vertex, faces regular
    /// between sharp edges are B-spline patches, and hole faces get no patch (their stencils still shape
    /// the neighbours).
    ///
    /// ```
    /// use gregvox::mesh::{parse_obj_cage, MeshMatrix};
    /// use gregvox::surface::{Features, GregoryStencils, Tangents};
    /// let cube = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
    ///             f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\nt hole 1/0/0 1\n\
    ///             t corner 1/1/0 6 10\n";
    /// let cage = parse_obj_cage(cube, "cube.obj").unwrap();
    /// let m = MeshMatrix::from_mesh(&cage.mesh);
    /// let f = Features::from_tags(&m, &cage.tags).unwrap();
    /// let s = GregoryStencils::with_features(&m, &f, Tangents::OpenSubdiv).unwrap();
    /// assert_eq!(s.patch_face, [0, 2, 3, 4, 5]); // face 1 is a hole
    /// let p = s.points(&cage.mesh.positions).unwrap();
    /// assert_eq!(p[6], cage.mesh.positions[6]); // the sharp corner interpolates its vertex
    /// ```
    pub fn with_features(m: &MeshMatrix, features: &Features, tangents: Tangents) -> Result<Self> {
        Self::build(m, features, tangents, None)
    }

    /// [`GregoryStencils::with_features`] for the faces of `m` where `select` is true only (quads, not
    /// holes), in face order: the level of a feature-adaptive refinement ([`crate::surface::adaptive`]),
    /// whose mesh is a part of the refined cage with an incomplete fringe. Only the rings of the selected
    /// faces' vertices are walked (they must be complete in `m`), so the fringe is never read and the
    /// whole-cage checks (manifold, orientation) are the caller's, made on the cage. Rows of unused
    /// vertices and corners are empty.
    pub(crate) fn with_features_on(
        m: &MeshMatrix,
        features: &Features,
        tangents: Tangents,
        select: &[bool],
    ) -> Result<Self> {
        Self::build(m, features, tangents, Some(select))
    }

    fn build(
        m: &MeshMatrix,
        features: &Features,
        tangents: Tangents,
        select: Option<&[bool]>,
    ) -> Result<Self> {
        let nf = m.n_faces();
        if nf == 0 {
            return Err(Error::Invalid(
                "Gregory stencils: the cage has no faces".into(),
            ));
        }
        let selected = |f: usize| select.is_none_or(|s| s[f]);
        if let Some(f) = (0..nf).find(|&f| selected(f) && m.face_len(f) != 4) {
            return Err(Error::Invalid(format!(
                "Gregory stencils: face {f} has {} vertices; ACC-2 needs an all-quad cage \
                 (use GregoryStencils::from_mesh to refine once)",
                m.face_len(f)
            )));
        }
        if select.is_none() {
            check_manifold_and_oriented(m)?;
        }
        let nv = m.n_verts();
        let nc = m.n_corners();
        features.check(m)?;
        let twin = twin_corners(m);
        let tags = VertexTags::new(m, &twin, features);
        let cv = m.corner_vertex();
        // The vertices whose rings the selected patches read (all of them without a selection).
        let mut needed = vec![select.is_none(); nv];
        if let Some(s) = select {
            for f in (0..nf).filter(|&f| s[f]) {
                for &v in m.face(f) {
                    needed[v as usize] = true;
                }
            }
        }
        let rings: Vec<Ring> = (0..nc as u32)
            .map(|c| {
                let v = cv[c as usize] as usize;
                if !needed[v] {
                    return Ok(Ring::unused(v as u32));
                }
                let mut r = ring_of(m, &twin, &tags.sharp_he, tags.cut(v), c)?;
                r.sharp = tags.span_is_sharp(v, r.faces);
                Ok(r)
            })
            .collect::<Result<_>>()?;
        // Face type: OpenSubdiv's PatchBuilder::IsPatchRegular at level 0 (B-spline patches between sharp
        // edges, and its legacy sharp-corner REGULAR patches).
        let regular: Vec<bool> = (0..nf)
            .map(|f| {
                selected(f) && {
                    let span = std::array::from_fn(|i| rings[m.face_start(f) as usize + i].faces);
                    tags.face_is_regular(m, &twin, f, span)
                }
            })
            .collect();
        // Boundary half-edges get an extra row for the point at their head pointing back.
        let mut back_row = vec![NONE; nc];
        let mut n_back = 0u32;
        for c in 0..nc {
            if twin[c] == NONE {
                back_row[c] = (nv + nc) as u32 + n_back;
                n_back += 1;
            }
        }
        let mut rows: Vec<Row> = vec![Vec::new(); nv + nc + n_back as usize];
        // P rows, one per vertex (from any of its corners).
        let mut p_done = vec![false; nv];
        for r in rings.iter().filter(|r| needed[r.v as usize]) {
            if !p_done[r.v as usize] {
                p_done[r.v as usize] = true;
                rows[r.v as usize] = p_row(r);
            }
        }
        // A vertex no face uses (exported OBJ files often carry some) takes part in no patch: its row is
        // the vertex itself, so every row stays an affine combination of the cage and the point is inert.
        for (v, done) in p_done.iter().enumerate() {
            if !done && select.is_none() {
                rows[v] = vec![(v as u32, 1.0)];
            }
        }
        // Edge rows: Ep of corner c = ring edge face_in_ring; the back row of a boundary half-edge
        // c = (a → b) is b's point toward a = the Em of b's corner in the same face (next(c)).
        for c in 0..nc {
            let r = &rings[c];
            if needed[r.v as usize] {
                rows[nv + c] = e_row(r, r.face_in_ring, tangents);
            }
            if back_row[c] != NONE {
                let nb = m.next(c as u32) as usize;
                let rb = &rings[nb];
                if needed[rb.v as usize] {
                    rows[back_row[c] as usize] = e_row(rb, em_edge(rb), tangents);
                }
            }
        }
        let ep_of = |c: usize| (nv + c) as u32;
        let em_of = |c: usize| -> u32 {
            // the point at corner c's vertex toward prev(c)'s vertex: Ep row of the twin of prev(c)
            let p = m.prev(c as u32) as usize;
            if twin[p] != NONE {
                (nv + twin[p] as usize) as u32
            } else {
                back_row[p]
            }
        };
        let mut patch_points = Vec::with_capacity(nf);
        for (f, &reg) in regular.iter().enumerate() {
            if !selected(f) {
                // Keeps patch k at face k; the unselected entries are dropped below.
                patch_points.push([0u32; 20]);
                continue;
            }
            let mut pp = [0u32; 20];
            let base = m.face_start(f) as usize;
            for i in 0..4 {
                let c = base + i;
                pp[5 * i] = rings[c].v;
                pp[5 * i + 1] = ep_of(c);
                pp[5 * i + 2] = em_of(c);
            }
            // Face points (GregoryConverter::computeIrregularFacePoints / assignRegularFacePoints).
            for i in 0..4 {
                let c = base + i;
                let (cn, cp) = (base + (i + 1) % 4, base + (i + 3) % 4);
                let r = &rings[c];
                let (rn, rp) = (&rings[cn], &rings[cp]);
                let (mut fp_reg, mut fm_reg) = if reg {
                    (true, true)
                } else {
                    (
                        r.is_regular() && rn.is_regular(),
                        r.is_regular() && rp.is_regular(),
                    )
                };
                let (mut fp_copy, mut fm_copy) = (false, false);
                if r.boundary && !reg {
                    if r.faces > 1 {
                        if r.face_in_ring == 0 {
                            fp_reg = fm_reg;
                            fp_copy = !fp_reg;
                        }
                        if r.face_in_ring == r.faces - 1 {
                            fm_reg = fp_reg;
                            fm_copy = !fm_reg;
                        }
                    } else {
                        fp_reg = true;
                        fm_reg = true;
                    }
                }
                let regular_fp = || -> Row {
                    vec![
                        (cv[c], 4.0 / 9.0),
                        (cv[cp], 2.0 / 9.0),
                        (cv[cn], 2.0 / 9.0),
                        (cv[base + (i + 2) % 4], 1.0 / 9.0),
                    ]
                };
                let irregular = |plus: bool| -> Row {
                    // f = c_far/3·P + (3 − 2c_near − c_far)/3·E_near + 2c_near/3·E_far ± R/3
                    let (far, e_near, e_far, edge, sign) = if plus {
                        (
                            rn,
                            &rows[ep_of(c) as usize],
                            &rows[em_of(cn) as usize],
                            r.face_in_ring,
                            1.0,
                        )
                    } else {
                        (
                            rp,
                            &rows[em_of(c) as usize],
                            &rows[ep_of(cp) as usize],
                            (r.face_in_ring + 1) % r.valence(),
                            -1.0,
                        )
                    };
                    let (cn_, cf) = (r.cos(), far.cos());
                    let mut row = Row::new();
                    add_scaled(&mut row, &rows[r.v as usize], cf / 3.0);
                    add_scaled(&mut row, e_near, (3.0 - 2.0 * cn_ - cf) / 3.0);
                    add_scaled(&mut row, e_far, 2.0 * cn_ / 3.0);
                    let val = r.valence();
                    let (ep_, en_) = ((edge + val - 1) % val, (edge + 1) % val);
                    row.push((r.e(ep_), -sign / 9.0));
                    row.push((r.d(ep_), -sign / 18.0));
                    row.push((r.d(edge), sign / 18.0));
                    row.push((r.e(en_), sign / 9.0));
                    row
                };
                let fp = if fp_reg {
                    Some(regular_fp())
                } else if !fp_copy {
                    Some(irregular(true))
                } else {
                    None
                };
                let fm = if fm_reg {
                    Some(regular_fp())
                } else if !fm_copy {
                    Some(irregular(false))
                } else {
                    None
                };
                // One row when the pair is equal by construction (regular pair or a copy).
                let (fp_idx, fm_idx) = match (fp, fm) {
                    (Some(a), Some(b)) => {
                        let ia = rows.len() as u32;
                        if fp_reg && fm_reg {
                            rows.push(a);
                            (ia, ia)
                        } else {
                            rows.push(a);
                            rows.push(b);
                            (ia, ia + 1)
                        }
                    }
                    (Some(a), None) | (None, Some(a)) => {
                        let ia = rows.len() as u32;
                        rows.push(a);
                        (ia, ia)
                    }
                    (None, None) => {
                        return Err(Error::Invalid(format!(
                            "Gregory stencils: face {f} corner {i}: both face points copied (degenerate boundary)"
                        )))
                    }
                };
                pp[5 * i + 3] = fp_idx;
                pp[5 * i + 4] = fm_idx;
            }
            patch_points.push(pp);
        }
        // Straight into CSR, each row freed as it is copied: the rows, a triplet list and its sorted copy
        // once lived at the same time (a regular 187 k-quad cage peaked at 636 MB).
        drop(rings);
        let n_rows = rows.len() as u32;
        let nnz: usize = rows.iter().map(Vec::len).sum();
        let mut row_ptr = Vec::with_capacity(rows.len() + 1);
        let (mut col, mut val) = (Vec::with_capacity(nnz), Vec::with_capacity(nnz));
        row_ptr.push(0u32);
        for row in rows {
            for (c, w) in compact(row) {
                col.push(c);
                val.push(w);
            }
            row_ptr.push(col.len() as u32);
        }
        col.shrink_to_fit();
        val.shrink_to_fit();
        let w = SparseMatrix {
            n_rows,
            n_cols: nv as u32,
            row_ptr,
            col,
            val,
        };
        // Holes: no patch, though their rings shaped every neighbour above.
        let patch_face: Vec<u32> = (0..nf as u32)
            .filter(|&f| !features.hole[f as usize] && selected(f as usize))
            .collect();
        let (patch_points, regular) = if patch_face.len() == nf {
            (patch_points, regular)
        } else {
            patch_face
                .iter()
                .map(|&f| (patch_points[f as usize], regular[f as usize]))
                .unzip()
        };
        Ok(GregoryStencils {
            w,
            patch_points,
            regular,
            patch_face,
        })
    }

    /// Stencils for any polygon cage: all-quad cages directly; otherwise one Catmull–Clark step first,
    /// folded into `w` (W·S), and a note saying so.
    ///
    /// ```
    /// use gregvox::mesh::parse_obj;
    /// use gregvox::surface::{GregoryStencils, Tangents};
    /// let tet = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n", "tet.obj").unwrap();
    /// let cs = GregoryStencils::from_mesh(&tet, Tangents::OpenSubdiv).unwrap();
    /// assert!(cs.note.is_some());
    /// assert_eq!(cs.stencils.patch_points.len(), 12); // 4 triangles → 12 quads
    /// assert_eq!(cs.stencils.w.n_cols, 4); // columns are the input cage vertices
    /// let p = cs.stencils.points(&tet.positions).unwrap();
    /// assert!(p.iter().all(|x| x.is_finite()));
    /// ```
    pub fn from_mesh(mesh: &Mesh, tangents: Tangents) -> Result<CageStencils> {
        if mesh.n_faces() == 0 {
            return Err(Error::Invalid(
                "Gregory stencils: the cage has no faces".into(),
            ));
        }
        let m = MeshMatrix::from_mesh(mesh);
        if (0..m.n_faces()).all(|f| m.face_len(f) == 4) {
            let stencils = GregoryStencils::new(&m, tangents)?;
            return Ok(CageStencils {
                stencils,
                quad_mesh: mesh.clone(),
                note: None,
                levels: 0,
            });
        }
        if let Some(msg) = manifold_error(&m) {
            return Err(Error::Invalid(msg));
        }
        let n_nonquad = (0..m.n_faces()).filter(|&f| m.face_len(f) != 4).count();
        let sub = catmull_clark_matrix(&m);
        let mut stencils = GregoryStencils::new(&sub.topology, tangents)?;
        stencils.w = stencils.w.matmul(&sub.s);
        let quad_mesh = sub.topology.to_mesh(sub.s.spmv(&mesh.positions));
        let note = format!(
            "cage has {n_nonquad} non-quad faces: refined once with Catmull–Clark ({} → {} quads)",
            m.n_faces(),
            sub.topology.n_faces()
        );
        Ok(CageStencils {
            stencils,
            quad_mesh,
            note: Some(note),
            levels: 1,
        })
    }

    /// Stencils for a tagged cage ([`Cage`]): infinitely sharp creases and corners, holes and the boundary
    /// rule ([`Features`]); a non-quad cage is refined once by Catmull–Clark with the sharp rules
    /// ([`crate::mesh::catmull_clark_matrix_creased`]), its features carried to the refined cage (the halves
    /// of sharp edges sharp, sharp vertices kept, the children of holes holes) as OpenSubdiv's uniform
    /// refinement carries them. An untagged cage gives exactly [`GregoryStencils::from_mesh`]'s stencils.
    ///
    /// Semi-sharp creases and corners (0 < s < 10, uniform or Chaikin creasing) refine the whole cage
    /// ⌈s⌉ times with Sdc's crease rules ([`crate::mesh::catmull_clark_matrix_creased`]) before the
    /// patches are built, folded into `w` like the single step of a non-quad cage.
    ///
    /// Errors: what [`GregoryStencils::from_mesh`] refuses, and any tag gregvox cannot honour yet
    /// ([`crate::mesh::SubdivTags::unsupported`]), named.
    ///
    /// ```
    /// use gregvox::mesh::parse_obj_cage;
    /// use gregvox::surface::{GregoryStencils, Tangents};
    /// let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\n\
    ///             f 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\nf 1 4 3 2\nt crease 2/1/0 0 4 10\n";
    /// let cage = parse_obj_cage(text, "pyramid.obj").unwrap();
    /// let cs = GregoryStencils::from_cage(&cage, Tangents::OpenSubdiv).unwrap();
    /// assert_eq!(cs.stencils.patch_points.len(), 16); // refined once: 4 triangles → 12 quads, 1 quad → 4
    /// // A semi-sharp crease (2.5) is exact after ⌈2.5⌉ = 3 levels.
    /// let semi = parse_obj_cage(&text.replace(" 10\n", " 2.5\n"), "semi.obj").unwrap();
    /// let cs = GregoryStencils::from_cage(&semi, Tangents::OpenSubdiv).unwrap();
    /// assert_eq!((cs.levels, cs.stencils.patch_points.len()), (3, 16 * 16));
    /// ```
    pub fn from_cage(cage: &Cage, tangents: Tangents) -> Result<CageStencils> {
        let mesh = &cage.mesh;
        let (m, features) = cage_features(cage)?;
        let notes = cage.tags.notes();
        let with_notes = |mut cs: CageStencils| {
            if !notes.is_empty() {
                let mut all: Vec<String> = cs.note.take().into_iter().collect();
                all.extend(notes.iter().cloned());
                cs.note = Some(all.join("; "));
            }
            cs
        };
        let Some(Isolation {
            levels,
            least,
            semi,
        }) = isolation(cage, &m, &features)?
        else {
            return Ok(with_notes(Self::from_mesh(mesh, tangents)?));
        };
        if levels == 0 {
            let stencils = GregoryStencils::with_features(&m, &features, tangents)?;
            return Ok(with_notes(CageStencils {
                stencils,
                quad_mesh: mesh.clone(),
                note: None,
                levels: 0,
            }));
        }
        // Uniform refinement multiplies the patches by 4 per level: refuse before allocating what a deep
        // semi-sharp feature on a large cage would need.
        let patches = uniform_patches(&m, levels);
        if patches > MAX_REFINED_PATCHES {
            let tag = cage
                .tags
                .creases
                .iter()
                .filter(|c| c.sharpness == semi)
                .map(|c| format!("t crease {} {} {}", c.a, c.b, c.sharpness))
                .chain(
                    cage.tags
                        .corners
                        .iter()
                        .filter(|c| c.sharpness == semi)
                        .map(|c| format!("t corner {} {}", c.vertex, c.sharpness)),
                )
                .next()
                .unwrap_or_default();
            return Err(Error::Invalid(format!(
                "{tag}: semi-sharp features need {levels} levels of refinement; gregvox tessellates and draws \
                 a uniform refinement of the whole cage, which would make {patches} patches, past the limit \
                 of {MAX_REFINED_PATCHES} (`gregvox evaluate` and LimitEvaluator refine feature-adaptively, \
                 as OpenSubdiv does, and `gregvox tessellate` grids its ptex faces over those patches): \
                 lower the sharpness or split the cage"
            )));
        }
        if let Some(msg) = manifold_error(&m) {
            return Err(Error::Invalid(msg));
        }
        let n_nonquad = (0..m.n_faces()).filter(|&f| m.face_len(f) != 4).count();
        let (mut es, mut vs) = features.sharpness(&m, &cage.tags);
        let mut hole = features.hole.clone();
        let mut level_m = m;
        let mut total: Option<SparseMatrix<f64>> = None;
        let mut hidden = cage.tags.hidden_semi_sharp.clone();
        for _ in 0..levels {
            let c =
                catmull_clark_matrix_creased_hidden(&level_m, &es, &vs, cage.tags.chaikin, &hidden);
            hidden = c.hidden;
            // Refined face k is the quad at corner k of the level above; a hole if its face is.
            hole = level_m
                .corner_face()
                .iter()
                .map(|&f| hole[f as usize])
                .collect();
            total = Some(match total {
                None => c.sub.s,
                Some(t) => c.sub.s.matmul(&t),
            });
            level_m = c.sub.topology;
            es = c.edge_sharpness;
            vs = c.vertex_sharpness;
        }
        let total = total.expect("levels ≥ 1");
        let refined = Features {
            sharp_edge: es
                .iter()
                .map(|&s| s >= crate::mesh::SHARPNESS_INFINITE)
                .collect(),
            sharp_vertex: vs
                .iter()
                .map(|&s| s >= crate::mesh::SHARPNESS_INFINITE)
                .collect(),
            hole,
        };
        let mut stencils = GregoryStencils::with_features(&level_m, &refined, tangents)?;
        stencils.w = stencils.w.matmul(&total);
        let quad_mesh = level_m.to_mesh(total.spmv(&mesh.positions));
        let mut why = Vec::new();
        if n_nonquad > 0 {
            why.push(format!("{n_nonquad} non-quad faces"));
        }
        if semi > 0.0 {
            why.push(format!("semi-sharp features (sharpness up to {semi})"));
        }
        if levels > least {
            why.push(format!("an isolation level of {levels} (--isolation)"));
        }
        let note = format!(
            "cage has {}: refined {} with Catmull–Clark ({} → {} quads)",
            why.join(" and "),
            if levels == 1 {
                "once".to_string()
            } else {
                format!("{levels} times")
            },
            mesh.n_faces(),
            level_m.n_faces()
        );
        Ok(with_notes(CageStencils {
            stencils,
            quad_mesh,
            note: Some(note),
            levels,
        }))
    }

    /// `w` in f32 (the GPU upload; weights rounded once from f64).
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// # use gregvox::surface::{GregoryStencils, Tangents};
    /// let s = GregoryStencils::new(&MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap(), Tangents::OpenSubdiv).unwrap();
    /// assert_eq!(s.w_f32().col, s.w.col);
    /// ```
    pub fn w_f32(&self) -> SparseMatrix<f32> {
        self.w.to_f32()
    }

    /// All distinct control points, `w · cage`. Errors if `cage` has the wrong length or a non-finite
    /// coordinate.
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// # use gregvox::surface::{GregoryStencils, Tangents};
    /// # use glam::DVec3;
    /// let s = GregoryStencils::new(&MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap(), Tangents::OpenSubdiv).unwrap();
    /// let cage = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
    /// assert_eq!(s.points(&cage).unwrap()[0], DVec3::ZERO); // sharp corner: P = v
    /// assert!(s.points(&cage[..3]).is_err());
    /// ```
    pub fn points(&self, cage: &[DVec3]) -> Result<Vec<DVec3>> {
        if cage.len() != self.w.n_cols as usize {
            return Err(Error::Invalid(format!(
                "Gregory stencils: cage has {} vertices, the stencils expect {}",
                cage.len(),
                self.w.n_cols
            )));
        }
        if let Some(i) = cage.iter().position(|p| !p.is_finite()) {
            return Err(Error::Invalid(format!(
                "Gregory stencils: cage vertex {i} is not finite"
            )));
        }
        Ok(self.w.spmv(cage))
    }

    /// The f64 patches, one per quad, gathered from [`GregoryStencils::points`].
    ///
    /// ```
    /// # use gregvox::mesh::MeshMatrix;
    /// # use gregvox::surface::{GregoryStencils, Tangents};
    /// # use glam::DVec3;
    /// let s = GregoryStencils::new(&MeshMatrix::new(4, &[0, 4], vec![0, 1, 2, 3]).unwrap(), Tangents::OpenSubdiv).unwrap();
    /// let cage = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
    /// let g = s.patches_f64(&cage).unwrap();
    /// assert!((g[0].eval(0.5, 0.5).0 - DVec3::new(0.5, 0.5, 0.0)).length() < 1e-15);
    /// ```
    pub fn patches_f64(&self, cage: &[DVec3]) -> Result<Vec<PatchF64>> {
        let pts = self.points(cage)?;
        Ok(gather_patches(&self.patch_points, &pts))
    }
}

/// Patches from shared points and the per-patch row table.
///
/// ```
/// use gregvox::surface::gather_patches;
/// use glam::DVec3;
/// let pts = vec![DVec3::ONE];
/// assert_eq!(gather_patches(&[[0; 20]], &pts)[0].cv[19], DVec3::ONE);
/// ```
pub fn gather_patches(patch_points: &[[u32; 20]], pts: &[DVec3]) -> Vec<PatchF64> {
    patch_points
        .iter()
        .map(|pp| PatchF64 {
            cv: std::array::from_fn(|j| pts[pp[j] as usize]),
        })
        .collect()
}

/// The matrix and infinitely sharp features of a tagged cage, after the checks every stencil builder makes
/// first: tags gregvox cannot honour, a cage with no faces.
pub(crate) fn cage_features(cage: &Cage) -> Result<(MeshMatrix, Features)> {
    if let Some(msg) = cage.tags.unsupported(&cage.mesh) {
        return Err(Error::Invalid(msg));
    }
    if cage.mesh.n_faces() == 0 {
        return Err(Error::Invalid(
            "Gregory stencils: the cage has no faces".into(),
        ));
    }
    let m = MeshMatrix::from_mesh(&cage.mesh);
    let features = Features::from_tags(&m, &cage.tags)?;
    Ok((m, features))
}

/// Errors unless `m` is a manifold, consistently oriented cage (naming the first offending edge).
pub(crate) fn check_manifold_and_oriented(m: &MeshMatrix) -> Result<()> {
    if let Some(msg) = manifold_error(m) {
        return Err(Error::Invalid(msg));
    }
    let rep = m.report();
    if rep.inconsistent_edges > 0 || rep.second_writes > 0 {
        return Err(Error::Invalid(format!(
            "Gregory stencils: the cage is not consistently oriented ({} edges used twice in the same direction)",
            rep.inconsistent_edges
        )));
    }
    Ok(())
}

/// How many patches [`GregoryStencils::from_cage`]'s uniform refinement makes of `cage` (checked before any
/// refinement: past [`MAX_REFINED_PATCHES`] it refuses). Errors: the tags' errors, as `from_cage`.
pub fn uniform_patch_count(cage: &Cage) -> Result<u64> {
    let (m, features) = cage_features(cage)?;
    let all_quads = (0..m.n_faces()).all(|f| m.face_len(f) == 4);
    let levels = isolation(cage, &m, &features)?.map_or(!all_quads as u32, |i| i.levels);
    Ok(uniform_patches(&m, levels))
}

/// The quads of `m` refined uniformly `levels` times (every face splits into its corners' quads).
fn uniform_patches(m: &MeshMatrix, levels: u32) -> u64 {
    if levels == 0 {
        m.n_faces() as u64
    } else {
        (m.n_corners() as u64) << (2 * (levels.min(31) - 1))
    }
}

/// How deep a tagged cage is refined before its patches are built.
pub(crate) struct Isolation {
    /// The isolation level L.
    pub levels: u32,
    /// The least level the cage needs (⌈largest semi-sharp sharpness⌉, 1 for non-quad faces).
    pub least: u32,
    /// The largest semi-sharp sharpness (0 without semi-sharp features).
    pub semi: f32,
}

/// The isolation level of `cage` (`m` its matrix, `features` its infinitely sharp features): `None` when
/// the cage needs nothing but the untagged path ([`GregoryStencils::from_mesh`]). Errors when every face is
/// a hole, or `--isolation` asks for fewer levels than the cage needs.
pub(crate) fn isolation(
    cage: &Cage,
    m: &MeshMatrix,
    features: &Features,
) -> Result<Option<Isolation>> {
    // Semi-sharp features are exact after ⌈s⌉ levels (OpenSubdiv isolates them to that level; its
    // B-spline patches elsewhere are the same limit surface at any level).
    let semi = cage
        .tags
        .creases
        .iter()
        .map(|c| c.sharpness)
        .chain(cage.tags.corners.iter().map(|c| c.sharpness))
        .filter(|&s| s > 0.0 && s < crate::mesh::SHARPNESS_INFINITE)
        .fold(0.0f32, f32::max);
    if features.is_none() && semi == 0.0 && cage.tags.isolation.unwrap_or(0) == 0 {
        return Ok(None);
    }
    if features.hole.iter().all(|&h| h) {
        return Err(Error::Invalid(format!(
            "Gregory stencils: every face of the cage is a hole ({} tagged{})",
            cage.tags.holes.len(),
            if cage.tags.boundary == crate::mesh::BoundaryInterpolation::None {
                ", and `t interpolateboundary 0` drops the faces at unsharpened boundaries"
            } else {
                ""
            }
        )));
    }
    let all_quads = (0..m.n_faces()).all(|f| m.face_len(f) == 4);
    let least = (semi.ceil() as u32).max(!all_quads as u32);
    let levels = match cage.tags.isolation {
        None => least,
        Some(l) if l >= least => l,
        Some(l) => {
            return Err(Error::Invalid(format!(
                "--isolation {l} is below the {least} level(s) this cage needs ({})",
                if semi > 0.0 {
                    format!("semi-sharp features up to sharpness {semi} are exact after ⌈s⌉ levels")
                } else {
                    "non-quad faces need one Catmull–Clark level".to_string()
                }
            )))
        }
    };
    Ok(Some(Isolation {
        levels,
        least,
        semi,
    }))
}

/// Why `m` is not a manifold, naming the first non-manifold edge and vertex (`None` if it is one).
/// OpenSubdiv accepts such cages by making the edges infinitely sharp; gregvox refuses them.
pub(crate) fn manifold_error(m: &MeshMatrix) -> Option<String> {
    let uses = m.edge_uses();
    let bad_edges: Vec<usize> = (0..uses.len()).filter(|&e| uses[e].faces() > 2).collect();
    let bad_verts = m.non_manifold_vertices();
    if bad_edges.is_empty() && bad_verts.is_empty() {
        return None;
    }
    let mut first = Vec::new();
    if let Some(&e) = bad_edges.first() {
        let [a, b] = m.edge_vertices(e);
        first.push(format!(
            "edge {a}–{b} (0-based vertices) is shared by {} faces",
            uses[e].faces()
        ));
    }
    if let Some(&v) = bad_verts.first() {
        first.push(format!("vertex {v} joins separate fans of faces"));
    }
    Some(format!(
        "Gregory stencils: the cage is not a manifold ({} non-manifold edges, {} non-manifold vertices; {}); \
         OpenSubdiv would make such edges infinitely sharp, gregvox refuses them",
        bad_edges.len(),
        bad_verts.len(),
        first.join("; ")
    ))
}

/// The ring edge of the Em point of a corner (toward the previous face vertex).
fn em_edge(r: &Ring) -> usize {
    (r.face_in_ring + 1) % r.valence()
}
