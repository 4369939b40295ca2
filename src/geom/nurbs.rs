//! NURBS curves: B-splines with positive weights, evaluated in homogeneous form and projected.
//!
//! Conventions: control points are Cartesian with a separate weight each (geomdl `ctrlpts` + `weights`;
//! geomdl's `ctrlptsw` is the premultiplied form (x·w, y·w, z·w, w)). Weights must be finite and > 0, which
//! keeps the denominator w(u) = Σ N_i w_i positive everywhere (the basis is a partition of unity), so
//! evaluation never divides by zero. Derivatives are those of the rational curve (quotient rule on the
//! homogeneous curve A = w·C), with respect to the stored knot parameter.
use super::bspline::{
    check_knots, clamped_uniform_knots, curve_derivs_raw, insert_knot_raw, split_raw,
};
use super::real::{check_finite, Point, Real};
use crate::{Error, Result};
use glam::{DVec3, DVec4};

/// Premultiplied homogeneous points (x·w, y·w, z·w, w), validating counts, finiteness and w > 0.
///
/// ```
/// use glam::{DVec3, DVec4};
/// let h = gregvox::geom::nurbs::homogeneous(&[DVec3::new(1., 2., 3.)], &[2.0]).unwrap();
/// assert_eq!(h, vec![DVec4::new(2., 4., 6., 2.)]);
/// assert!(gregvox::geom::nurbs::homogeneous(&[DVec3::ZERO], &[]).is_err());
/// ```
pub fn homogeneous(ctrl: &[DVec3], weights: &[f64]) -> Result<Vec<DVec4>> {
    check_weights(ctrl.len(), weights)?;
    check_finite(ctrl, "control points")?;
    Ok(ctrl
        .iter()
        .zip(weights)
        .map(|(p, &w)| (*p * w).extend(w))
        .collect())
}

pub(crate) fn check_weights<S: Real>(n_ctrl: usize, weights: &[S]) -> Result<()> {
    if weights.len() != n_ctrl {
        return Err(Error::Invalid(format!(
            "NURBS: {n_ctrl} control points but {} weights",
            weights.len()
        )));
    }
    if let Some(i) = weights
        .iter()
        .position(|w| !(w.is_finite() && *w > S::ZERO))
    {
        return Err(Error::Invalid(format!(
            "NURBS: weight {i} = {:?} must be finite and > 0",
            weights[i]
        )));
    }
    Ok(())
}

/// C, C′, C″ of a rational curve from the homogeneous derivatives A, A′, A″ (w in the last component).
pub(crate) fn rational_derivs2(d: &[DVec4]) -> [DVec3; 3] {
    let w = |i: usize| d.get(i).map_or(0.0, |h| h.w);
    let a = |i: usize| d.get(i).map_or(DVec3::ZERO, |h| h.truncate());
    let c0 = a(0) / w(0);
    let c1 = (a(1) - c0 * w(1)) / w(0);
    let c2 = (a(2) - c1 * (2.0 * w(1)) - c0 * w(2)) / w(0);
    [c0, c1, c2]
}

/// Derivatives C⁽ᵏ⁾, k = 0..=nd, of a rational curve from the homogeneous ones (A = w·C, *The NURBS Book*
/// eq. 4.8): C⁽ᵏ⁾ = (A⁽ᵏ⁾ − Σ_{i=1..k} C(k,i) w⁽ⁱ⁾ C⁽ᵏ⁻ⁱ⁾) / w.
pub(crate) fn rational_derivs<S: Real, P: Point<S>>(a: &[P], w: &[S]) -> Vec<P> {
    let mut c: Vec<P> = Vec::with_capacity(a.len());
    for k in 0..a.len() {
        let mut v = a[k];
        for i in 1..=k {
            v = v - c[k - i] * (super::real::binomial::<S>(k, i) * w[i]);
        }
        c.push(v * (S::ONE / w[0]));
    }
    c
}

