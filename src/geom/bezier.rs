//! Bézier curves of any degree: Bernstein and de Casteljau evaluation, split, hodographs, degree
//! elevation, rational Bézier curves.
//!
//! Conventions: the parameter domain is [0, 1] (values outside are clamped); a curve of degree n has n + 1
//! control points, n ≥ 0 (a single point is a constant curve, whose hodograph is the zero curve of degree
//! 0). De Casteljau is the evaluator of record (what the shaders do); the Bernstein sum exists because the
//! lecture notes define the curve that way and tests compare the two.
use super::real::{binomial, check_finite, Point, Real};
use crate::{Error, Result};
use glam::DVec4;

/// All Bernstein polynomials B_{i,n}(t), i = 0..=n, by the triangular recurrence (no binomials, no
/// powers: stable at t = 0 and 1).
///
/// ```
/// let b = gregvox::geom::bezier::bernstein_all::<f64>(3, 0.5);
/// assert_eq!(b, vec![0.125, 0.375, 0.375, 0.125]);
/// ```
pub fn bernstein_all<S: Real>(n: usize, t: S) -> Vec<S> {
    let mut b = vec![S::ZERO; n + 1];
    b[0] = S::ONE;
    let s = S::ONE - t;
    for j in 1..=n {
        let mut saved = S::ZERO;
        for k in 0..j {
            let tmp = b[k];
            b[k] = saved + s * tmp;
            saved = t * tmp;
        }
        b[j] = saved;
    }
    b
}

/// One Bernstein polynomial B_{i,n}(t) = C(n,i) tⁱ (1−t)ⁿ⁻ⁱ (0 when i > n).
///
/// ```
/// assert!((gregvox::geom::bezier::bernstein::<f64>(3, 1, 0.5) - 0.375).abs() < 1e-15);
/// ```
pub fn bernstein<S: Real>(n: usize, i: usize, t: S) -> S {
    if i > n {
        return S::ZERO;
    }
    let mut r = binomial::<S>(n, i);
    for _ in 0..i {
        r *= t;
    }
    for _ in 0..(n - i) {
        r *= S::ONE - t;
    }
    r
}

/// Clamps a parameter to [0, 1] (NaN becomes 0, so no NaN leaves an evaluator through t).
pub(crate) fn clamp01<S: Real>(t: S) -> S {
    if t > S::ONE {
        S::ONE
    } else if t >= S::ZERO {
        t
    } else {
        S::ZERO
    }
}

/// De Casteljau evaluation of the control polygon `ctrl` at `t` (unchecked kernel; `ctrl` non-empty).
///
/// ```
/// use glam::DVec2;
/// let c = [DVec2::new(0., 0.), DVec2::new(1., 2.), DVec2::new(3., 2.), DVec2::new(4., 0.)];
/// assert_eq!(gregvox::geom::bezier::de_casteljau(&c, 0.5), DVec2::new(2.0, 1.5));
/// ```
pub fn de_casteljau<S: Real, P: Point<S>>(ctrl: &[P], t: S) -> P {
    let mut w: Vec<P> = ctrl.to_vec();
    let n = w.len();
    for r in 1..n {
        for i in 0..n - r {
            w[i] = w[i] * (S::ONE - t) + w[i + 1] * t;
        }
    }
    w[0]
}

/// A Bézier curve of degree `ctrl.len() − 1` over points `P` (2D, 3D, homogeneous 4D, f32 or f64).
///
/// ```
/// use gregvox::geom::bezier::Bezier;
/// use glam::DVec3;
/// let c = Bezier::new(vec![DVec3::ZERO, DVec3::X, DVec3::Y]).unwrap();
/// assert_eq!((c.degree(), c.ctrl().len()), (2, 3));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Bezier<S: Real, P: Point<S>> {
    ctrl: Vec<P>,
    _s: std::marker::PhantomData<S>,
}

impl<S: Real, P: Point<S>> Bezier<S, P> {
    /// A curve through the given control points; at least one, all finite.
    ///
    /// ```
    /// use gregvox::geom::bezier::Bezier;
    /// use glam::DVec2;
    /// assert!(Bezier::<f64, DVec2>::new(vec![]).is_err());
    /// assert_eq!(Bezier::new(vec![DVec2::ZERO, DVec2::X]).unwrap().degree(), 1);
    /// ```
    pub fn new(ctrl: Vec<P>) -> Result<Self> {
        if ctrl.is_empty() {
            return Err(Error::Invalid(
                "Bézier curve: needs at least one control point".into(),
            ));
        }
        check_finite(&ctrl, "Bézier control points")?;
        Ok(Bezier {
            ctrl,
            _s: std::marker::PhantomData,
        })
    }

    /// Degree n (number of control points − 1).
    ///
    /// ```
    /// use gregvox::geom::bezier::Bezier;
    /// assert_eq!(Bezier::<f64, f64>::new(vec![1.0]).unwrap().degree(), 0);
    /// ```
    pub fn degree(&self) -> usize {
        self.ctrl.len() - 1
    }

