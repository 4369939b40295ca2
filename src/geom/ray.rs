//! Ray intersections of the lecture notes' ray tracer: sphere and triangle.
//!
//! Conventions: a ray is `origin + t·dir`; `dir` need not be unit length and t is in units of |dir|. The
//! sphere returns both roots (sorted; the caller chooses, e.g. the nearest t ≥ ε); the quadratic is solved in
//! the cancellation-free form (Δ from the perpendicular distance, q = −(b + sign(b)√Δ), roots q/a and c/q). Triangles are two-sided
//! (Möller–Trumbore) and report barycentrics (u, v) with the hit = (1−u−v)·a + u·b + v·c.
use glam::DVec3;

/// Both parameters t0 ≤ t1 where the ray meets the sphere, or `None` (miss or zero direction). A tangent
/// ray gives t0 = t1; an origin inside gives t0 < 0 < t1.
///
/// ```
/// use gregvox::geom::ray::ray_sphere;
/// use glam::DVec3;
/// assert_eq!(ray_sphere(DVec3::new(0., 0., -5.), DVec3::Z, DVec3::ZERO, 1.0), Some((4.0, 6.0)));
/// assert_eq!(ray_sphere(DVec3::new(0., 2., -5.), DVec3::Z, DVec3::ZERO, 1.0), None);
/// assert_eq!(ray_sphere(DVec3::ZERO, DVec3::X, DVec3::ZERO, 1.0), Some((-1.0, 1.0)));
/// ```
pub fn ray_sphere(origin: DVec3, dir: DVec3, centre: DVec3, radius: f64) -> Option<(f64, f64)> {
    let a = dir.dot(dir);
    if !(a > 0.0) {
        return None;
    }
    let oc = origin - centre;
    let b = dir.dot(oc); // half of the usual b
    let c = oc.dot(oc) - radius * radius;
    // Δ = b² − a·c computed as a·(r² − |oc − (b/a)·dir|²) (Ray Tracing Gems ch. 7): no cancellation when the
    // sphere is far away relative to its radius
    let perp = oc - dir * (b / a);
    let disc = a * (radius * radius - perp.dot(perp));
    if !(disc >= 0.0) {
        return None;
    }
    let sq = disc.sqrt();
    let q = -(b + if b >= 0.0 { sq } else { -sq });
    if q == 0.0 {
        // b = 0 and disc = 0: tangent at the ray origin's foot, or c = 0 with b = 0
        let t = 0.0;
        return Some((t, t));
    }
    let (t0, t1) = (q / a, c / q);
    Some((t0.min(t1), t0.max(t1)))
}

/// The nearest sphere hit with t ≥ `t_min` (use a small ε > 0 for secondary rays).
///
/// ```
/// use gregvox::geom::ray::ray_sphere_hit;
/// use glam::DVec3;
/// assert_eq!(ray_sphere_hit(DVec3::ZERO, DVec3::X, DVec3::ZERO, 1.0, 1e-9), Some(1.0));
/// ```
pub fn ray_sphere_hit(
    origin: DVec3,
    dir: DVec3,
    centre: DVec3,
    radius: f64,
    t_min: f64,
) -> Option<f64> {
    let (t0, t1) = ray_sphere(origin, dir, centre, radius)?;
    if t0 >= t_min {
        Some(t0)
    } else if t1 >= t_min {
        Some(t1)
    } else {
        None
    }
}

/// A ray–triangle hit: ray parameter and barycentrics.
///
/// ```
/// use gregvox::geom::ray::ray_triangle;
/// use glam::DVec3;
/// let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
/// let h = ray_triangle(DVec3::new(0.5, 0.25, 2.0), -DVec3::Z, a, b, c).unwrap();
/// assert_eq!(a * (1.0 - h.u - h.v) + b * h.u + c * h.v, DVec3::new(0.5, 0.25, 0.0));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Ray parameter.
    pub t: f64,
    /// Weight of vertex b.
    pub u: f64,
    /// Weight of vertex c.
    pub v: f64,
}

/// Möller–Trumbore, two-sided, hits with t ≥ 0 only; `None` for a miss, a ray parallel to the plane
/// (|det| ≤ 1e-14·|e1|·|e2|·|dir|) or a degenerate triangle.
///
/// ```
/// use gregvox::geom::ray::ray_triangle;
/// use glam::DVec3;
/// let h = ray_triangle(DVec3::new(0.25, 0.25, 1.0), -DVec3::Z, DVec3::ZERO, DVec3::X, DVec3::Y).unwrap();
/// assert_eq!((h.t, h.u, h.v), (1.0, 0.25, 0.25));
/// assert!(ray_triangle(DVec3::new(0.8, 0.8, 1.0), -DVec3::Z, DVec3::ZERO, DVec3::X, DVec3::Y).is_none());
/// ```
pub fn ray_triangle(
    origin: DVec3,
    dir: DVec3,
    a: DVec3,
    b: DVec3,
    c: DVec3,
) -> Option<TriangleHit> {
    let e1 = b - a;
    let e2 = c - a;
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if !(det.abs() > 1e-14 * e1.length() * e2.length() * dir.length()) {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t >= 0.0).then_some(TriangleHit { t, u, v })
}
