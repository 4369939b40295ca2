//! CPU mathematics with no Vulkan: Bézier, B-spline, NURBS, surfaces, the Gregory patch, curvature,
//! lecture kernels. The GPU paths are tested against these.
//!
//! Conventions shared by every file below:
//! - Reference maths is f64 (`glam::DVec2`/`DVec3`/`DVec4`); evaluators that the GPU must match are generic
//!   over [`Real`] (f32 or f64) and [`Point`] (glam vectors of that scalar), so the f32 results can be
//!   compared with a shader bit for bit in operation order. The Gregory patch has an explicit f32 mirror.
//! - Degrees, not orders: a degree-p B-spline with n control points has n + p + 1 knots.
//! - Constructors that take user data validate it and return [`crate::Error::Invalid`]; once a value exists,
//!   its evaluators do not fail (parameters outside the domain are clamped to it).
//! - Surfaces index control points `ctrl[i * size_v + j]` (i along u, j along v; v fastest), as geomdl.
// `!(a < b)` is deliberate throughout: unlike `a >= b` it is true when either side is NaN, which is how
// invalid input is rejected and how NaN parameters are clamped.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Index loops mirror the published algorithms (The NURBS Book A2.x, A5.1) line by line.
#![allow(clippy::needless_range_loop)]
pub mod bezier;
pub mod bspline;
pub mod compat;
pub mod curvature;
pub mod gregory;
pub mod nurbs;
pub mod random;
pub mod raster;
pub mod ray;
pub mod real;
pub mod shading;
pub mod surface;
pub mod transform;

pub use real::{Point, Real};

/// Whether a box lies more than 16 of its own sizes from the world origin (false for an empty or
/// non-finite box): such a model is worked on relative to a local origin, in f64, before anything becomes
/// f32 (at 16 sizes the f32 rounding of world coordinates is still below 1e-6 of the size).
///
/// ```
/// use gregvox::geom::is_far;
/// assert!(!is_far([0.0; 3], [1.0; 3]));
/// assert!(is_far([1e7; 3], [1e7 + 1.0; 3]));
/// ```
pub fn is_far(lo: [f64; 3], hi: [f64; 3]) -> bool {
    let size = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
    let reach = (0..3)
        .map(|a| lo[a].abs().max(hi[a].abs()))
        .fold(0.0, f64::max);
    lo.iter().chain(&hi).all(|c| c.is_finite()) && reach > 16.0 * size
}
