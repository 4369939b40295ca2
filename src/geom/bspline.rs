//! B-spline basis functions (Cox–de Boor), span search, B-spline curves, knot insertion and split.
//!
//! Conventions (as geomdl and *The NURBS Book*): degree p, not order; n control points need n + p + 1
//! non-decreasing knots; the curve is defined on [`U[p]`, `U[n]`] and parameters outside are clamped to it.
//! Clamped (open) knot vectors repeat the end knots p + 1 times, so the curve interpolates the end control
//! points; arbitrary non-decreasing vectors are accepted as long as that domain is not empty. At u = `U[n]`
//! the last non-empty span is used (the left limit), so the end point is reached exactly.
use super::real::{check_finite, Point, Real};
use crate::{Error, Result};

/// Validates a (degree, number of control points, knot vector) triple; the message names the problem.
///
/// ```
/// use gregvox::geom::bspline::check_knots;
/// assert!(check_knots(3, 7, &[0., 0., 0., 0., 0.25, 0.5, 0.75, 1., 1., 1., 1.]).is_ok());
/// assert!(check_knots(3, 7, &[0., 0., 0., 0., 0.5, 0.25, 0.75, 1., 1., 1., 1.]).is_err()); // decreasing
/// assert!(check_knots(0, 2, &[0., 0.5, 1.]).is_err()); // degree 0
/// assert!(check_knots(3, 3, &[0., 0., 0., 1., 1., 1.]).is_err()); // degree > n - 1
/// ```
pub fn check_knots<S: Real>(degree: usize, n_ctrl: usize, knots: &[S]) -> Result<()> {
    if degree == 0 {
        return Err(Error::Invalid(
            "B-spline: degree 0 is not supported (degree, not order: use ≥ 1)".into(),
        ));
    }
    if n_ctrl < degree + 1 {
        return Err(Error::Invalid(format!(
            "B-spline: degree {degree} needs at least {} control points, got {n_ctrl}",
            degree + 1
        )));
    }
    if knots.len() != n_ctrl + degree + 1 {
        return Err(Error::Invalid(format!(
            "B-spline: {n_ctrl} control points of degree {degree} need {} knots, got {}",
            n_ctrl + degree + 1,
            knots.len()
        )));
    }
    if let Some(i) = knots.iter().position(|k| !k.is_finite()) {
        return Err(Error::Invalid(format!("B-spline: knot {i} is not finite")));
    }
    if let Some(i) = knots.windows(2).position(|w| !(w[0] <= w[1])) {
        return Err(Error::Invalid(format!(
            "B-spline: knot vector is not non-decreasing at index {} ({:?} > {:?})",
            i + 1,
            knots[i],
            knots[i + 1]
        )));
    }
    if !(knots[degree] < knots[n_ctrl]) {
        return Err(Error::Invalid(format!(
            "B-spline: empty parameter domain [U[{degree}], U[{n_ctrl}]] = [{:?}, {:?}]",
            knots[degree], knots[n_ctrl]
        )));
    }
    Ok(())
}

/// The clamped uniform ("open uniform") knot vector on [0, 1] for `n_ctrl` points of degree `degree`.
///
/// ```
/// let k = gregvox::geom::bspline::clamped_uniform_knots::<f64>(3, 7);
/// assert_eq!(k, vec![0., 0., 0., 0., 0.25, 0.5, 0.75, 1., 1., 1., 1.]);
/// ```
pub fn clamped_uniform_knots<S: Real>(degree: usize, n_ctrl: usize) -> Vec<S> {
    let inner = n_ctrl.saturating_sub(degree + 1);
    let mut k = vec![S::ZERO; degree + 1];
    for i in 1..=inner {
        k.push(S::from_f64(i as f64 / (inner + 1) as f64));
    }
    k.extend(std::iter::repeat_n(S::ONE, degree + 1));
    k
}

