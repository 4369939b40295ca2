//! The bicubic Gregory patch (Chiyokura & Kimura 1983): 20 control points in OpenSubdiv's GREGORY_BASIS
//! order, position, exact first and second partial derivatives, the corner 0/0 guard and normals with a
//! degenerate fallback. See `docs/notes/gregory.md` §1.
//!
//! Conventions and invariants:
//! - Corner i (CCW: (0,0), (1,0), (1,1), (0,1)) owns indices `5i..5i+4 = [P, Ep, Em, Fp, Fm]`; the Bézier
//!   grid `b[row = v index][col = u index]` is [`BEZIER_GRID`].
//! - S(u,v) = Σ B_i(u) B_j(v) Q_ij(u,v), Q_ij rational in the four interior cells: Q = (a·P_a + b·P_b)/(a+b)
//!   with (a, b) = (u, v), (1−u, v), (u, 1−v), (1−u, 1−v) for Q11, Q21, Q12, Q22 (see [`BEZIER_GRID`]).
//! - Corner guard: where d = a + b < [`CORNER_EPS`] (= 1e-6, in f32 and f64 alike) Q = P_a and ∂Q = 0. Only
//!   the exact corner has d = 0, and there every weight multiplying Q is 0, so any finite value is right;
//!   1e-6 rather than `d == 0` because 1/d² overflows f32 for d below ~1e-19 (Inf·0 = NaN).
//! - (u, v) outside `[0,1]²` (and NaN) are clamped into it first, so no input produces NaN from finite points.
//! - One generic implementation serves f64 (reference) and f32 (GPU mirror, [`Patch`]); the operation order
//!   is the documented one of [`eval_generic`], which the shaders follow.
use super::bezier::clamp01;
use super::real::{Point, Real};
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec3};

/// Corner-guard threshold on the denominator d = a + b of a rational interior point.
///
/// ```
/// // exactly at a corner the guard picks P_a and the result is still the corner point
/// use gregvox::geom::gregory::{PatchF64, CORNER_EPS};
/// use glam::DVec3;
/// let g = PatchF64 { cv: std::array::from_fn(|i| DVec3::splat(i as f64)) };
/// assert_eq!(CORNER_EPS, 1e-6);
/// assert_eq!(g.eval(0.0, 0.0).0, g.cv[0]);
/// ```
pub const CORNER_EPS: f64 = 1e-6;

/// The 4×4 Bézier grid in terms of the 20 control points: `BEZIER_GRID[row = v][col = u] = [a, b]`; on the
/// boundary a = b, in the interior cells Q = (α·`cv[a]` + β·`cv[b]`)/(α + β) with (α, β) = (u, v) at (1,1),
/// (1−u, v) at col 2 row 1, (u, 1−v) at col 1 row 2, (1−u, 1−v) at (2,2).
///
/// ```
/// use gregvox::geom::gregory::BEZIER_GRID;
/// assert_eq!(BEZIER_GRID[0], [[0, 0], [1, 1], [7, 7], [5, 5]]);
/// assert_eq!(BEZIER_GRID[1][1], [3, 4]); // Q11: P110 = f0+ (cv3), P111 = f0− (cv4)
/// ```
pub const BEZIER_GRID: [[[usize; 2]; 4]; 4] = [
    [[0, 0], [1, 1], [7, 7], [5, 5]],
    [[2, 2], [3, 4], [9, 8], [6, 6]],
    [[16, 16], [19, 18], [13, 14], [12, 12]],
    [[15, 15], [17, 17], [11, 11], [10, 10]],
];

/// Interior cells (col, row) and the signs of (∂a/∂u, ∂b/∂v): a depends on u only, b on v only.
const INTERIOR: [(usize, usize, f64, f64); 4] = [
    (1, 1, 1.0, 1.0),
    (2, 1, -1.0, 1.0),
    (1, 2, 1.0, -1.0),
    (2, 2, -1.0, -1.0),
];

/// Cubic Bernstein values and first and second derivatives at t.
fn bern3<S: Real>(t: S) -> [[S; 4]; 3] {
    let three = S::from_f64(3.0);
    let six = S::from_f64(6.0);
    let s = S::ONE - t;
    [
        [s * s * s, three * t * s * s, three * t * t * s, t * t * t],
        [
            -three * s * s,
            three * s * s - six * t * s,
            six * t * s - three * t * t,
            three * t * t,
        ],
        // d²/dt² of (1−t)³, 3t(1−t)², 3t²(1−t), t³
        [
            six * s,
            S::from_f64(18.0) * t - S::from_f64(12.0),
            six - S::from_f64(18.0) * t,
            six * t,
        ],
    ]
}