/// A NURBS curve over points `P` (f64 or f32): degree, knots, Cartesian control points and weights.
///
/// ```
/// use gregvox::geom::nurbs::NurbsCurve;
/// let c = NurbsCurve::<f64, f64>::new(1, vec![0., 0., 1., 1.], vec![0.0, 1.0], vec![1.0, 3.0]).unwrap();
/// assert_eq!((c.degree(), c.knots().len(), c.ctrl(), c.weights()), (1, 4, &[0.0, 1.0][..], &[1.0, 3.0][..]));
/// assert_eq!(c.eval(0.5), 0.75); // (0·1 + 1·3)·½ / ((1 + 3)·½)
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct NurbsCurve<S: Real, P: Point<S>> {
    degree: usize,
    knots: Vec<S>,
    ctrl: Vec<P>,
    weights: Vec<S>,
    /// premultiplied points w·P, kept so evaluation is one pass
    wctrl: Vec<P>,
}

impl<S: Real, P: Point<S>> NurbsCurve<S, P> {
    /// Validates knots (see [`check_knots`]), weights (count, finite, > 0) and points.
    ///
    /// ```
    /// use gregvox::geom::nurbs::NurbsCurve;
    /// use glam::DVec2;
    /// let w = std::f64::consts::FRAC_1_SQRT_2;
    /// let q = NurbsCurve::new(2, vec![0., 0., 0., 1., 1., 1.], vec![DVec2::X, DVec2::ONE, DVec2::Y], vec![1., w, 1.]).unwrap();
    /// assert!((q.eval(0.37).length() - 1.0).abs() < 1e-15);
    /// assert!(NurbsCurve::new(2, vec![0., 0., 0., 1., 1., 1.], vec![DVec2::X, DVec2::ONE, DVec2::Y], vec![1., -1., 1.]).is_err());
    /// ```
    pub fn new(degree: usize, knots: Vec<S>, ctrl: Vec<P>, weights: Vec<S>) -> Result<Self> {
        check_knots(degree, ctrl.len(), &knots)?;
        check_weights(ctrl.len(), &weights)?;
        check_finite(&ctrl, "NURBS control points")?;
        let wctrl = ctrl.iter().zip(&weights).map(|(&p, &w)| p * w).collect();
        Ok(NurbsCurve {
            degree,
            knots,
            ctrl,
            weights,
            wctrl,
        })
    }

    /// A rational Bézier curve as a NURBS (knots 0 and 1, each repeated degree + 1 times).
    ///
    /// ```
    /// use gregvox::geom::nurbs::NurbsCurve;
    /// let c = NurbsCurve::<f64, f64>::rational_bezier(vec![0.0, 1.0], vec![1.0, 1.0]).unwrap();
    /// assert_eq!(c.eval(0.5), 0.5);
    /// ```
    pub fn rational_bezier(ctrl: Vec<P>, weights: Vec<S>) -> Result<Self> {
        let p = ctrl.len().saturating_sub(1);
        Self::new(p, clamped_uniform_knots(p, ctrl.len()), ctrl, weights)
    }

    /// Degree p.
    ///
    /// ```
    /// let c = gregvox::geom::nurbs::NurbsCurve::<f64, f64>::new(1, vec![0., 0., 1., 1.], vec![0.0, 1.0], vec![1.0, 3.0]).unwrap();
    /// assert_eq!(c.degree(), 1);
    /// ```
    pub fn degree(&self) -> usize {
        self.degree
    }
    /// Knots.
    ///
    /// ```
    /// let c = gregvox::geom::nurbs::NurbsCurve::<f64, f64>::new(1, vec![0., 0., 1., 1.], vec![0.0, 1.0], vec![1.0, 3.0]).unwrap();
    /// assert_eq!(c.knots(), &[0., 0., 1., 1.]);
    /// ```
    pub fn knots(&self) -> &[S] {
        &self.knots
    }
    /// Cartesian control points.
    ///
    /// ```
    /// let c = gregvox::geom::nurbs::NurbsCurve::<f64, f64>::new(1, vec![0., 0., 1., 1.], vec![0.0, 1.0], vec![1.0, 3.0]).unwrap();
    /// assert_eq!(c.ctrl(), &[0.0, 1.0]);
    /// ```
    pub fn ctrl(&self) -> &[P] {
        &self.ctrl
    }
    /// Weights.
    ///
    /// ```
    /// let c = gregvox::geom::nurbs::NurbsCurve::<f64, f64>::new(1, vec![0., 0., 1., 1.], vec![0.0, 1.0], vec![1.0, 3.0]).unwrap();
    /// assert_eq!(c.weights(), &[1.0, 3.0]);
    /// ```
    pub fn weights(&self) -> &[S] {
        &self.weights
    }

