//! Tensor-product surfaces: N×M Bézier, rational Bézier, B-spline and NURBS, with positions, first and
//! second partial derivatives, normals, Gaussian and mean curvature.
//!
//! Conventions: control points (and weights) are a flat array indexed `i * size_v + j`, i along u and j
//! along v (v fastest), exactly geomdl's order. One evaluator serves all four kinds: a Bézier patch is the
//! B-spline with knots {0^(p+1), 1^(p+1)}, and non-rational surfaces skip the division (so they are not
//! perturbed by a Σ N ≠ 1 rounding). Rational derivatives follow from A = w·S by the quotient rule;
//! weights are > 0, so w(u, v) > 0 everywhere.
use super::bspline::{
    check_knots, clamp_domain, clamped_uniform_knots, ders_basis_funs, find_span,
};
use super::curvature::{gaussian_mean_curvature, surface_normal};
use super::nurbs::check_weights;
use super::real::{check_finite, Point, Real};
use crate::{Error, Result};
use glam::DVec3;

/// Position and partial derivatives up to order 2 at one (u, v).
///
/// ```
/// use gregvox::geom::surface::NurbsSurface;
/// use glam::DVec3;
/// let s = NurbsSurface::bezier([2, 2], vec![DVec3::ZERO, DVec3::Y, DVec3::X, DVec3::new(1., 1., 1.)]).unwrap();
/// let d = s.derivs(0.5, 0.5);
/// assert_eq!((d.p, d.suv), (DVec3::new(0.5, 0.5, 0.25), DVec3::Z));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceDerivs<P> {
    /// S(u, v)
    pub p: P,
    /// ∂S/∂u
    pub su: P,
    /// ∂S/∂v
    pub sv: P,
    /// ∂²S/∂u²
    pub suu: P,
    /// ∂²S/∂u∂v
    pub suv: P,
    /// ∂²S/∂v²
    pub svv: P,
}

impl SurfaceDerivs<DVec3> {
    /// Unit normal S_u × S_v / |…|, `None` at a singular point.
    ///
    /// ```
    /// use gregvox::geom::surface::SurfaceDerivs;
    /// use glam::DVec3;
    /// let d = SurfaceDerivs { p: DVec3::ZERO, su: DVec3::X, sv: DVec3::Y, suu: DVec3::ZERO, suv: DVec3::ZERO, svv: DVec3::ZERO };
    /// assert_eq!(d.normal(), Some(DVec3::Z));
    /// ```
    pub fn normal(&self) -> Option<DVec3> {
        surface_normal(self.su, self.sv)
    }

    /// (Gaussian K, mean H), see [`gaussian_mean_curvature`].
    ///
    /// ```
    /// use gregvox::geom::surface::SurfaceDerivs;
    /// use glam::DVec3;
    /// let d = SurfaceDerivs { p: DVec3::ZERO, su: DVec3::X, sv: DVec3::Y, suu: DVec3::ZERO, suv: DVec3::ZERO, svv: DVec3::ZERO };
    /// assert_eq!(d.curvature(), Some((0.0, 0.0)));
    /// ```
    pub fn curvature(&self) -> Option<(f64, f64)> {
        gaussian_mean_curvature(self.su, self.sv, self.suu, self.suv, self.svv)
    }
}

/// A tensor-product B-spline or NURBS surface (Bézier and rational Bézier patches are special cases).
///
/// ```
/// use gregvox::geom::surface::NurbsSurface;
/// let s = NurbsSurface::<f64, f64>::rational_bezier([2, 3], vec![0., 0., 0., 1., 1., 1.], vec![1.; 6]).unwrap();
/// assert_eq!((s.degree(), s.size(), s.ctrl().len(), s.weights().map(|w| w.len())), ([1, 2], [2, 3], 6, Some(6)));
/// assert_eq!(s.eval(0.25, 0.9), 0.25);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct NurbsSurface<S: Real, P: Point<S>> {
    degree: [usize; 2],
    size: [usize; 2],
    knots_u: Vec<S>,
    knots_v: Vec<S>,
    ctrl: Vec<P>,
    /// `None` for non-rational surfaces
    weights: Option<Vec<S>>,
    wctrl: Vec<P>,
}