/// Rational interior point with its first and second derivatives: [Q, Q_u, Q_v, Q_uu, Q_uv, Q_vv].
fn rational_point<S: Real, P: Point<S>>(pa: P, pb: P, a: S, b: S, au: S, bv: S) -> [P; 6] {
    let d = a + b;
    if d < S::from_f64(CORNER_EPS) {
        return [pa, P::zero(), P::zero(), P::zero(), P::zero(), P::zero()];
    }
    let inv = S::ONE / d;
    let q = (pa * a + pb * b) * inv;
    let diff = pa - pb;
    // f = a/d, Q = P_b + f·(P_a − P_b); a_v = b_u = 0
    let inv2 = inv * inv;
    let two = S::from_f64(2.0);
    let fu = au * b * inv2;
    let fv = -(a * bv) * inv2;
    let fuu = -(two * fu * au) * inv;
    let fvv = -(two * fv * bv) * inv;
    let fuv = au * bv * inv2 - two * fu * bv * inv;
    [q, diff * fu, diff * fv, diff * fuu, diff * fuv, diff * fvv]
}

/// Evaluation result: position, first and (optionally) second partial derivatives.
///
/// ```
/// use gregvox::geom::gregory::{eval_generic, PatchF64};
/// use glam::DVec3;
/// let g = PatchF64 { cv: [DVec3::ONE; 20] };
/// let e = eval_generic(&g.cv, 0.5, 0.5, true, true);
/// assert_eq!((e.p, e.su, e.second[1]), (DVec3::ONE, DVec3::ZERO, DVec3::ZERO));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GregoryEval<P> {
    /// S(u, v)
    pub p: P,
    /// ∂S/∂u
    pub su: P,
    /// ∂S/∂v
    pub sv: P,
    /// ∂²S/∂u², ∂²S/∂u∂v, ∂²S/∂v² (zero unless requested)
    pub second: [P; 3],
}

/// The evaluator of record, generic over f32/f64 so the GPU's arithmetic can be mirrored:
/// 1. clamp u, v to [0, 1]; cubic Bernstein B, B′ (B″) in u and v;
/// 2. the four rational points Q_ij with the corner guard (d < 1e-6 ⇒ Q = P_a, ∂Q = 0), else
///    `inv = 1/d; Q = (P_a·a + P_b·b)·inv`, ∂Q from f = a/d;
/// 3. S, S_u, S_v by contracting the frozen 4×4 net row by row (v index outer, u inner);
/// 4. if `exact`, add Σ B_i(u)B_j(v)·∂Q_ij over the interior cells (in the order Q11, Q21, Q12, Q22).
///
/// `second` also computes the second derivatives (exact: with the ∂Q and ∂²Q terms).
///
/// ```
/// use gregvox::geom::gregory::{eval_generic, PatchF64};
/// use glam::{DVec3, Vec3};
/// let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| DVec3::new(i as f64, j as f64, (i + j) as f64)));
/// let g = PatchF64::from_bezier(&b);
/// let e64 = eval_generic(&g.cv, 0.25, 0.5, true, false);
/// let e32 = eval_generic(&g.to_gpu().points(), 0.25f32, 0.5f32, true, false);
/// assert_eq!(e64.p, DVec3::new(0.75, 1.5, 2.25));
/// assert!((e32.p - Vec3::new(0.75, 1.5, 2.25)).length() < 1e-6);
/// ```
pub fn eval_generic<S: Real, P: Point<S>>(
    cv: &[P; 20],
    u: S,
    v: S,
    exact: bool,
    second: bool,
) -> GregoryEval<P> {
    let (u, v) = (clamp01(u), clamp01(v));
    let bu = bern3(u);
    let bv = bern3(v);
    let (uu, vv) = (S::ONE - u, S::ONE - v);
    let mut net = [[P::zero(); 4]; 4];
    for (j, row) in BEZIER_GRID.iter().enumerate() {
        for (i, &[a, _]) in row.iter().enumerate() {
            net[j][i] = cv[a];
        }
    }
    let mut dq = [[P::zero(); 5]; 4];
    for (k, &(i, j, su, sv)) in INTERIOR.iter().enumerate() {
        let [ia, ib] = BEZIER_GRID[j][i];
        let a = if su > 0.0 { u } else { uu };
        let b = if sv > 0.0 { v } else { vv };
        let r = rational_point(cv[ia], cv[ib], a, b, S::from_f64(su), S::from_f64(sv));
        net[j][i] = r[0];
        dq[k] = [r[1], r[2], r[3], r[4], r[5]];
    }
    let contract = |wu: &[S; 4], wv: &[S; 4]| -> P {
        let mut acc = P::zero();
        for j in 0..4 {
            let mut row = P::zero();
            for i in 0..4 {
                row = row + net[j][i] * wu[i];
            }
            acc = acc + row * wv[j];
        }
        acc
    };
    let p = contract(&bu[0], &bv[0]);
    let mut su = contract(&bu[1], &bv[0]);
    let mut sv = contract(&bu[0], &bv[1]);
    let mut sec = [P::zero(); 3];
    if second {
        sec = [
            contract(&bu[2], &bv[0]),
            contract(&bu[1], &bv[1]),
            contract(&bu[0], &bv[2]),
        ];
    }
    if exact {
        let two = S::from_f64(2.0);
        for (k, &(i, j, _, _)) in INTERIOR.iter().enumerate() {
            let w = bu[0][i] * bv[0][j];
            let [qu, qv, quu, quv, qvv] = dq[k];
            su = su + qu * w;
            sv = sv + qv * w;
            if second {
                sec[0] = sec[0] + qu * (two * bu[1][i] * bv[0][j]) + quu * w;
                sec[1] = sec[1] + qv * (bu[1][i] * bv[0][j]) + qu * (bu[0][i] * bv[1][j]) + quv * w;
                sec[2] = sec[2] + qv * (two * bu[0][i] * bv[1][j]) + qvv * w;
            }
        }
    }
    GregoryEval {
        p,
        su,
        sv,
        second: sec,
    }
}

