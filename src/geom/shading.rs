//! Local illumination terms of the lecture notes (ambient, Lambert, Phong) and hard shadows, as small pure
//! functions that the shaders' CPU references reuse.
//!
//! Conventions: `n` (surface normal), `l` (towards the light) and `v` (towards the viewer) are unit vectors
//! pointing away from the surface. Diffuse is max(0, n·l); the Phong reflection vector is r = 2(n·l)n − l and
//! the specular term is 0 whenever n·l ≤ 0 (a light behind the surface cannot create a highlight). Shadow
//! rays start at p + ε·n (ε ≈ 1e-4 × scene bbox diagonal, which avoids self-shadowing "acne") and only
//! occluders strictly between that origin and the light count.
use super::ray::ray_sphere;
use glam::DVec3;

/// Ambient term k_a·I_a.
///
/// ```
/// assert_eq!(gregvox::geom::shading::ambient(0.2, 0.5), 0.1);
/// ```
pub fn ambient(ka: f64, ia: f64) -> f64 {
    ka * ia
}

/// Lambert's diffuse factor max(0, n·l).
///
/// ```
/// use gregvox::geom::shading::lambert;
/// use glam::DVec3;
/// assert_eq!(lambert(DVec3::Z, DVec3::Z), 1.0);
/// assert_eq!(lambert(DVec3::Z, -DVec3::Z), 0.0);
/// ```
pub fn lambert(n: DVec3, l: DVec3) -> f64 {
    n.dot(l).max(0.0)
}

/// Mirror direction of `l` about `n`: r = 2(n·l)n − l.
///
/// ```
/// use gregvox::geom::shading::reflect;
/// use glam::DVec3;
/// assert_eq!(reflect(DVec3::new(1.0, 0.0, 1.0), DVec3::Z), DVec3::new(-1.0, 0.0, 1.0));
/// ```
pub fn reflect(l: DVec3, n: DVec3) -> DVec3 {
    2.0 * n.dot(l) * n - l
}

/// Phong's specular factor max(0, r·v)^shininess, 0 when n·l ≤ 0.
///
/// ```
/// use gregvox::geom::shading::phong_specular;
/// use glam::DVec3;
/// let l = DVec3::new(1.0, 0.0, 1.0).normalize();
/// let v = DVec3::new(-1.0, 0.0, 1.0).normalize();
/// assert!((phong_specular(DVec3::Z, l, v, 20.0) - 1.0).abs() < 1e-13);
/// assert_eq!(phong_specular(DVec3::Z, -l, v, 20.0), 0.0);
/// ```
pub fn phong_specular(n: DVec3, l: DVec3, v: DVec3, shininess: f64) -> f64 {
    if n.dot(l) <= 0.0 {
        return 0.0;
    }
    reflect(l, n).dot(v).max(0.0).powf(shininess)
}

/// Material coefficients of the Phong model.
///
/// ```
/// use gregvox::geom::shading::{phong, Phong};
/// use glam::DVec3;
/// let matte = Phong { ka: 0.0, kd: 1.0, ks: 0.0, shininess: 1.0 };
/// assert_eq!(phong(&matte, DVec3::Z, DVec3::Z, DVec3::X, 0.0, 0.5, true), 0.5);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phong {
    /// Ambient reflectance k_a.
    pub ka: f64,
    /// Diffuse reflectance k_d.
    pub kd: f64,
    /// Specular reflectance k_s.
    pub ks: f64,
    /// Shininess exponent.
    pub shininess: f64,
}

/// I = k_a·I_a + I_l·(k_d·max(0, n·l) + k_s·spec); `lit = false` (in shadow) keeps only the ambient term.
///
/// ```
/// use gregvox::geom::shading::{phong, Phong};
/// use glam::DVec3;
/// let m = Phong { ka: 0.1, kd: 0.6, ks: 0.3, shininess: 10.0 };
/// assert!((phong(&m, DVec3::Z, DVec3::Z, DVec3::Z, 1.0, 1.0, true) - 1.0).abs() < 1e-15);
/// assert_eq!(phong(&m, DVec3::Z, DVec3::Z, DVec3::Z, 1.0, 1.0, false), 0.1);
/// ```
pub fn phong(m: &Phong, n: DVec3, l: DVec3, v: DVec3, ia: f64, il: f64, lit: bool) -> f64 {
    let direct = if lit {
        il * (m.kd * lambert(n, l) + m.ks * phong_specular(n, l, v, m.shininess))
    } else {
        0.0
    };
    ambient(m.ka, ia) + direct
}

/// Shadow ray towards a point light: (origin p + ε·n, direction light − origin); the light is at t = 1.
///
/// ```
/// use gregvox::geom::shading::shadow_ray;
/// use glam::DVec3;
/// let (o, d) = shadow_ray(DVec3::ZERO, DVec3::Z, DVec3::new(0.0, 0.0, 2.0), 1e-4);
/// assert_eq!(o + d, DVec3::new(0.0, 0.0, 2.0));
/// ```
pub fn shadow_ray(p: DVec3, n: DVec3, light: DVec3, eps: f64) -> (DVec3, DVec3) {
    let o = p + n * eps;
    (o, light - o)
}

/// Hard shadow test: is the segment from p + ε·n to the point light blocked? `hit(origin, dir)` returns the
/// ray parameters of an occluder's hits (any t in (0, 1) blocks).
///
/// ```
/// use gregvox::geom::shading::in_shadow_by;
/// use gregvox::geom::ray::ray_sphere;
/// use glam::DVec3;
/// let blocked = in_shadow_by(DVec3::ZERO, DVec3::Z, DVec3::new(0., 0., 10.), 1e-4,
///     |o, d| ray_sphere(o, d, DVec3::new(0., 0., 5.), 1.0).map(|(a, b)| vec![a, b]).unwrap_or_default());
/// assert!(blocked);
/// ```
pub fn in_shadow_by(
    p: DVec3,
    n: DVec3,
    light: DVec3,
    eps: f64,
    hit: impl Fn(DVec3, DVec3) -> Vec<f64>,
) -> bool {
    let (o, d) = shadow_ray(p, n, light, eps);
    hit(o, d).into_iter().any(|t| t > 0.0 && t < 1.0)
}

/// Hard shadow test against spheres (centre, radius).
///
/// ```
/// use gregvox::geom::shading::in_shadow_spheres;
/// use glam::DVec3;
/// let s = [(DVec3::new(0., 0., 5.), 1.0)];
/// assert!(in_shadow_spheres(DVec3::ZERO, DVec3::Z, DVec3::new(0., 0., 10.), 1e-4, &s));
/// assert!(!in_shadow_spheres(DVec3::new(3., 0., 0.), DVec3::Z, DVec3::new(3., 0., 10.), 1e-4, &s));
/// ```
pub fn in_shadow_spheres(
    p: DVec3,
    n: DVec3,
    light: DVec3,
    eps: f64,
    spheres: &[(DVec3, f64)],
) -> bool {
    in_shadow_by(p, n, light, eps, |o, d| {
        spheres
            .iter()
            .filter_map(|&(c, r)| ray_sphere(o, d, c, r))
            .flat_map(|(a, b)| [a, b])
            .collect()
    })
}
