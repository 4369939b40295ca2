//! Chiyokura–Kimura compatibility correction: face points that make two Gregory patches sharing a boundary
//! cubic G1 along the whole edge (Takeda 2008 eqs. 2.10–2.12; docs/notes/gregory.md §2).
//!
//! Conventions: the shared cubic has Bézier points P0..P3 (P0 at t = 0); C_i = P_{i+1} − P_i;
//! A_i = (A's first inner-row point at station i) − P_i, B_i likewise for B, both pointing *away* from the
//! edge into their own patch. G1 means B(t) = k(t)·A(t) + h(t)·C(t) with k, h linear; for patches on
//! opposite sides k < 0. A0, A3, B0, B3 (the edge points on the other boundary curves) are inputs and are
//! never changed: the corners must already be G1 (B0 ∈ span(A0, C0), B3 ∈ span(A3, C2)), otherwise the
//! 2×2 least squares of eq. 2.12 leaves a residual (reported) and the edge is G1 only in between.
//! Step 2.10 makes A's cross-boundary field linear, which is what makes eq. 2.11 exact for every t; it moves
//! A's face points too. Only the four face points of this edge change, and with Gregory patches they
//! influence no other edge.
use super::gregory::PatchF64;
use crate::{Error, Result};
use glam::DVec3;

/// Result of the correction.
///
/// ```
/// use gregvox::geom::compat::chiyokura_kimura;
/// use glam::DVec3;
/// let p = [0.0, 1.0, 2.0, 3.0].map(|x| DVec3::new(x, 0.0, 0.0));
/// let s = chiyokura_kimura(&p, DVec3::Y, DVec3::Y, -2.0 * DVec3::Y, -DVec3::Y).unwrap();
/// assert_eq!((s.k, s.h), ([-2.0, -1.0], [0.0, 0.0]));
/// assert_eq!(s.corner_residual, [0.0, 0.0]);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CkSolution {
    /// (k0, k1) of k(t) = k0(1−t) + k1 t.
    pub k: [f64; 2],
    /// (h0, h1) of h(t) = h0(1−t) + h1 t.
    pub h: [f64; 2],
    /// A's new face points P1 + A1, P2 + A2.
    pub a_face: [DVec3; 2],
    /// B's new face points P1 + B1, P2 + B2.
    pub b_face: [DVec3; 2],
    /// |B0 − k0A0 − h0C0| and |B3 − k1A3 − h1C2|: 0 (to rounding) when the corners are G1.
    pub corner_residual: [f64; 2],
}

/// Least squares solution (k, h) of b ≈ k·a + h·c, with its residual.
fn solve2(a: DVec3, c: DVec3, b: DVec3) -> Result<(f64, f64, f64)> {
    let (aa, ac, cc) = (a.dot(a), a.dot(c), c.dot(c));
    let det = aa * cc - ac * ac;
    if !(det > 1e-24 * aa * cc) || !det.is_finite() {
        return Err(Error::Invalid(
            "Chiyokura–Kimura: cross-boundary vector parallel to the boundary tangent at an end (or zero)".into(),
        ));
    }
    let (ab, cb) = (a.dot(b), c.dot(b));
    let k = (ab * cc - cb * ac) / det;
    let h = (aa * cb - ac * ab) / det;
    Ok((k, h, (b - a * k - c * h).length()))
}

/// The correction for one shared edge: boundary cubic `p`, A's end vectors (A0, A3) and B's (B0, B3).
///
/// ```
/// use gregvox::geom::compat::chiyokura_kimura;
/// use glam::DVec3;
/// // a flat edge along x; A goes towards +y, B towards −y: k = −1, h = 0, face points mirror
/// let p = [0.0, 1.0, 2.0, 3.0].map(|x| DVec3::new(x, 0.0, 0.0));
/// let s = chiyokura_kimura(&p, DVec3::Y, DVec3::Y, -DVec3::Y, -DVec3::Y).unwrap();
/// assert_eq!(s.k, [-1.0, -1.0]);
/// assert_eq!(s.b_face, [DVec3::new(1.0, -1.0, 0.0), DVec3::new(2.0, -1.0, 0.0)]);
/// ```
pub fn chiyokura_kimura(
    p: &[DVec3; 4],
    a0: DVec3,
    a3: DVec3,
    b0: DVec3,
    b3: DVec3,
) -> Result<CkSolution> {
    if p.iter()
        .chain([a0, a3, b0, b3].iter())
        .any(|v| !v.is_finite())
    {
        return Err(Error::Invalid("Chiyokura–Kimura: non-finite input".into()));
    }
    let c = [p[1] - p[0], p[2] - p[1], p[3] - p[2]];
    let (k0, h0, r0) = solve2(a0, c[0], b0)?; // eq. 2.12
    let (k1, h1, r1) = solve2(a3, c[2], b3)?;
    let a1 = (a0 * 2.0 + a3) / 3.0; // eq. 2.10
    let a2 = (a0 + a3 * 2.0) / 3.0;
    let b1 = ((k1 - k0) * a0 + 3.0 * k0 * a1 + 2.0 * h0 * c[1] + h1 * c[0]) / 3.0; // eq. 2.11
    let b2 = (3.0 * k1 * a2 - (k1 - k0) * a3 + h0 * c[2] + 2.0 * h1 * c[1]) / 3.0;
    Ok(CkSolution {
        k: [k0, k1],
        h: [h0, h1],
        a_face: [p[1] + a1, p[2] + a2],
        b_face: [p[1] + b1, p[2] + b2],
        corner_residual: [r0, r1],
    })
}