    /// The control points.
    ///
    /// ```
    /// use gregvox::geom::bezier::Bezier;
    /// assert_eq!(Bezier::<f64, f64>::new(vec![1.0, 2.0]).unwrap().ctrl(), &[1.0, 2.0]);
    /// ```
    pub fn ctrl(&self) -> &[P] {
        &self.ctrl
    }

    /// C(t) = Σ B_{i,n}(t) P_i, the definition of the notes.
    ///
    /// ```
    /// use gregvox::geom::bezier::Bezier;
    /// use glam::DVec2;
    /// let c = Bezier::new(vec![DVec2::new(0., 0.), DVec2::new(1., 2.), DVec2::new(3., 2.), DVec2::new(4., 0.)]).unwrap();
    /// assert!((c.eval_bernstein(0.5) - DVec2::new(2.0, 1.5)).length() < 1e-15);
    /// ```
    pub fn eval_bernstein(&self, t: S) -> P {
        let b = bernstein_all(self.degree(), clamp01(t));
        self.ctrl
            .iter()
            .zip(b)
            .fold(P::zero(), |acc, (&p, w)| acc + p * w)
    }

    /// C(t) by de Casteljau (the evaluator of record).
    ///
    /// ```
    /// use gregvox::geom::bezier::Bezier;
    /// use glam::DVec2;
    /// let c = Bezier::new(vec![DVec2::new(0., 0.), DVec2::new(1., 2.), DVec2::new(3., 2.), DVec2::new(4., 0.)]).unwrap();
    /// assert_eq!(c.eval(0.5), DVec2::new(2.0, 1.5));
    /// ```
    pub fn eval(&self, t: S) -> P {
        de_casteljau(&self.ctrl, clamp01(t))
    }

    /// Splits at `t` into [0, t] and [t, 1], each reparameterised to [0, 1] (the sides of the de
    /// Casteljau triangle).
    ///
    /// ```
    /// use gregvox::geom::bezier::Bezier;
    /// use glam::DVec2;
    /// let c = Bezier::new(vec![DVec2::new(0., 0.), DVec2::new(1., 2.), DVec2::new(3., 2.), DVec2::new(4., 0.)]).unwrap();
    /// let (a, b) = c.split(0.5);
    /// assert_eq!(a.ctrl()[3], DVec2::new(2.0, 1.5));
    /// assert_eq!(b.ctrl()[0], DVec2::new(2.0, 1.5));
    /// assert!((a.eval(0.5) - c.eval(0.25)).length() < 1e-15);
    /// ```
    pub fn split(&self, t: S) -> (Self, Self) {
        let t = clamp01(t);
        let n = self.ctrl.len();
        let mut w = self.ctrl.clone();
        let mut left = Vec::with_capacity(n);
        let mut right = vec![P::zero(); n];
        left.push(w[0]);
        right[n - 1] = w[n - 1];
        for r in 1..n {
            for i in 0..n - r {
                w[i] = w[i] * (S::ONE - t) + w[i + 1] * t;
            }
            left.push(w[0]);
            right[n - 1 - r] = w[n - 1 - r];
        }
        let mk = |ctrl| Bezier {
            ctrl,
            _s: std::marker::PhantomData,
        };
        (mk(left), mk(right))
    }

    /// The hodograph C′(t): degree n − 1 with points n (P_{i+1} − P_i); the derivative of a constant
    /// curve is the zero curve of degree 0.
    ///
    /// ```
    /// use gregvox::geom::bezier::Bezier;
    /// use glam::DVec2;
    /// let c = Bezier::new(vec![DVec2::new(0., 0.), DVec2::new(1., 2.), DVec2::new(3., 2.), DVec2::new(4., 0.)]).unwrap();
    /// assert_eq!(c.derivative().eval(0.5), DVec2::new(4.5, 0.0));
    /// assert_eq!(c.derivative().derivative().eval(0.5), DVec2::new(0.0, -12.0));
    /// ```
    pub fn derivative(&self) -> Self {
        let n = self.degree();
        let ctrl = if n == 0 {
            vec![P::zero()]
        } else {
            let s = S::from_usize(n);
            self.ctrl.windows(2).map(|w| (w[1] - w[0]) * s).collect()
        };
        Bezier {
            ctrl,
            _s: std::marker::PhantomData,
        }
    }

    /// C(t), C′(t), …, C⁽ᵏ⁾(t) (k + 1 values) from repeated hodographs.
    ///
    /// ```
    /// use gregvox::geom::bezier::Bezier;
    /// let c = Bezier::<f64, f64>::new(vec![0.0, 1.0, 3.0]).unwrap();  // 2t + t²
    /// assert_eq!(c.derivs(1.0, 3), vec![3.0, 4.0, 2.0, 0.0]);
    /// ```
    pub fn derivs(&self, t: S, k: usize) -> Vec<P> {
        let mut out = Vec::with_capacity(k + 1);
        let mut c = self.clone();
        for _ in 0..=k {
            out.push(c.eval(t));
            c = c.derivative();
        }
        out
    }