/// Span index k with `U[k]` ≤ u < `U[k+1]`, k ∈ [p, n−1] (binary search, *The NURBS Book* A2.1); u is clamped
/// to the domain and u = `U[n]` maps to the last non-empty span.
///
/// ```
/// let k = [0., 0., 0., 0., 0.25, 0.5, 0.75, 1., 1., 1., 1.];
/// use gregvox::geom::bspline::find_span;
/// assert_eq!(find_span(3, 7, 0.3, &k), 4);
/// assert_eq!(find_span(3, 7, 0.25, &k), 4);
/// assert_eq!(find_span(3, 7, 1.0, &k), 6);
/// assert_eq!(find_span(3, 7, 0.0, &k), 3);
/// ```
pub fn find_span<S: Real>(degree: usize, n_ctrl: usize, u: S, knots: &[S]) -> usize {
    let p = degree;
    let n = n_ctrl - 1;
    if u >= knots[n + 1] {
        // last non-empty span
        let mut k = n;
        while k > p && !(knots[k] < knots[k + 1]) {
            k -= 1;
        }
        return k;
    }
    if !(u > knots[p]) {
        let mut k = p;
        while k < n && !(knots[k] < knots[k + 1]) {
            k += 1;
        }
        return k;
    }
    let (mut lo, mut hi) = (p, n + 1);
    let mut mid = (lo + hi) / 2;
    while u < knots[mid] || u >= knots[mid + 1] {
        if u < knots[mid] {
            hi = mid;
        } else {
            lo = mid;
        }
        mid = (lo + hi) / 2;
    }
    mid
}

/// The p + 1 non-zero basis functions N_{k−p..=k, p}(u) on span k (Cox–de Boor, A2.2).
///
/// ```
/// let k = [0., 0., 0., 1., 1., 1.];
/// let n = gregvox::geom::bspline::basis_funs(2, 2, 0.5, &k);
/// assert_eq!(n, vec![0.25, 0.5, 0.25]);
/// ```
pub fn basis_funs<S: Real>(span: usize, degree: usize, u: S, knots: &[S]) -> Vec<S> {
    ders_basis_funs(span, degree, u, 0, knots).swap_remove(0)
}

/// Basis functions and their derivatives up to order `nd` on span k (A2.3): `ders[d][j]` is the d-th
/// derivative of N_{k−p+j, p}(u). Orders above p are zero.
///
/// ```
/// let k = [0., 0., 0., 0., 1., 1., 1., 1.];
/// let d = gregvox::geom::bspline::ders_basis_funs(3, 3, 0.5, 1, &k);
/// // derivatives of the cubic Bernstein basis at 1/2: 3(B_{i-1,2} − B_{i,2})
/// assert_eq!(d[1], vec![-0.75, -0.75, 0.75, 0.75]);
/// ```
pub fn ders_basis_funs<S: Real>(
    span: usize,
    degree: usize,
    u: S,
    nd: usize,
    knots: &[S],
) -> Vec<Vec<S>> {
    let p = degree;
    let i = span;
    let mut ndu = vec![vec![S::ZERO; p + 1]; p + 1];
    let mut left = vec![S::ZERO; p + 1];
    let mut right = vec![S::ZERO; p + 1];
    ndu[0][0] = S::ONE;
    for j in 1..=p {
        left[j] = u - knots[i + 1 - j];
        right[j] = knots[i + j] - u;
        let mut saved = S::ZERO;
        for r in 0..j {
            ndu[j][r] = right[r + 1] + left[j - r];
            let temp = ndu[r][j - 1] / ndu[j][r];
            ndu[r][j] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        ndu[j][j] = saved;
    }
    let mut ders = vec![vec![S::ZERO; p + 1]; nd + 1];
    for j in 0..=p {
        ders[0][j] = ndu[j][p];
    }
    let mut a = vec![vec![S::ZERO; p + 1]; 2];
    for r in 0..=p {
        let (mut s1, mut s2) = (0usize, 1usize);
        a[0][0] = S::ONE;
        for k in 1..=nd.min(p) {
            let mut d = S::ZERO;
            let rk = r as isize - k as isize;
            let pk = p - k;
            if r >= k {
                a[s2][0] = a[s1][0] / ndu[pk + 1][rk as usize];
                d = a[s2][0] * ndu[rk as usize][pk];
            }
            let j1 = if rk >= -1 { 1 } else { (-rk) as usize };
            let j2 = if (r as isize - 1) <= pk as isize {
                k - 1
            } else {
                p - r
            };
            for j in j1..=j2 {
                let idx = (rk + j as isize) as usize;
                a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][idx];
                d += a[s2][j] * ndu[idx][pk];
            }
            if r <= pk {
                a[s2][k] = -a[s1][k - 1] / ndu[pk + 1][r];
                d += a[s2][k] * ndu[r][pk];
            }
            ders[k][r] = d;
            std::mem::swap(&mut s1, &mut s2);
        }
    }
    let mut f = S::from_usize(p);
    for k in 1..=nd.min(p) {
        for j in 0..=p {
            ders[k][j] *= f;
        }
        f *= S::from_usize(p - k);
    }
    ders
}

