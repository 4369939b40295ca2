//! Face centroids, face normals and vertex normals as mapped products with M.
//!
//! Conventions: the unnormalised face normal is `N_f = Σ_k (p_k − p_0) × (p_{k+1} − p_0)` over the fan of
//! the face (for a triangle exactly `e₁₂ × e₁₃`, |N_f| = 2·area; for a planar polygon 2·area too). Vertex
//! normals are gathers over Mᵀ in corner order (`N_v = B·w_f N̂_f`), then normalised. Unreferenced vertices
//! and vertices whose weighted sum is exactly zero get a zero normal, never NaN, so nothing non-finite
//! reaches a GPU buffer. AREA weighting equals libigl's default `per_vertex_normals`; ANGLE equals libigl
//! ANGLE and `trimesh.vertex_normals`.
use super::matrix::MeshMatrix;
use glam::DVec3;

/// How face normals are weighted when summed into vertex normals.
///
/// ```
/// assert_eq!(gregvox::mesh::NormalWeighting::default(), gregvox::mesh::NormalWeighting::Area);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NormalWeighting {
    /// Weight by face area (sum of unnormalised normals); libigl's default. The project default.
    #[default]
    Area,
    /// Every incident face counts once (sum of unit normals).
    Uniform,
    /// Weight by the corner angle at the vertex (libigl ANGLE, trimesh).
    Angle,
}

/// Unnormalised face normals (length = 2·area for planar faces).
///
/// ```
/// use gregvox::mesh::{MeshMatrix, face_normals_unnormalized};
/// use glam::DVec3;
/// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
/// let n = face_normals_unnormalized(&m, &[DVec3::ZERO, DVec3::X * 2.0, DVec3::Y]);
/// assert_eq!(n, vec![DVec3::new(0.0, 0.0, 2.0)]);
/// ```
pub fn face_normals_unnormalized(m: &MeshMatrix, p: &[DVec3]) -> Vec<DVec3> {
    (0..m.n_faces())
        .map(|f| {
            let face = m.face(f);
            let p0 = p[face[0] as usize];
            let mut n = DVec3::ZERO;
            for w in face[1..].windows(2) {
                n += (p[w[0] as usize] - p0).cross(p[w[1] as usize] - p0);
            }
            n
        })
        .collect()
}

/// Unit face normals; a degenerate face gets `(0, 0, 0)` (libigl's `per_face_normals` default Z).
///
/// ```
/// use gregvox::mesh::{MeshMatrix, face_normals};
/// use glam::DVec3;
/// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
/// assert_eq!(face_normals(&m, &[DVec3::ZERO, DVec3::X, DVec3::Y]), vec![DVec3::Z]);
/// assert_eq!(face_normals(&m, &[DVec3::ZERO, DVec3::X, DVec3::X]), vec![DVec3::ZERO]);
/// ```
pub fn face_normals(m: &MeshMatrix, p: &[DVec3]) -> Vec<DVec3> {
    face_normals_unnormalized(m, p)
        .into_iter()
        .map(|n| n.try_normalize().unwrap_or(DVec3::ZERO))
        .collect()
}

/// Face centroids as the vertex average `D_F⁻¹ Bᵀ P` (= `igl::barycenter` for triangles).
///
/// ```
/// use gregvox::mesh::{MeshMatrix, face_centroids};
/// use glam::DVec3;
/// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
/// let c = face_centroids(&m, &[DVec3::ZERO, DVec3::X * 3.0, DVec3::Y * 3.0]);
/// assert_eq!(c, vec![DVec3::new(1.0, 1.0, 0.0)]);
/// ```
pub fn face_centroids(m: &MeshMatrix, p: &[DVec3]) -> Vec<DVec3> {
    (0..m.n_faces())
        .map(|f| {
            let face = m.face(f);
            let mut s = DVec3::ZERO;
            for &v in face {
                s += p[v as usize];
            }
            s / face.len() as f64
        })
        .collect()
}

