//! The exact kernels: the signed solid angle of one triangle (Van Oosterom & Strackee 1983) with a bound on
//! its rounding error, the plain winding-number sum (the reference every decision falls back to), and the
//! distance helpers the bounds use.
//!
//! Invariants: everything is f64 in grid-local coordinates (world − grid origin); a solid angle is positive
//! when the query point sees the triangle counter-clockwise (it lies behind an outward face), so a closed
//! outward surface has winding number +1 inside. [`solid_angle_bounded`]'s error bound covers the rounding
//! of the determinant and the denominator (each a sum of products of the corner vectors, computed to a few
//! ulps of its largest term) through the conditioning of `atan2`: near an edge of the triangle, where both
//! vanish, the bound grows instead of lying.
use super::super::surface::{cross, dot, sub};
use crate::voxel::mesh::TriMesh;

/// 4π.
pub const FOUR_PI: f64 = 4.0 * std::f64::consts::PI;

pub(crate) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// The signed solid angle of triangle (a, b, c) seen from `p`.
pub fn solid_angle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    solid_angle_bounded(p, a, b, c).0
}

/// The signed solid angle of triangle (a, b, c) seen from `p`, and a bound on its rounding error.
#[inline]
pub fn solid_angle_bounded(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> (f64, f64) {
    let (a, b, c) = (sub(a, p), sub(b, p), sub(c, p));
    let (la, lb, lc) = (norm(a), norm(b), norm(c));
    let det = dot(a, cross(b, c));
    let den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    let scale = la * lb * lc;
    // |det| and each term of den are at most la·lb·lc; each is computed to within 8 ulps of that scale (the
    // norms add their own), so the pair moves by at most 48ε·scale; atan2 turns that into an angle error of
    // at most 48ε·scale / |(det, den)|, twice for the half angle, plus atan2's own ulps.
    let radius = (det * det + den * den).sqrt();
    let err = if radius > 0.0 {
        2.0 * 48.0 * f64::EPSILON * scale / radius + 8.0 * f64::EPSILON
    } else {
        f64::INFINITY
    };
    (2.0 * det.atan2(den), err)
}

/// The exact generalized winding number of `mesh` at world point `p`, by the plain sum in triangle order
/// (O(triangles): a reference for tests and small inputs).
pub fn winding_number(mesh: &TriMesh, p: [f64; 3]) -> f64 {
    let mut sum = 0.0;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| mesh.positions[v as usize].map(|x| x as f64));
        sum += solid_angle(p, a, b, c);
    }
    sum / FOUR_PI
}

/// The winding number at local point `p` of `triangles` (local f64 corners), summed in order: the
/// decision of last resort, which defines the answer at the few points no bound separates from ½.
pub fn winding_sum(triangles: &[[[f64; 3]; 3]], p: [f64; 3]) -> f64 {
    let mut sum = 0.0;
    for &[a, b, c] in triangles {
        sum += solid_angle(p, a, b, c);
    }
    sum / FOUR_PI
}

/// The squared distance from `p` to the segment a–b.
#[inline]
pub fn segment_distance2(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let (ab, ap) = (sub(b, a), sub(p, a));
    let l2 = dot(ab, ab);
    let t = if l2 > 0.0 {
        (dot(ap, ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = [a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]];
    let d = sub(p, q);
    dot(d, d)
}

/// The distance from `p` to triangle (a, b, c): to its plane where `p` projects inside it, else to its
/// nearest edge (a degenerate triangle is its edges).
pub fn triangle_distance(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let n = cross(sub(b, a), sub(c, a));
    let nn = dot(n, n);
    if nn > 0.0
        && dot(cross(sub(b, a), sub(p, a)), n) >= 0.0
        && dot(cross(sub(c, b), sub(p, b)), n) >= 0.0
        && dot(cross(sub(a, c), sub(p, c)), n) >= 0.0
    {
        return dot(n, sub(p, a)).abs() / nn.sqrt();
    }
    segment_distance2(p, a, b)
        .min(segment_distance2(p, b, c))
        .min(segment_distance2(p, c, a))
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_closed_cube_has_winding_number_one_inside_and_zero_outside() {
        let cube = TriMesh::cube([0.0; 3], 1.0);
        assert!((winding_number(&cube, [0.5, 0.4, 0.3]) - 1.0).abs() < 1e-12);
        assert!(winding_number(&cube, [1.5, 0.4, 0.3]).abs() < 1e-12);
    }

    #[test]
    fn the_rounding_bound_covers_the_error_and_grows_at_edges() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        // Far above the middle: a small, well-conditioned angle.
        let (w, e) = solid_angle_bounded([0.3, 0.3, 5.0], a, b, c);
        assert!(w.abs() < 0.05 && e < 1e-13, "{w} {e}");
        // A hair above an edge: both det and den vanish, and the bound says so.
        let (_, e) = solid_angle_bounded([0.5, 0.0, 1e-13], a, b, c);
        assert!(e > 1e-4, "{e}");
    }

    #[test]
    fn distances_to_triangles_and_segments() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        assert!((triangle_distance([0.5, 0.5, 3.0], a, b, c) - 3.0).abs() < 1e-15);
        assert!((triangle_distance([-1.0, 0.5, 0.0], a, b, c) - 1.0).abs() < 1e-15);
        assert!((segment_distance2([1.0, 1.0, 0.0], a, b) - 1.0).abs() < 1e-15);
    }
}
