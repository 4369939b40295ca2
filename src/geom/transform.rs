//! Affine and projective transforms of control nets (glam 4×4 matrices).
//!
//! Conventions: glam is column-major with column vectors, p′ = M·p, as GLSL; the lecture notes write row
//! vectors (p′ = p·M), so their matrices are the transposes of these. Bézier, B-spline, NURBS and Gregory
//! patches are affinely invariant: transforming the control points transforms the surface (weights are
//! unchanged). NURBS are also projectively invariant once the weights are transformed with the points, which
//! is what [`transform_rational`] does. The bottom row of an affine matrix is (0, 0, 0, 1); affine helpers
//! ignore it (glam's `transform_point3`).
use super::gregory::PatchF64;
use crate::{Error, Result};
use glam::{DMat4, DVec3, DVec4};

/// Applies an affine transform to every point.
///
/// ```
/// use gregvox::geom::transform::transform_points;
/// use glam::{DMat4, DVec3};
/// let m = DMat4::from_translation(DVec3::X) * DMat4::from_scale(DVec3::splat(2.0));
/// assert_eq!(transform_points(&m, &[DVec3::ONE]), vec![DVec3::new(3.0, 2.0, 2.0)]);
/// ```
pub fn transform_points(m: &DMat4, pts: &[DVec3]) -> Vec<DVec3> {
    pts.iter().map(|&p| m.transform_point3(p)).collect()
}

/// A Gregory patch with an affine transform applied to its 20 control points.
///
/// ```
/// use gregvox::geom::{gregory::PatchF64, transform::transform_patch};
/// use glam::{DMat4, DVec3};
/// let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| DVec3::new(i as f64, j as f64, 0.0)));
/// let g = transform_patch(&DMat4::from_rotation_x(std::f64::consts::FRAC_PI_2), &PatchF64::from_bezier(&b));
/// assert!((g.normal(0.5, 0.5) - DVec3::new(0.0, -1.0, 0.0)).length() < 1e-15);
/// ```
pub fn transform_patch(m: &DMat4, p: &PatchF64) -> PatchF64 {
    PatchF64 {
        cv: p.cv.map(|c| m.transform_point3(c)),
    }
}

/// Projective transform of a rational control net: (w·P, w) ↦ M·(w·P, w), giving new Cartesian points and
/// weights; errors if a transformed weight is not > 0 (the net would cross the plane at infinity).
///
/// ```
/// use gregvox::geom::transform::transform_rational;
/// use glam::{DMat4, DVec3};
/// let (p, w) = transform_rational(&DMat4::from_scale(DVec3::splat(3.0)), &[DVec3::X], &[2.0]).unwrap();
/// assert_eq!((p[0], w[0]), (DVec3::new(3.0, 0.0, 0.0), 2.0));
/// ```
pub fn transform_rational(
    m: &DMat4,
    pts: &[DVec3],
    weights: &[f64],
) -> Result<(Vec<DVec3>, Vec<f64>)> {
    let hom = super::nurbs::homogeneous(pts, weights)?;
    let out: Vec<DVec4> = hom.iter().map(|&h| *m * h).collect();
    if let Some(i) = out.iter().position(|h| !(h.w > 0.0 && h.is_finite())) {
        return Err(Error::Invalid(format!(
            "projective transform: control point {i} gets weight {} (must be > 0)",
            out[i].w
        )));
    }
    Ok((
        out.iter().map(|h| h.truncate() / h.w).collect(),
        out.iter().map(|h| h.w).collect(),
    ))
}