/// The frozen 16-point Bézier net at (u, v): the boundary points and Q_ij(u, v), `[row = v][col = u]`.
///
/// ```
/// use gregvox::geom::gregory::bezier_net_generic;
/// use glam::DVec3;
/// let cv: [DVec3; 20] = std::array::from_fn(|i| DVec3::splat(i as f64));
/// // Q11 = (u·P110 + v·P111)/(u + v) with P110 = cv3, P111 = cv4
/// assert_eq!(bezier_net_generic(&cv, 0.25, 0.75)[1][1], DVec3::splat(3.75));
/// ```
pub fn bezier_net_generic<S: Real, P: Point<S>>(cv: &[P; 20], u: S, v: S) -> [[P; 4]; 4] {
    let (u, v) = (clamp01(u), clamp01(v));
    let mut net = [[P::zero(); 4]; 4];
    for (j, row) in BEZIER_GRID.iter().enumerate() {
        for (i, &[a, _]) in row.iter().enumerate() {
            net[j][i] = cv[a];
        }
    }
    for &(i, j, su, sv) in INTERIOR.iter() {
        let [ia, ib] = BEZIER_GRID[j][i];
        let a = if su > 0.0 { u } else { S::ONE - u };
        let b = if sv > 0.0 { v } else { S::ONE - v };
        net[j][i] = rational_point(cv[ia], cv[ib], a, b, S::ONE, S::ONE)[0];
    }
    net
}