/// An edge of a Gregory patch, with the control-point indices of its boundary cubic and of the first inner
/// row, both listed in increasing parameter (u for `V0`/`V1`, v for `U0`/`U1`).
///
/// ```
/// use gregvox::geom::compat::Edge;
/// // every edge's cubic starts at a corner point (indices 0, 5, 10, 15)
/// for e in [Edge::V0, Edge::U1, Edge::V1, Edge::U0] { assert_eq!(e.boundary()[0] % 5, 0); }
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edge {
    /// v = 0
    V0,
    /// u = 1
    U1,
    /// v = 1
    V1,
    /// u = 0
    U0,
}

impl Edge {
    /// The boundary cubic's control-point indices.
    ///
    /// ```
    /// use gregvox::geom::compat::Edge;
    /// assert_eq!(Edge::V0.boundary(), [0, 1, 7, 5]);
    /// ```
    pub fn boundary(self) -> [usize; 4] {
        match self {
            Edge::V0 => [0, 1, 7, 5],
            Edge::U1 => [5, 6, 12, 10],
            Edge::V1 => [15, 17, 11, 10],
            Edge::U0 => [0, 2, 16, 15],
        }
    }

    /// The inner row: the two edge points of the neighbouring boundaries and, between them, the face points
    /// that set this edge's cross-boundary derivative (P_ij0 for v-edges, P_ij1 for u-edges).
    ///
    /// ```
    /// use gregvox::geom::compat::Edge;
    /// assert_eq!(Edge::V0.inner(), [2, 3, 9, 6]);
    /// assert_eq!(Edge::U0.inner(), [1, 4, 18, 17]);
    /// ```
    pub fn inner(self) -> [usize; 4] {
        match self {
            Edge::V0 => [2, 3, 9, 6],
            Edge::U1 => [7, 8, 14, 11],
            Edge::V1 => [16, 19, 13, 12],
            Edge::U0 => [1, 4, 18, 17],
        }
    }

    /// The (u, v) of the point at parameter t along this edge (t in the edge's increasing parameter).
    ///
    /// ```
    /// assert_eq!(gregvox::geom::compat::Edge::U1.uv(0.25), (1.0, 0.25));
    /// ```
    pub fn uv(self, t: f64) -> (f64, f64) {
        match self {
            Edge::V0 => (t, 0.0),
            Edge::U1 => (1.0, t),
            Edge::V1 => (t, 1.0),
            Edge::U0 => (0.0, t),
        }
    }
}

/// Applies the correction to two patches sharing an edge (`ea` of `a`, `eb` of `b`; the cubic may run in
/// the same or the opposite direction, detected from the points, tolerance 1e-9 × the cubic's size).
/// Writes the four face points and returns the solution (in A's edge parameter).
///
/// ```
/// use gregvox::geom::compat::{ck_correct_edge, Edge};
/// use gregvox::geom::gregory::PatchF64;
/// use glam::DVec3;
/// let grid = |y0: f64| -> [[DVec3; 4]; 4] { std::array::from_fn(|j| std::array::from_fn(|i|
///     DVec3::new(i as f64, y0 + j as f64, 0.0))) };
/// let mut a = PatchF64::from_bezier(&grid(0.0));
/// let mut b = PatchF64::from_bezier(&grid(-3.0)); // b's v = 1 edge is a's v = 0 edge
/// let s = ck_correct_edge(&mut a, Edge::V0, &mut b, Edge::V1).unwrap();
/// assert_eq!(s.k, [-1.0, -1.0]);
/// assert!(ck_correct_edge(&mut a, Edge::U1, &mut b, Edge::V1).is_err()); // not shared
/// ```
pub fn ck_correct_edge(
    a: &mut PatchF64,
    ea: Edge,
    b: &mut PatchF64,
    eb: Edge,
) -> Result<CkSolution> {
    let pa = ea.boundary().map(|i| a.cv[i]);
    let ia = ea.inner();
    let (mut bb, mut ib) = (eb.boundary(), eb.inner());
    let size = (pa[3] - pa[0]).length() + (pa[1] - pa[0]).length() + (pa[2] - pa[1]).length();
    let tol = 1e-9 * size.max(f64::MIN_POSITIVE);
    let same = |idx: &[usize; 4]| {
        idx.iter()
            .zip(&pa)
            .all(|(&i, p)| (b.cv[i] - *p).length() <= tol)
    };
    if !same(&bb) {
        bb.reverse();
        ib.reverse();
        if !same(&bb) {
            return Err(Error::Invalid(format!(
                "Chiyokura–Kimura: edge {ea:?} of A and edge {eb:?} of B do not share a boundary cubic"
            )));
        }
    }
    let s = chiyokura_kimura(
        &pa,
        a.cv[ia[0]] - pa[0],
        a.cv[ia[3]] - pa[3],
        b.cv[ib[0]] - pa[0],
        b.cv[ib[3]] - pa[3],
    )?;
    a.cv[ia[1]] = s.a_face[0];
    a.cv[ia[2]] = s.a_face[1];
    b.cv[ib[1]] = s.b_face[0];
    b.cv[ib[2]] = s.b_face[1];
    Ok(s)
}