/// C(u) and its derivatives up to order `nd` for raw (degree, knots, control points); unchecked kernel
/// shared by curves, NURBS (on homogeneous points) and surfaces.
pub(crate) fn curve_derivs_raw<S: Real, P: Point<S>>(
    degree: usize,
    knots: &[S],
    ctrl: &[P],
    u: S,
    nd: usize,
) -> Vec<P> {
    let n = ctrl.len();
    let u = clamp_domain(degree, n, knots, u);
    let span = find_span(degree, n, u, knots);
    let ders = ders_basis_funs(span, degree, u, nd, knots);
    (0..=nd)
        .map(|k| {
            (0..=degree).fold(P::zero(), |acc, j| {
                acc + ctrl[span - degree + j] * ders[k][j]
            })
        })
        .collect()
}

pub(crate) fn clamp_domain<S: Real>(degree: usize, n_ctrl: usize, knots: &[S], u: S) -> S {
    let (a, b) = (knots[degree], knots[n_ctrl]);
    if u > b {
        b
    } else if u >= a {
        u
    } else {
        a // also NaN
    }
}

/// Boehm knot insertion (A5.1) of `u`, `r` times, on raw data; returns (new knots, new points).
/// Linear in the points, so NURBS insert on (w·P, w) with the same call.
pub(crate) fn insert_knot_raw<S: Real, P: Point<S>>(
    degree: usize,
    knots: &[S],
    ctrl: &[P],
    u: S,
    r: usize,
) -> Result<(Vec<S>, Vec<P>)> {
    let p = degree;
    let n = ctrl.len();
    if !(u.is_finite() && u >= knots[p] && u <= knots[n]) {
        return Err(Error::Invalid(format!(
            "knot insertion: u = {u:?} is outside the domain [{:?}, {:?}]",
            knots[p], knots[n]
        )));
    }
    let s = knots.iter().filter(|&&k| k == u).count();
    if r + s > p {
        return Err(Error::Invalid(format!(
            "knot insertion: u = {u:?} has multiplicity {s}; inserting {r} more exceeds the degree {p}"
        )));
    }
    if r == 0 {
        return Ok((knots.to_vec(), ctrl.to_vec()));
    }
    // span with U[k] <= u < U[k+1] (for an existing knot: the span after its last copy)
    let k = knots.iter().rposition(|&x| x <= u).unwrap_or(p).min(n - 1);
    let mp = n + p; // last knot index
    let mut uq = Vec::with_capacity(knots.len() + r);
    uq.extend_from_slice(&knots[..=k]);
    uq.extend(std::iter::repeat_n(u, r));
    uq.extend_from_slice(&knots[k + 1..=mp]);
    let mut q = vec![P::zero(); n + r];
    q[..=(k - p)].copy_from_slice(&ctrl[..=(k - p)]);
    q[(k - s + r)..(n + r)].copy_from_slice(&ctrl[(k - s)..n]);
    let mut rw: Vec<P> = (0..=(p - s)).map(|i| ctrl[k - p + i]).collect();
    let mut l = 0;
    for j in 1..=r {
        l = k - p + j;
        for i in 0..=(p - j - s) {
            let alpha = (u - knots[l + i]) / (knots[i + k + 1] - knots[l + i]);
            rw[i] = rw[i + 1] * alpha + rw[i] * (S::ONE - alpha);
        }
        q[l] = rw[0];
        q[k + r - j - s] = rw[p - j - s];
    }
    if l + 1 < k - s {
        q[(l + 1)..(k - s)].copy_from_slice(&rw[1..(k - s - l)]);
    }
    Ok((uq, q))
}