macro_rules! normal_impl {
    ($s:ty, $v:ty, $bits:ty, $mant:expr, $bias:expr) => {
        /// `a` and `b` multiplied by one power of two that brings their largest component into [½, 1)
        /// (as GLSL's `frexp`): exact, so every ratio, test and unit vector below keeps its bits, while a
        /// cross product of 1e-20-sized derivatives no longer underflows to 0 (nor 1e20-sized ones
        /// overflow). Zero, subnormal and non-finite inputs are left as they are.
        fn rescaled(a: $v, b: $v) -> ($v, $v) {
            let m = a.abs().max_element().max(b.abs().max_element());
            let exp = ((m.to_bits() >> $mant) & ((1 << (<$bits>::BITS - 1 - $mant)) - 1)) as i32;
            if exp == 0 || !m.is_finite() {
                return (a, b);
            }
            // m = f·2^e with f in [½, 1): e = exp − bias + 1; scale by 2^−e.
            let e = exp - $bias + 1;
            if -e + $bias < 1 {
                return (a, b); // 2^−e would be subnormal: m is within a factor 2 of the largest float
            }
            let k = <$s>::from_bits(((-e + $bias) as $bits) << $mant);
            (a * k, b * k)
        }

        /// Unit normal with the degenerate fallback (notes §1.5):
        /// 1. N = S_u × S_v if |N| > 1e-5·(|S_u| + |S_v|)² (a scale-free form of OpenSubdiv's test: it
        ///    also catches a derivative that is only rounding noise on a collapsed edge, where a pure angle
        ///    test would accept the noise's direction);
        /// 2. else the cross product of the diagonals of the de Casteljau 2×2 bilinear hull at (u, v),
        ///    (c11 − c00) × (c01 − c10) (OpenSubdiv `OsdEvalPatchBezier`);
        /// 3. else the same with the four corner points; 4. else +Z. Never NaN for finite points.
        pub(super) fn normal_from(net: &[[$v; 4]; 4], su: $v, sv: $v, u: $s, v: $s) -> $v {
            let (su, sv) = rescaled(su, sv);
            let n = su.cross(sv);
            let ln = n.length();
            let scale = su.length() + sv.length();
            if ln > 1e-5 * scale * scale && ln.is_finite() {
                return n / ln;
            }
            let (u, v) = (clamp01(u), clamp01(v));
            let lerp2 = |pts: [$v; 4], t: $s| -> [$v; 2] {
                let a = [
                    pts[0].lerp(pts[1], t),
                    pts[1].lerp(pts[2], t),
                    pts[2].lerp(pts[3], t),
                ];
                [a[0].lerp(a[1], t), a[1].lerp(a[2], t)]
            };
            let rows: [[$v; 2]; 4] = [
                lerp2(net[0], u),
                lerp2(net[1], u),
                lerp2(net[2], u),
                lerp2(net[3], u),
            ];
            let c0 = lerp2([rows[0][0], rows[1][0], rows[2][0], rows[3][0]], v);
            let c1 = lerp2([rows[0][1], rows[1][1], rows[2][1], rows[3][1]], v);
            // c0 = [c00, c01] (column u-low, v low/high), c1 = [c10, c11]
            let (d0, d1) = rescaled(c1[1] - c0[0], c0[1] - c1[0]);
            let hull = d0.cross(d1);
            let lh = hull.length();
            if lh > 0.0 && lh.is_finite() {
                return hull / lh;
            }
            let (d0, d1) = rescaled(net[3][3] - net[0][0], net[3][0] - net[0][3]);
            let corners = d0.cross(d1);
            let lc = corners.length();
            if lc > 0.0 && lc.is_finite() {
                return corners / lc;
            }
            <$v>::Z
        }
    };
}

mod normal64 {
    use super::*;
    normal_impl!(f64, DVec3, u64, 52, 1023);
}
mod normal32 {
    use super::*;
    normal_impl!(f32, Vec3, u32, 23, 127);
}

/// A Gregory patch in f64 for reference maths.
///
/// ```
/// use gregvox::geom::gregory::PatchF64;
/// use glam::DVec3;
/// let g = PatchF64 { cv: std::array::from_fn(|i| DVec3::new(i as f64, 0.0, 0.0)) };
/// assert_eq!(g.eval(1.0, 0.0).0, g.cv[5]); // corner 1 = (1, 0)
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchF64 {
    /// The 20 control points in GREGORY_BASIS order.
    pub cv: [DVec3; 20],
}

/// A Gregory patch as the GPU reads it: 20 × vec4 (w = 1, unused), std430-compatible, `Pod`.
///
/// ```
/// use gregvox::geom::gregory::Patch;
/// let p = Patch { cv: [[0.0, 1.0, 2.0, 1.0]; 20] };
/// let bytes: &[u8] = bytemuck::bytes_of(&p);
/// assert_eq!(bytes.len(), 20 * 16); // 20 × vec4, std430 array stride 16
/// ```
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Patch {
    /// The 20 control points in GREGORY_BASIS order, xyz + w = 1.
    pub cv: [[f32; 4]; 20],
}

