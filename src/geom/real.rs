//! Scalar and point abstractions for evaluators that exist in f64 (reference) and f32 (GPU mirror).
//!
//! Invariants: [`Real`] is implemented for `f32` and `f64` only; [`Point<S>`] for `S` itself and for the
//! glam vectors of that scalar (`Vec2/3/4`, `DVec2/3/4`); `coords()` allocates and serves validation and
//! tests only, never an evaluation path. Homogeneous (rational) maths uses the 4-vectors or a point plus a
//! separate weight, never a special type.
use glam::{DVec2, DVec3, DVec4, Vec2, Vec3, Vec4};
use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// A floating-point scalar: `f32` (what shaders compute in) or `f64` (reference maths).
///
/// ```
/// use gregvox::geom::Real;
/// assert_eq!(<f32 as Real>::from_f64(0.5), 0.5f32);
/// assert_eq!(Real::to_f64(0.25f32), 0.25);
/// ```
pub trait Real:
    Copy
    + Debug
    + PartialOrd
    + Default
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + Send
    + Sync
    + 'static
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Conversion from f64 (rounds to nearest for f32).
    fn from_f64(x: f64) -> Self;
    /// Exact widening to f64.
    fn to_f64(self) -> f64;
    /// Conversion from a small integer (exact).
    fn from_usize(i: usize) -> Self {
        Self::from_f64(i as f64)
    }
    /// Absolute value.
    fn abs(self) -> Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// Neither NaN nor infinite.
    fn is_finite(self) -> bool;
}

macro_rules! impl_real {
    ($t:ty) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            #[inline]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
        }
    };
}
impl_real!(f32);
impl_real!(f64);

/// A point (or vector) of an affine space over the scalar `S`: what curves and surfaces are made of.
///
/// ```
/// use gregvox::geom::Point;
/// use glam::DVec3;
/// let p = <DVec3 as Point<f64>>::zero() + DVec3::X * 2.0;
/// assert!(Point::<f64>::all_finite(p));
/// assert_eq!(<DVec3 as Point<f64>>::coords(p), vec![2.0, 0.0, 0.0]);
/// ```
pub trait Point<S: Real>:
    Copy
    + Debug
    + PartialEq
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<S, Output = Self>
    + Send
    + Sync
    + 'static
{
    /// The origin / zero vector.
    fn zero() -> Self;
    /// The coordinates, in order (for tests and tolerances).
    fn coords(self) -> Vec<S>;
    /// Every coordinate finite.
    fn all_finite(self) -> bool {
        self.coords().into_iter().all(Real::is_finite)
    }
    /// Euclidean length, in f64.
    fn norm_f64(self) -> f64 {
        self.coords()
            .into_iter()
            .map(|c| c.to_f64() * c.to_f64())
            .sum::<f64>()
            .sqrt()
    }
}

impl<S: Real> Point<S> for S {
    fn zero() -> Self {
        S::ZERO
    }
    fn coords(self) -> Vec<S> {
        vec![self]
    }
}

macro_rules! impl_point {
    ($s:ty, $v:ty, [$($f:ident),*]) => {
        impl Point<$s> for $v {
            #[inline]
            fn zero() -> Self {
                <$v>::ZERO
            }
            fn coords(self) -> Vec<$s> {
                vec![$(self.$f),*]
            }
        }
    };
}
impl_point!(f64, DVec2, [x, y]);
impl_point!(f64, DVec3, [x, y, z]);
impl_point!(f64, DVec4, [x, y, z, w]);
impl_point!(f32, Vec2, [x, y]);
impl_point!(f32, Vec3, [x, y, z]);
impl_point!(f32, Vec4, [x, y, z, w]);

/// Binomial coefficient C(n, k) as a scalar (exact for the degrees used here, n ≤ 60).
///
/// ```
/// assert_eq!(gregvox::geom::real::binomial::<f64>(5, 2), 10.0);
/// ```
pub fn binomial<S: Real>(n: usize, k: usize) -> S {
    if k > n {
        return S::ZERO;
    }
    let k = k.min(n - k);
    let mut c = 1.0f64;
    for i in 0..k {
        c = c * (n - i) as f64 / (i + 1) as f64;
    }
    S::from_f64(c.round())
}

/// Validates that every value is finite, naming `what` in the error.
pub(crate) fn check_finite<S: Real, P: Point<S>>(pts: &[P], what: &str) -> crate::Result<()> {
    match pts.iter().position(|p| !p.all_finite()) {
        Some(i) => Err(crate::Error::Invalid(format!(
            "{what}: entry {i} is not finite ({:?})",
            pts[i]
        ))),
        None => Ok(()),
    }
}