/// Split raw data at u into two clamped pieces (knots in the original parameter).
pub(crate) fn split_raw<S: Real, P: Point<S>>(
    degree: usize,
    knots: &[S],
    ctrl: &[P],
    u: S,
) -> Result<[(Vec<S>, Vec<P>); 2]> {
    let p = degree;
    let n = ctrl.len();
    if !(u.is_finite() && u > knots[p] && u < knots[n]) {
        return Err(Error::Invalid(format!(
            "split: u = {u:?} must lie strictly inside the domain ({:?}, {:?})",
            knots[p], knots[n]
        )));
    }
    let s = knots.iter().filter(|&&k| k == u).count();
    let (kn, q) = insert_knot_raw(p, knots, ctrl, u, p.saturating_sub(s))?;
    let a = kn
        .iter()
        .position(|&x| x == u)
        .expect("inserted knot present");
    let mut lk = kn[..a + p].to_vec();
    lk.push(u);
    let lq = q[..a].to_vec();
    let mut rk = vec![u];
    rk.extend_from_slice(&kn[a..]);
    let rq = q[a - 1..].to_vec();
    Ok([(lk, lq), (rk, rq)])
}

/// A non-rational B-spline curve (degree, knots, control points), validated on construction.
///
/// ```
/// use gregvox::geom::bspline::BSplineCurve;
/// use glam::DVec2;
/// let c = BSplineCurve::clamped_uniform(2, vec![DVec2::ZERO, DVec2::X, DVec2::ONE, DVec2::Y]).unwrap();
/// assert_eq!((c.degree(), c.knots(), c.ctrl().len(), c.domain()), (2, &[0., 0., 0., 0.5, 1., 1., 1.][..], 4, (0.0, 1.0)));
/// assert_eq!(c.eval(0.0), DVec2::ZERO); // clamped: interpolates the end points
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct BSplineCurve<S: Real, P: Point<S>> {
    degree: usize,
    knots: Vec<S>,
    ctrl: Vec<P>,
}

impl<S: Real, P: Point<S>> BSplineCurve<S, P> {
    /// Validates with [`check_knots`] and finiteness of the points.
    ///
    /// ```
    /// use gregvox::geom::bspline::BSplineCurve;
    /// use glam::DVec3;
    /// let c = BSplineCurve::new(1, vec![0.0, 0.0, 1.0, 1.0], vec![DVec3::ZERO, DVec3::X]).unwrap();
    /// assert_eq!(c.eval(0.25), DVec3::new(0.25, 0.0, 0.0));
    /// assert!(BSplineCurve::new(2, vec![0.0, 0.0, 1.0, 1.0], vec![DVec3::ZERO, DVec3::X]).is_err());
    /// ```
    pub fn new(degree: usize, knots: Vec<S>, ctrl: Vec<P>) -> Result<Self> {
        check_knots(degree, ctrl.len(), &knots)?;
        check_finite(&ctrl, "B-spline control points")?;
        Ok(BSplineCurve {
            degree,
            knots,
            ctrl,
        })
    }

    /// A clamped uniform curve on [0, 1] through the given control points.
    ///
    /// ```
    /// use gregvox::geom::bspline::BSplineCurve;
    /// let c = BSplineCurve::<f64, f64>::clamped_uniform(2, vec![0.0, 1.0, 0.0]).unwrap();
    /// assert_eq!(c.eval(0.5), 0.5);
    /// ```
    pub fn clamped_uniform(degree: usize, ctrl: Vec<P>) -> Result<Self> {
        let k = clamped_uniform_knots(degree, ctrl.len());
        Self::new(degree, k, ctrl)
    }

    /// Degree p.
    ///
    /// ```
    /// let c = gregvox::geom::bspline::BSplineCurve::<f64, f64>::clamped_uniform(2, vec![0.0, 1.0, 0.0]).unwrap();
    /// assert_eq!(c.degree(), 2);
    /// ```
    pub fn degree(&self) -> usize {
        self.degree
    }
    /// Knot vector.
    ///
    /// ```
    /// let c = gregvox::geom::bspline::BSplineCurve::<f64, f64>::clamped_uniform(2, vec![0.0, 1.0, 0.0]).unwrap();
    /// assert_eq!(c.knots().len(), 6);
    /// ```
    pub fn knots(&self) -> &[S] {
        &self.knots
    }
    /// Control points.
    ///
    /// ```
    /// let c = gregvox::geom::bspline::BSplineCurve::<f64, f64>::clamped_uniform(2, vec![0.0, 1.0, 0.0]).unwrap();
    /// assert_eq!(c.ctrl(), &[0.0, 1.0, 0.0]);
    /// ```
    pub fn ctrl(&self) -> &[P] {
        &self.ctrl
    }
    /// Parameter domain [`U[p]`, `U[n]`].
    ///
    /// ```
    /// let c = gregvox::geom::bspline::BSplineCurve::<f64, f64>::clamped_uniform(2, vec![0.0, 1.0, 0.0]).unwrap();
    /// assert_eq!(c.domain(), (0.0, 1.0));
    /// ```
    pub fn domain(&self) -> (S, S) {
        (self.knots[self.degree], self.knots[self.ctrl.len()])
    }