impl<S: Real, P: Point<S>> NurbsSurface<S, P> {
    /// A general surface: degrees (p_u, p_v), grid size (n_u, n_v), knots in u and v, `n_u·n_v` control
    /// points (v fastest) and optionally as many weights (finite, > 0).
    ///
    /// ```
    /// use gregvox::geom::surface::NurbsSurface;
    /// use glam::DVec3;
    /// let k = vec![0., 0., 1., 1.];
    /// let ctrl = vec![DVec3::ZERO, DVec3::Y, DVec3::X, DVec3::new(1., 1., 0.)];
    /// let s = NurbsSurface::new([1, 1], [2, 2], k.clone(), k.clone(), ctrl.clone(), None).unwrap();
    /// assert_eq!(s.eval(0.25, 0.5), DVec3::new(0.25, 0.5, 0.0));
    /// assert!(NurbsSurface::new([1, 1], [2, 2], k.clone(), k, ctrl[..3].to_vec(), None).is_err());
    /// ```
    pub fn new(
        degree: [usize; 2],
        size: [usize; 2],
        knots_u: Vec<S>,
        knots_v: Vec<S>,
        ctrl: Vec<P>,
        weights: Option<Vec<S>>,
    ) -> Result<Self> {
        check_knots(degree[0], size[0], &knots_u)
            .map_err(|e| Error::Invalid(format!("surface, u direction: {e}")))?;
        check_knots(degree[1], size[1], &knots_v)
            .map_err(|e| Error::Invalid(format!("surface, v direction: {e}")))?;
        if ctrl.len() != size[0] * size[1] {
            return Err(Error::Invalid(format!(
                "surface: a {}×{} grid needs {} control points, got {}",
                size[0],
                size[1],
                size[0] * size[1],
                ctrl.len()
            )));
        }
        check_finite(&ctrl, "surface control points")?;
        let wctrl = match &weights {
            Some(w) => {
                check_weights(ctrl.len(), w)?;
                ctrl.iter().zip(w).map(|(&p, &w)| p * w).collect()
            }
            None => ctrl.clone(),
        };
        Ok(NurbsSurface {
            degree,
            size,
            knots_u,
            knots_v,
            ctrl,
            weights,
            wctrl,
        })
    }

    /// An N×M Bézier patch: `size = [deg_u + 1, deg_v + 1]`, control points v fastest.
    ///
    /// ```
    /// use gregvox::geom::surface::NurbsSurface;
    /// use glam::DVec3;
    /// let ctrl: Vec<DVec3> = (0..4).flat_map(|i| (0..4).map(move |j| DVec3::new(i as f64, j as f64, 0.0))).collect();
    /// let s = NurbsSurface::bezier([4, 4], ctrl).unwrap();
    /// assert_eq!(s.eval(0.5, 0.5), DVec3::new(1.5, 1.5, 0.0));
    /// ```
    pub fn bezier(size: [usize; 2], ctrl: Vec<P>) -> Result<Self> {
        Self::rational_bezier_opt(size, ctrl, None)
    }

    /// An N×M rational Bézier patch.
    ///
    /// ```
    /// use gregvox::geom::surface::NurbsSurface;
    /// use glam::DVec3;
    /// // a quarter cylinder: rational quadratic arc in u, line in v
    /// let w = std::f64::consts::FRAC_1_SQRT_2;
    /// let ctrl = vec![DVec3::X, DVec3::new(1., 0., 1.), DVec3::new(1., 1., 0.), DVec3::new(1., 1., 1.), DVec3::Y, DVec3::new(0., 1., 1.)];
    /// let s = NurbsSurface::rational_bezier([3, 2], ctrl, vec![1., 1., w, w, 1., 1.]).unwrap();
    /// let p = s.eval(0.3, 0.7);
    /// assert!((p.truncate().length() - 1.0).abs() < 1e-15 && (p.z - 0.7).abs() < 1e-15);
    /// ```
    pub fn rational_bezier(size: [usize; 2], ctrl: Vec<P>, weights: Vec<S>) -> Result<Self> {
        Self::rational_bezier_opt(size, ctrl, Some(weights))
    }

    fn rational_bezier_opt(
        size: [usize; 2],
        ctrl: Vec<P>,
        weights: Option<Vec<S>>,
    ) -> Result<Self> {
        let d = [size[0].saturating_sub(1), size[1].saturating_sub(1)];
        let (ku, kv) = (
            clamped_uniform_knots(d[0], size[0]),
            clamped_uniform_knots(d[1], size[1]),
        );
        Self::new(d, size, ku, kv, ctrl, weights)
    }

    /// Degrees (p_u, p_v).
    ///
    /// ```
    /// let s = gregvox::geom::surface::NurbsSurface::<f64, f64>::bezier([2, 2], vec![0., 1., 2., 3.]).unwrap();
    /// assert_eq!(s.degree(), [1, 1]);
    /// ```
    pub fn degree(&self) -> [usize; 2] {
        self.degree
    }
    /// Grid size (n_u, n_v).
    ///
    /// ```
    /// let s = gregvox::geom::surface::NurbsSurface::<f64, f64>::bezier([2, 2], vec![0., 1., 2., 3.]).unwrap();
    /// assert_eq!(s.size(), [2, 2]);
    /// ```
    pub fn size(&self) -> [usize; 2] {
        self.size
    }
    /// Control points (v fastest).
    ///
    /// ```
    /// let s = gregvox::geom::surface::NurbsSurface::<f64, f64>::bezier([2, 2], vec![0., 1., 2., 3.]).unwrap();
    /// assert_eq!(s.ctrl()[3], 3.0);
    /// ```
    pub fn ctrl(&self) -> &[P] {
        &self.ctrl
    }
    /// Weights, if rational.
    ///
    /// ```
    /// let s = gregvox::geom::surface::NurbsSurface::<f64, f64>::bezier([2, 2], vec![0., 1., 2., 3.]).unwrap();
    /// assert_eq!(s.weights(), None);
    /// ```
    pub fn weights(&self) -> Option<&[S]> {
        self.weights.as_deref()
    }