impl PatchF64 {
    /// From 20 control points; all must be finite.
    ///
    /// ```
    /// use gregvox::geom::gregory::PatchF64;
    /// use glam::DVec3;
    /// assert!(PatchF64::new([DVec3::ZERO; 20]).is_ok());
    /// let mut cv = [DVec3::ZERO; 20];
    /// cv[7].x = f64::NAN;
    /// assert!(PatchF64::new(cv).is_err());
    /// ```
    pub fn new(cv: [DVec3; 20]) -> Result<Self> {
        if let Some(i) = cv.iter().position(|p| !p.is_finite()) {
            return Err(Error::Invalid(format!(
                "Gregory patch: control point {i} is not finite"
            )));
        }
        Ok(PatchF64 { cv })
    }

    /// The Gregory patch equal to a bicubic Bézier patch `b[row = v][col = u]` (each interior pair gets
    /// the same point).
    ///
    /// ```
    /// use gregvox::geom::gregory::PatchF64;
    /// use gregvox::geom::surface::bicubic_bezier;
    /// use glam::DVec3;
    /// let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| DVec3::new(i as f64, j as f64, (i * j) as f64)));
    /// let g = PatchF64::from_bezier(&b);
    /// assert!((g.eval(0.3, 0.8).0 - bicubic_bezier(&b, 0.3, 0.8)).length() < 1e-14);
    /// ```
    pub fn from_bezier(b: &[[DVec3; 4]; 4]) -> Self {
        let mut cv = [DVec3::ZERO; 20];
        for (j, row) in BEZIER_GRID.iter().enumerate() {
            for (i, &[a, bb]) in row.iter().enumerate() {
                cv[a] = b[j][i];
                cv[bb] = b[j][i];
            }
        }
        PatchF64 { cv }
    }

    /// The Bézier patch, if every interior pair coincides (else `None`).
    ///
    /// ```
    /// use gregvox::geom::gregory::PatchF64;
    /// use glam::DVec3;
    /// let b = [[DVec3::ONE; 4]; 4];
    /// assert_eq!(PatchF64::from_bezier(&b).to_bezier(), Some(b));
    /// ```
    pub fn to_bezier(&self) -> Option<[[DVec3; 4]; 4]> {
        let mut b = [[DVec3::ZERO; 4]; 4];
        for (j, row) in BEZIER_GRID.iter().enumerate() {
            for (i, &[a, bb]) in row.iter().enumerate() {
                if self.cv[a] != self.cv[bb] {
                    return None;
                }
                b[j][i] = self.cv[a];
            }
        }
        Some(b)
    }

    /// (S, S_u, S_v) with exact derivatives.
    ///
    /// ```
    /// use gregvox::geom::gregory::PatchF64;
    /// use glam::DVec3;
    /// let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| DVec3::new(i as f64, j as f64, 0.0)));
    /// let (p, su, sv) = PatchF64::from_bezier(&b).eval(0.5, 0.5);
    /// assert_eq!((p, su, sv), (DVec3::new(1.5, 1.5, 0.0), DVec3::new(3.0, 0.0, 0.0), DVec3::new(0.0, 3.0, 0.0)));
    /// ```
    pub fn eval(&self, u: f64, v: f64) -> (DVec3, DVec3, DVec3) {
        let e = eval_generic(&self.cv, u, v, true, false);
        (e.p, e.su, e.sv)
    }

    /// (S, S_u, S_v) with OpenSubdiv's approximate derivatives (Q frozen at (u, v)); exact on the edges.
    ///
    /// ```
    /// use gregvox::geom::gregory::PatchF64;
    /// use glam::DVec3;
    /// let mut cv: [DVec3; 20] = std::array::from_fn(|i| DVec3::new(i as f64, (i * i) as f64 * 0.1, 1.0));
    /// let g = PatchF64::new(cv).unwrap();
    /// assert_eq!(g.approx_derivatives(0.0, 0.4), g.eval(0.0, 0.4)); // equal on an edge
    /// assert_ne!(g.approx_derivatives(0.5, 0.4).1, g.eval(0.5, 0.4).1);
    /// ```
    pub fn approx_derivatives(&self, u: f64, v: f64) -> (DVec3, DVec3, DVec3) {
        let e = eval_generic(&self.cv, u, v, false, false);
        (e.p, e.su, e.sv)
    }

