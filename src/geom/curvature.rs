//! Curvature of curves and surfaces from their derivatives.
//!
//! Conventions: plane curvature is *signed*, κ = (x′y″ − y′x″)/|r′|³ (the lecture notes' formula; positive
//! when the curve turns left / counter-clockwise; `bezier.get_curvature` agrees, kurbo has the opposite
//! sign). The unit normal of a plane curve is r′ rotated by +90°, so the centre of curvature is r + N/κ
//! whatever the sign. Surface normals are S_u × S_v normalised; mean curvature H is signed with respect to
//! that normal (H > 0 when the surface bends towards the normal). Degenerate inputs (r′ = 0, κ = 0, S_u ∥
//! S_v) give `None`, never NaN.
use glam::{DVec2, DVec3};

/// Signed curvature κ of a plane curve from r′ and r″; `None` when r′ = 0 (singular point).
///
/// ```
/// use gregvox::geom::curvature::plane_curvature;
/// use glam::DVec2;
/// let k = plane_curvature(DVec2::new(4.5, 0.0), DVec2::new(0.0, -12.0)).unwrap();
/// assert!((k - (-0.592593)).abs() < 1e-6);
/// ```
pub fn plane_curvature(d1: DVec2, d2: DVec2) -> Option<f64> {
    let s2 = d1.length_squared();
    if !(s2 > 0.0) || !s2.is_finite() {
        return None;
    }
    Some(d1.perp_dot(d2) / (s2 * s2.sqrt()))
}

/// The circle of curvature (osculating circle) at a point: (centre, radius = 1/|κ|). `None` when κ = 0
/// (inflection or straight segment: the circle is a line) or r′ = 0.
///
/// ```
/// use gregvox::geom::curvature::circle_of_curvature;
/// use glam::DVec2;
/// let (c, r) = circle_of_curvature(DVec2::new(2.0, 1.5), DVec2::new(4.5, 0.0), DVec2::new(0.0, -12.0)).unwrap();
/// assert!((c - DVec2::new(2.0, -0.1875)).length() < 1e-12);
/// assert!((r - 1.6875).abs() < 1e-12);
/// ```
pub fn circle_of_curvature(p: DVec2, d1: DVec2, d2: DVec2) -> Option<(DVec2, f64)> {
    let k = plane_curvature(d1, d2)?;
    if k == 0.0 {
        return None;
    }
    let n = d1.perp() / d1.length();
    Some((p + n / k, 1.0 / k.abs()))
}

/// Unsigned curvature of a space curve, κ = |r′ × r″| / |r′|³; `None` when r′ = 0.
///
/// ```
/// use gregvox::geom::curvature::space_curvature;
/// use glam::DVec3;
/// // helix (cos t, sin t, t): κ = 1/2 everywhere
/// let (t, a): (f64, f64) = (0.7, 1.0);
/// let d1 = DVec3::new(-t.sin(), t.cos(), a);
/// let d2 = DVec3::new(-t.cos(), -t.sin(), 0.0);
/// assert!((space_curvature(d1, d2).unwrap() - 0.5).abs() < 1e-15);
/// ```
pub fn space_curvature(d1: DVec3, d2: DVec3) -> Option<f64> {
    let s2 = d1.length_squared();
    if !(s2 > 0.0) || !s2.is_finite() {
        return None;
    }
    Some(d1.cross(d2).length() / (s2 * s2.sqrt()))
}

/// Unit normal S_u × S_v / |S_u × S_v|; `None` when the cross product vanishes.
///
/// ```
/// use gregvox::geom::curvature::surface_normal;
/// use glam::DVec3;
/// assert_eq!(surface_normal(DVec3::X, DVec3::Y), Some(DVec3::Z));
/// assert_eq!(surface_normal(DVec3::X, DVec3::X), None);
/// ```
pub fn surface_normal(su: DVec3, sv: DVec3) -> Option<DVec3> {
    let n = su.cross(sv);
    let l = n.length();
    if l > 0.0 && l.is_finite() {
        Some(n / l)
    } else {
        None
    }
}

/// Gaussian and mean curvature (K, H) from the first and second partial derivatives, via the first
/// (E, F, G) and second (L, M, N) fundamental forms: K = (LN − M²)/(EG − F²), H = (EN − 2FM + GL)/(2(EG − F²)).
/// `None` at singular points (S_u ∥ S_v).
///
/// ```
/// use gregvox::geom::curvature::gaussian_mean_curvature;
/// use glam::DVec3;
/// // paraboloid z = (x² + y²)/2 at the origin: K = 1, H = 1 (bends towards +z = S_u × S_v)
/// let (k, h) = gaussian_mean_curvature(DVec3::X, DVec3::Y, DVec3::Z, DVec3::ZERO, DVec3::Z).unwrap();
/// assert_eq!((k, h), (1.0, 1.0));
/// ```
pub fn gaussian_mean_curvature(
    su: DVec3,
    sv: DVec3,
    suu: DVec3,
    suv: DVec3,
    svv: DVec3,
) -> Option<(f64, f64)> {
    let n = surface_normal(su, sv)?;
    let (e, f, g) = (su.dot(su), su.dot(sv), sv.dot(sv));
    let (l, m, nn) = (suu.dot(n), suv.dot(n), svv.dot(n));
    let det = e * g - f * f;
    if !(det > 0.0) {
        return None;
    }
    Some((
        (l * nn - m * m) / det,
        (e * nn - 2.0 * f * m + g * l) / (2.0 * det),
    ))
}