    /// C(u) = Σ N_i w_i P_i / Σ N_i w_i.
    ///
    /// ```
    /// use gregvox::geom::nurbs::NurbsCurve;
    /// use glam::DVec3;
    /// let pts = [[0.,0.,0.],[1.,2.,0.],[3.,3.,1.],[4.,1.,2.],[6.,0.,1.],[7.,2.,0.],[9.,3.,1.]].map(DVec3::from);
    /// let c = NurbsCurve::new(3, vec![0.,0.,0.,0.,0.25,0.5,0.75,1.,1.,1.,1.], pts.to_vec(),
    ///                         vec![1., 0.5, 2., 1., 3., 0.7, 1.]).unwrap();
    /// assert!((c.eval(0.3) - DVec3::new(3.109170306, 2.579912664, 1.143231441)).length() < 1e-9);
    /// ```
    pub fn eval(&self, u: S) -> P {
        self.derivs(u, 0)[0]
    }

    /// C(u), C′(u), …, C⁽ᵏ⁾(u) of the rational curve.
    ///
    /// ```
    /// use gregvox::geom::nurbs::NurbsCurve;
    /// use glam::DVec2;
    /// let w = std::f64::consts::FRAC_1_SQRT_2;
    /// let q = NurbsCurve::new(2, vec![0., 0., 0., 1., 1., 1.], vec![DVec2::X, DVec2::ONE, DVec2::Y], vec![1., w, 1.]).unwrap();
    /// let d = q.derivs(0.5, 1);
    /// assert!(d[0].dot(d[1]).abs() < 1e-15); // tangent ⟂ radius on a circle
    /// ```
    pub fn derivs(&self, u: S, k: usize) -> Vec<P> {
        let a = curve_derivs_raw(self.degree, &self.knots, &self.wctrl, u, k);
        let w = curve_derivs_raw(self.degree, &self.knots, &self.weights, u, k);
        rational_derivs(&a, &w)
    }

    /// Knot insertion on the homogeneous form (the curve is unchanged).
    ///
    /// ```
    /// use gregvox::geom::nurbs::NurbsCurve;
    /// let c = NurbsCurve::<f64, f64>::new(2, vec![0., 0., 0., 1., 1., 1.], vec![0., 1., 0.], vec![1., 2., 1.]).unwrap();
    /// let d = c.insert_knot(0.25, 2).unwrap();
    /// assert_eq!(d.ctrl().len(), 5);
    /// assert!((d.eval(0.6) - c.eval(0.6)).abs() < 1e-15);
    /// ```
    pub fn insert_knot(&self, u: S, times: usize) -> Result<Self> {
        let (knots, wctrl) = insert_knot_raw(self.degree, &self.knots, &self.wctrl, u, times)?;
        let (_, weights) = insert_knot_raw(self.degree, &self.knots, &self.weights, u, times)?;
        Ok(self.with_homogeneous(knots, wctrl, weights))
    }

    /// Splits at u (strictly inside the domain) into two NURBS curves.
    ///
    /// ```
    /// use gregvox::geom::nurbs::NurbsCurve;
    /// let c = NurbsCurve::<f64, f64>::new(2, vec![0., 0., 0., 1., 1., 1.], vec![0., 1., 0.], vec![1., 2., 1.]).unwrap();
    /// let (a, b) = c.split(0.5).unwrap();
    /// assert!((a.eval(0.25) - c.eval(0.25)).abs() < 1e-15 && (b.eval(0.75) - c.eval(0.75)).abs() < 1e-15);
    /// ```
    pub fn split(&self, u: S) -> Result<(Self, Self)> {
        let [(lk, lq), (rk, rq)] = split_raw(self.degree, &self.knots, &self.wctrl, u)?;
        let [(_, lw), (_, rw)] = split_raw(self.degree, &self.knots, &self.weights, u)?;
        Ok((
            self.with_homogeneous(lk, lq, lw),
            self.with_homogeneous(rk, rq, rw),
        ))
    }

    fn with_homogeneous(&self, knots: Vec<S>, wctrl: Vec<P>, weights: Vec<S>) -> Self {
        let ctrl = wctrl
            .iter()
            .zip(&weights)
            .map(|(&p, &w)| p * (S::ONE / w))
            .collect();
        NurbsCurve {
            degree: self.degree,
            knots,
            ctrl,
            weights,
            wctrl,
        }
    }
}