    /// Degree elevation by one: Q_i = (i/(n+1)) P_{i−1} + (1 − i/(n+1)) P_i; same curve, one more point.
    ///
    /// ```
    /// use gregvox::geom::bezier::Bezier;
    /// use glam::DVec2;
    /// let q = Bezier::new(vec![DVec2::new(0., 0.), DVec2::new(1., 2.), DVec2::new(2., 0.)]).unwrap().elevate();
    /// let want = [DVec2::new(0., 0.), DVec2::new(2. / 3., 4. / 3.), DVec2::new(4. / 3., 4. / 3.), DVec2::new(2., 0.)];
    /// for (a, b) in q.ctrl().iter().zip(want) { assert!((*a - b).length() < 1e-15); }
    /// ```
    pub fn elevate(&self) -> Self {
        let n = self.degree();
        let np1 = S::from_usize(n + 1);
        let mut ctrl = Vec::with_capacity(n + 2);
        ctrl.push(self.ctrl[0]);
        for i in 1..=n {
            let a = S::from_usize(i) / np1;
            ctrl.push(self.ctrl[i - 1] * a + self.ctrl[i] * (S::ONE - a));
        }
        ctrl.push(self.ctrl[n]);
        Bezier {
            ctrl,
            _s: std::marker::PhantomData,
        }
    }
}

/// A rational Bézier curve in 3D: control points with positive weights, evaluated in homogeneous
/// coordinates (x·w, y·w, z·w, w) and projected.
///
/// ```
/// use gregvox::geom::bezier::RationalBezier;
/// use glam::DVec3;
/// // weights 1 everywhere: the ordinary Bézier curve
/// let c = RationalBezier::new(&[DVec3::ZERO, DVec3::X * 2.0], &[1.0, 1.0]).unwrap();
/// assert_eq!((c.degree(), c.eval(0.5)), (1, DVec3::X));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct RationalBezier {
    hom: Bezier<f64, DVec4>,
}

impl RationalBezier {
    /// From Cartesian control points and weights (same count, at least one, weights finite and > 0).
    ///
    /// ```
    /// use gregvox::geom::bezier::RationalBezier;
    /// use glam::DVec3;
    /// let w = std::f64::consts::FRAC_1_SQRT_2;
    /// let q = RationalBezier::new(&[DVec3::X, DVec3::new(1., 1., 0.), DVec3::Y], &[1., w, 1.]).unwrap();
    /// assert!((q.eval(0.3).length() - 1.0).abs() < 1e-15);
    /// assert!(RationalBezier::new(&[DVec3::X], &[0.0]).is_err());
    /// ```
    pub fn new(ctrl: &[glam::DVec3], weights: &[f64]) -> Result<Self> {
        let hom = super::nurbs::homogeneous(ctrl, weights)?;
        Ok(RationalBezier {
            hom: Bezier::new(hom)?,
        })
    }

    /// Degree.
    ///
    /// ```
    /// use gregvox::geom::bezier::RationalBezier;
    /// use glam::DVec3;
    /// assert_eq!(RationalBezier::new(&[DVec3::ZERO; 4], &[1.0; 4]).unwrap().degree(), 3);
    /// ```
    pub fn degree(&self) -> usize {
        self.hom.degree()
    }

    /// C(t).
    ///
    /// ```
    /// use gregvox::geom::bezier::RationalBezier;
    /// use glam::DVec3;
    /// // a heavy middle weight pulls the curve towards its control point
    /// let c = RationalBezier::new(&[DVec3::ZERO, DVec3::Y, DVec3::X], &[1.0, 10.0, 1.0]).unwrap();
    /// assert!(c.eval(0.5).y > 0.9);
    /// ```
    pub fn eval(&self, t: f64) -> glam::DVec3 {
        let h = self.hom.eval(t);
        h.truncate() / h.w
    }

    /// C(t), C′(t), C″(t) by the quotient rule on the homogeneous curve (A = wC):
    /// C′ = (A′ − w′C)/w, C″ = (A″ − 2w′C′ − w″C)/w.
    ///
    /// ```
    /// use gregvox::geom::bezier::RationalBezier;
    /// use glam::DVec3;
    /// let c = RationalBezier::new(&[DVec3::ZERO, DVec3::X], &[1.0, 1.0]).unwrap();
    /// assert_eq!(c.derivs2(0.5)[1], DVec3::X);
    /// ```
    pub fn derivs2(&self, t: f64) -> [glam::DVec3; 3] {
        let d = self.hom.derivs(t, 2);
        super::nurbs::rational_derivs2(&d)
    }
}