    /// Exact second derivatives (S_uu, S_uv, S_vv), for curvature shading.
    ///
    /// ```
    /// use gregvox::geom::gregory::PatchF64;
    /// use glam::DVec3;
    /// // z = u·v as a Bézier patch: b_ij z = i·j/9
    /// let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| DVec3::new(i as f64 / 3.0, j as f64 / 3.0, (i * j) as f64 / 9.0)));
    /// let [suu, suv, svv] = PatchF64::from_bezier(&b).second_derivatives(0.2, 0.7);
    /// assert!(suu.length() < 1e-14 && svv.length() < 1e-14 && (suv - DVec3::Z).length() < 1e-14);
    /// ```
    pub fn second_derivatives(&self, u: f64, v: f64) -> [DVec3; 3] {
        eval_generic(&self.cv, u, v, true, true).second
    }

    /// (Gaussian K, mean H) from the exact first and second derivatives (H signed w.r.t. S_u × S_v);
    /// `None` where S_u ∥ S_v.
    ///
    /// ```
    /// use gregvox::geom::gregory::PatchF64;
    /// use glam::DVec3;
    /// // the paraboloid z = (x² + y²)/2 over [−1, 1]², exactly bicubic: K = H = 1 at the apex
    /// let g3 = [0.5, -1.0 / 6.0, -1.0 / 6.0, 0.5];
    /// let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i|
    ///     DVec3::new(-1.0 + 2.0 * i as f64 / 3.0, -1.0 + 2.0 * j as f64 / 3.0, g3[i] + g3[j])));
    /// let (k, h) = PatchF64::from_bezier(&b).curvature(0.5, 0.5).unwrap();
    /// assert!((k - 1.0).abs() < 1e-14 && (h - 1.0).abs() < 1e-14);
    /// ```
    pub fn curvature(&self, u: f64, v: f64) -> Option<(f64, f64)> {
        let e = eval_generic(&self.cv, u, v, true, true);
        let [suu, suv, svv] = e.second;
        super::curvature::gaussian_mean_curvature(e.su, e.sv, suu, suv, svv)
    }

    /// Unit normal with the degenerate fallback (see [`Patch::normal`] for the steps); never NaN.
    ///
    /// ```
    /// use gregvox::geom::gregory::PatchF64;
    /// use glam::DVec3;
    /// // top edge collapsed to a point: S_u = 0 along v = 1, the fallback still gives +Z
    /// let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| {
    ///     let x = i as f64 / 3.0; let y = j as f64 / 3.0;
    ///     DVec3::new(0.5 + (x - 0.5) * (1.0 - y), y, 0.0)
    /// }));
    /// let n = PatchF64::from_bezier(&b).normal(0.3, 1.0);
    /// assert!((n - DVec3::Z).length() < 1e-12);
    /// ```
    pub fn normal(&self, u: f64, v: f64) -> DVec3 {
        let e = eval_generic(&self.cv, u, v, true, false);
        normal64::normal_from(&bezier_net_generic(&self.cv, u, v), e.su, e.sv, u, v)
    }

    /// The frozen 4×4 Bézier net at (u, v) (`[row = v][col = u]`).
    ///
    /// ```
    /// use gregvox::geom::gregory::PatchF64;
    /// use glam::DVec3;
    /// let b = [[DVec3::X; 4]; 4];
    /// assert_eq!(PatchF64::from_bezier(&b).bezier_net(0.3, 0.6), b);
    /// ```
    pub fn bezier_net(&self, u: f64, v: f64) -> [[DVec3; 4]; 4] {
        bezier_net_generic(&self.cv, u, v)
    }

    /// Rounds to the GPU layout.
    ///
    /// ```
    /// use gregvox::geom::gregory::PatchF64;
    /// use glam::DVec3;
    /// let p = PatchF64 { cv: [DVec3::new(1.0, 2.0, 3.0); 20] }.to_gpu();
    /// assert_eq!(p.cv[19], [1.0, 2.0, 3.0, 1.0]);
    /// assert_eq!(std::mem::size_of_val(&p), 320);
    /// ```
    pub fn to_gpu(&self) -> Patch {
        Patch {
            cv: self.cv.map(|p| [p.x as f32, p.y as f32, p.z as f32, 1.0]),
        }
    }
}

impl Patch {
    /// The control points as `Vec3`.
    ///
    /// ```
    /// use gregvox::geom::gregory::Patch;
    /// assert_eq!(Patch { cv: [[1.0, 2.0, 3.0, 1.0]; 20] }.points()[0], glam::Vec3::new(1.0, 2.0, 3.0));
    /// ```
    pub fn points(&self) -> [Vec3; 20] {
        self.cv.map(|c| Vec3::new(c[0], c[1], c[2]))
    }