    /// S(u, v).
    ///
    /// ```
    /// let s = gregvox::geom::surface::NurbsSurface::<f64, f64>::bezier([2, 2], vec![0., 1., 2., 3.]).unwrap();
    /// assert_eq!(s.eval(0.5, 0.5), 1.5);
    /// ```
    pub fn eval(&self, u: S, v: S) -> P {
        self.derivs(u, v).p
    }

    /// Position and all partial derivatives up to order 2.
    ///
    /// ```
    /// use gregvox::geom::surface::NurbsSurface;
    /// use glam::DVec3;
    /// // z = u·v on the unit square (bilinear): S_uv = (0, 0, 1)
    /// let ctrl = vec![DVec3::ZERO, DVec3::Y, DVec3::X, DVec3::ONE];
    /// let d = NurbsSurface::bezier([2, 2], ctrl).unwrap().derivs(0.3, 0.6);
    /// assert_eq!(d.suv, DVec3::Z);
    /// assert_eq!(d.suu, DVec3::ZERO);
    /// ```
    pub fn derivs(&self, u: S, v: S) -> SurfaceDerivs<P> {
        let [pu, pv] = self.degree;
        let [nu, nv] = self.size;
        let u = clamp_domain(pu, nu, &self.knots_u, u);
        let v = clamp_domain(pv, nv, &self.knots_v, v);
        let su = find_span(pu, nu, u, &self.knots_u);
        let sv = find_span(pv, nv, v, &self.knots_v);
        let bu = ders_basis_funs(su, pu, u, 2, &self.knots_u);
        let bv = ders_basis_funs(sv, pv, v, 2, &self.knots_v);
        let contract = |pts: &dyn Fn(usize) -> P, k: usize, l: usize| -> P {
            let mut acc = P::zero();
            for a in 0..=pu {
                let mut row = P::zero();
                for b in 0..=pv {
                    row = row + pts((su - pu + a) * nv + (sv - pv + b)) * bv[l][b];
                }
                acc = acc + row * bu[k][a];
            }
            acc
        };
        let kl = [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)];
        let a: Vec<P> = kl
            .iter()
            .map(|&(k, l)| contract(&|i| self.wctrl[i], k, l))
            .collect();
        let Some(wts) = &self.weights else {
            return SurfaceDerivs {
                p: a[0],
                su: a[1],
                sv: a[2],
                suu: a[3],
                suv: a[4],
                svv: a[5],
            };
        };
        let mut w = [S::ZERO; 6];
        for (slot, &(k, l)) in w.iter_mut().zip(kl.iter()) {
            let mut acc = S::ZERO;
            for aa in 0..=pu {
                for b in 0..=pv {
                    acc += wts[(su - pu + aa) * nv + (sv - pv + b)] * bu[k][aa] * bv[l][b];
                }
            }
            *slot = acc;
        }
        let inv = S::ONE / w[0];
        let two = S::from_f64(2.0);
        let p = a[0] * inv;
        let s_u = (a[1] - p * w[1]) * inv;
        let s_v = (a[2] - p * w[2]) * inv;
        let suu = (a[3] - s_u * (two * w[1]) - p * w[3]) * inv;
        let suv = (a[4] - p * w[4] - s_v * w[1] - s_u * w[2]) * inv;
        let svv = (a[5] - s_v * (two * w[2]) - p * w[5]) * inv;
        SurfaceDerivs {
            p,
            su: s_u,
            sv: s_v,
            suu,
            suv,
            svv,
        }
    }
}

/// A bicubic Bézier patch b[row = v index][col = u index] evaluated by tensor de Casteljau (the shader's
/// way: four curves in u, then one in v).
///
/// ```
/// use gregvox::geom::surface::bicubic_bezier;
/// use glam::DVec3;
/// let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| DVec3::new(i as f64, j as f64, 0.0)));
/// assert_eq!(bicubic_bezier(&b, 0.5, 0.25), DVec3::new(1.5, 0.75, 0.0));
/// ```
pub fn bicubic_bezier(b: &[[DVec3; 4]; 4], u: f64, v: f64) -> DVec3 {
    let rows: Vec<DVec3> = b
        .iter()
        .map(|row| super::bezier::de_casteljau(row, u))
        .collect();
    super::bezier::de_casteljau(&rows, v)
}