/// Per-corner weights times face normals, then a gather per vertex over Mᵀ and a normalisation.
///
/// ```
/// use gregvox::mesh::{MeshMatrix, vertex_normals, NormalWeighting};
/// use glam::DVec3;
/// // two triangles folded along the x axis; vertex 3 is unreferenced
/// let p = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::ONE, DVec3::new(0.0, -1.0, 1.0)];
/// let m = MeshMatrix::new(5, &[0, 3, 6], vec![0, 1, 2, 1, 0, 4]).unwrap();
/// let n = vertex_normals(&m, &p, NormalWeighting::Area);
/// assert!((n[0].length() - 1.0).abs() < 1e-15);
/// assert_eq!(n[3], DVec3::ZERO);
/// ```
pub fn vertex_normals(m: &MeshMatrix, p: &[DVec3], weighting: NormalWeighting) -> Vec<DVec3> {
    let fnu = face_normals_unnormalized(m, p);
    let vc = m.vertex_corners();
    let cf = m.corner_face();
    let cv = m.corner_vertex();
    let mut out = Vec::with_capacity(m.n_verts());
    match weighting {
        NormalWeighting::Area => {
            for v in 0..m.n_verts() {
                let mut acc = DVec3::ZERO;
                for k in vc.ptr[v]..vc.ptr[v + 1] {
                    acc += fnu[cf[vc.corner[k as usize] as usize] as usize];
                }
                out.push(acc);
            }
        }
        NormalWeighting::Uniform | NormalWeighting::Angle => {
            let unit: Vec<DVec3> = fnu
                .iter()
                .map(|n| n.try_normalize().unwrap_or(DVec3::ZERO))
                .collect();
            for v in 0..m.n_verts() {
                let mut acc = DVec3::ZERO;
                for k in vc.ptr[v]..vc.ptr[v + 1] {
                    let c = vc.corner[k as usize];
                    let f = cf[c as usize] as usize;
                    let w = if weighting == NormalWeighting::Angle {
                        let pv = p[v];
                        let a = p[cv[m.next(c) as usize] as usize] - pv;
                        let b = p[cv[m.prev(c) as usize] as usize] - pv;
                        corner_angle(a, b)
                    } else {
                        1.0
                    };
                    acc += w * unit[f];
                }
                out.push(acc);
            }
        }
    }
    for n in &mut out {
        *n = n.try_normalize().unwrap_or(DVec3::ZERO);
    }
    out
}

/// The angle between two edge vectors, 0 if either is zero (no NaN from a degenerate corner).
fn corner_angle(a: DVec3, b: DVec3) -> f64 {
    let (la, lb) = (a.length(), b.length());
    if la == 0.0 || lb == 0.0 {
        return 0.0;
    }
    (a.dot(b) / (la * lb)).clamp(-1.0, 1.0).acos()
}

/// AREA vertex normals in `f32`, in exactly the operation order of the two GPU gather passes: face
/// pass `n_f = Σ_k (p_k − p_0) × (p_{k+1} − p_0)` (fan order), vertex pass `Σ n_f` over Mᵀ's row in corner
/// order, then `n · (1/√(n·n))` (zero stays zero). A GPU kernel written the same way reproduces this up to
/// the last-ulp freedom of its `inversesqrt` and any FMA contraction the driver applies.
///
/// ```
/// use gregvox::mesh::{MeshMatrix, vertex_normals_f32};
/// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
/// let n = vertex_normals_f32(&m, &[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
/// assert_eq!(n[0], [0.0, 0.0, 1.0]);
/// ```
pub fn vertex_normals_f32(m: &MeshMatrix, p: &[[f32; 3]]) -> Vec<[f32; 3]> {
    let sub = |a: [f32; 3], b: [f32; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f32; 3], b: [f32; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let face_n: Vec<[f32; 3]> = (0..m.n_faces())
        .map(|f| {
            let face = m.face(f);
            let p0 = p[face[0] as usize];
            let mut n = [0.0f32; 3];
            for w in face[1..].windows(2) {
                let c = cross(sub(p[w[0] as usize], p0), sub(p[w[1] as usize], p0));
                n = [n[0] + c[0], n[1] + c[1], n[2] + c[2]];
            }
            n
        })
        .collect();
    let vc = m.vertex_corners();
    let cf = m.corner_face();
    (0..m.n_verts())
        .map(|v| {
            let mut n = [0.0f32; 3];
            for k in vc.ptr[v]..vc.ptr[v + 1] {
                let c = face_n[cf[vc.corner[k as usize] as usize] as usize];
                n = [n[0] + c[0], n[1] + c[1], n[2] + c[2]];
            }
            let d = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
            if d > 0.0 && d.is_finite() {
                let s = 1.0 / d.sqrt();
                [n[0] * s, n[1] * s, n[2] * s]
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

impl MeshMatrix {
    /// Vertex normals of this connectivity at positions `p` (see [`vertex_normals`]).
    ///
    /// ```
    /// use gregvox::mesh::{MeshMatrix, NormalWeighting};
    /// use glam::DVec3;
    /// let m = MeshMatrix::new(3, &[0, 3], vec![0, 1, 2]).unwrap();
    /// let n = m.vertex_normals(&[DVec3::ZERO, DVec3::X, DVec3::Y], NormalWeighting::default());
    /// assert_eq!(n, vec![DVec3::Z; 3]);
    /// ```
    pub fn vertex_normals(&self, p: &[DVec3], weighting: NormalWeighting) -> Vec<DVec3> {
        vertex_normals(self, p, weighting)
    }
}