    /// Widening to f64 (exact).
    ///
    /// ```
    /// use gregvox::geom::gregory::Patch;
    /// let p = Patch { cv: [[0.5, 0.25, 2.0, 1.0]; 20] };
    /// assert_eq!(p.to_f64().to_gpu(), p);
    /// ```
    pub fn to_f64(&self) -> PatchF64 {
        PatchF64 {
            cv: self
                .cv
                .map(|c| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64)),
        }
    }

    /// f32 (S, S_u, S_v) with exact derivatives, in the operation order of [`eval_generic`].
    ///
    /// ```
    /// use gregvox::geom::gregory::PatchF64;
    /// use glam::{DVec3, Vec3};
    /// let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| DVec3::new(i as f64, j as f64, 0.0)));
    /// let (p, _, _) = PatchF64::from_bezier(&b).to_gpu().eval(0.5, 0.5);
    /// assert_eq!(p, Vec3::new(1.5, 1.5, 0.0));
    /// ```
    pub fn eval(&self, u: f32, v: f32) -> (Vec3, Vec3, Vec3) {
        let e = eval_generic(&self.points(), u, v, true, false);
        (e.p, e.su, e.sv)
    }

    /// f32 (S, S_u, S_v) with approximate (frozen-Q) derivatives.
    ///
    /// ```
    /// use gregvox::geom::gregory::Patch;
    /// let p = Patch { cv: [[1.0, 2.0, 3.0, 1.0]; 20] };
    /// assert_eq!(p.approx_derivatives(0.5, 0.5).1, glam::Vec3::ZERO);
    /// ```
    pub fn approx_derivatives(&self, u: f32, v: f32) -> (Vec3, Vec3, Vec3) {
        let e = eval_generic(&self.points(), u, v, false, false);
        (e.p, e.su, e.sv)
    }

    /// f32 exact second derivatives (S_uu, S_uv, S_vv).
    ///
    /// ```
    /// use gregvox::geom::gregory::Patch;
    /// let p = Patch { cv: [[1.0, 2.0, 3.0, 1.0]; 20] };
    /// assert_eq!(p.second_derivatives(0.5, 0.5)[1], glam::Vec3::ZERO);
    /// ```
    pub fn second_derivatives(&self, u: f32, v: f32) -> [Vec3; 3] {
        eval_generic(&self.points(), u, v, true, true).second
    }

    /// f32 unit normal with the degenerate fallback:
    /// 1. S_u × S_v when |S_u × S_v| > 1e-5·(|S_u| + |S_v|)²;
    /// 2. else (c11 − c00) × (c01 − c10) over the de Casteljau bilinear hull of the frozen net at (u, v);
    /// 3. else the corner quad's diagonals; 4. else +Z.
    ///
    /// ```
    /// use gregvox::geom::gregory::Patch;
    /// let p = Patch { cv: [[1.0, 2.0, 3.0, 1.0]; 20] }; // everything collapsed to one point
    /// assert_eq!(p.normal(0.5, 0.5), glam::Vec3::Z);
    /// ```
    pub fn normal(&self, u: f32, v: f32) -> Vec3 {
        let pts = self.points();
        let e = eval_generic(&pts, u, v, true, false);
        normal32::normal_from(&bezier_net_generic(&pts, u, v), e.su, e.sv, u, v)
    }
}

/// The f32 unit normal of a frozen net `[row = v][col = u]` and the exact partials at (u, v), with the
/// degenerate fallback of [`PatchF64::normal`] (what glsl/include/gregory.glsl's `gregory_normal` computes):
/// the host evaluator ([`crate::surface::gregory_host`]) calls it for the samples whose S_u × S_v fails the
/// test.
///
/// ```
/// use gregvox::geom::gregory::normal_from_net_f32;
/// use glam::Vec3;
/// let net = [[Vec3::ZERO; 4]; 4];
/// assert_eq!(normal_from_net_f32(&net, Vec3::X, Vec3::Y, 0.5, 0.5), Vec3::Z);
/// assert_eq!(normal_from_net_f32(&net, Vec3::ZERO, Vec3::ZERO, 0.5, 0.5), Vec3::Z); // all collapsed
/// ```
pub fn normal_from_net_f32(net: &[[Vec3; 4]; 4], su: Vec3, sv: Vec3, u: f32, v: f32) -> Vec3 {
    normal32::normal_from(net, su, sv, u, v)
}