    /// C(u) (de Boor via the basis functions of the span).
    ///
    /// ```
    /// use gregvox::geom::bspline::BSplineCurve;
    /// use glam::DVec3;
    /// let pts = [[0.,0.,0.],[1.,2.,0.],[3.,3.,1.],[4.,1.,2.],[6.,0.,1.],[7.,2.,0.],[9.,3.,1.]].map(DVec3::from);
    /// let c = BSplineCurve::new(3, vec![0.,0.,0.,0.,0.25,0.5,0.75,1.,1.,1.,1.], pts.to_vec()).unwrap();
    /// assert!((c.eval(0.3) - DVec3::new(3.030666667, 2.302666667, 1.154666667)).length() < 1e-9);
    /// ```
    pub fn eval(&self, u: S) -> P {
        curve_derivs_raw(self.degree, &self.knots, &self.ctrl, u, 0)[0]
    }

    /// C(u), C′(u), …, C⁽ᵏ⁾(u).
    ///
    /// ```
    /// use gregvox::geom::bspline::BSplineCurve;
    /// let c = BSplineCurve::<f64, f64>::new(2, vec![0., 0., 0., 1., 1., 1.], vec![0.0, 0.0, 1.0]).unwrap(); // u²
    /// assert_eq!(c.derivs(0.5, 3), vec![0.25, 1.0, 2.0, 0.0]);
    /// ```
    pub fn derivs(&self, u: S, k: usize) -> Vec<P> {
        curve_derivs_raw(self.degree, &self.knots, &self.ctrl, u, k)
    }

    /// Inserts knot `u` `times` times (Boehm); the curve is unchanged. Errors if u is outside the domain or
    /// its multiplicity would exceed the degree.
    ///
    /// ```
    /// use gregvox::geom::bspline::BSplineCurve;
    /// let c = BSplineCurve::<f64, f64>::new(2, vec![0., 0., 0., 1., 1., 1.], vec![0.0, 0.0, 1.0]).unwrap();
    /// let d = c.insert_knot(0.5, 1).unwrap();
    /// assert_eq!(d.knots(), &[0., 0., 0., 0.5, 1., 1., 1.]);
    /// assert_eq!(d.eval(0.7), c.eval(0.7));
    /// assert!(c.insert_knot(0.5, 3).is_err());
    /// ```
    pub fn insert_knot(&self, u: S, times: usize) -> Result<Self> {
        let (knots, ctrl) = insert_knot_raw(self.degree, &self.knots, &self.ctrl, u, times)?;
        Ok(BSplineCurve {
            degree: self.degree,
            knots,
            ctrl,
        })
    }

    /// Splits at u (strictly inside the domain) into two clamped curves on [`U[p]`, u] and [u, `U[n]`].
    ///
    /// ```
    /// use gregvox::geom::bspline::BSplineCurve;
    /// let c = BSplineCurve::<f64, f64>::clamped_uniform(3, vec![0.0, 2.0, -1.0, 3.0, 1.0]).unwrap();
    /// let (a, b) = c.split(0.4).unwrap();
    /// assert_eq!(a.domain(), (0.0, 0.4));
    /// assert!((a.eval(0.2) - c.eval(0.2)).abs() < 1e-15 && (b.eval(0.9) - c.eval(0.9)).abs() < 1e-15);
    /// ```
    pub fn split(&self, u: S) -> Result<(Self, Self)> {
        let [(lk, lq), (rk, rq)] = split_raw(self.degree, &self.knots, &self.ctrl, u)?;
        let p = self.degree;
        Ok((
            BSplineCurve {
                degree: p,
                knots: lk,
                ctrl: lq,
            },
            BSplineCurve {
                degree: p,
                knots: rk,
                ctrl: rq,
            },
        ))
    }
}
