//! The `curves` scene: a Bézier, a B-spline and a NURBS curve side by side in the world's x–z plane, each with
//! its control polygon; the de Casteljau construction of the Bézier curve at a moving t (every intermediate
//! polygon); curvature combs on the Bézier and B-spline curves; the circle of curvature at a moving point of the
//! NURBS curve (one of whose weights breathes). Every point, derivative and curvature comes from src/geom
//! (`Bezier`, `BSplineCurve`, `NurbsCurve`, `plane_curvature`, `circle_of_curvature`); the engine only draws
//! the segments (passes/lines.rs).
//!
//! Invariants: [`curve_lines`] is a pure function of the time, so a frame's vertex list is reproducible and
//! its segment count is known in advance ([`expected_vertices`]); the vertices go to the frame slot's own
//! host-visible buffer (`LineRing`), never to one a frame in flight reads.
use super::scene::{FrameTargets, Orbit, Scene, SceneLines, ViewState};
use crate::geom::bezier::Bezier;
use crate::geom::bspline::BSplineCurve;
use crate::geom::curvature::{circle_of_curvature, plane_curvature};
use crate::geom::nurbs::NurbsCurve;
use crate::gpu::{Context, Profiler};
use crate::passes::draw::ColorTarget;
use crate::passes::lines::LineVertex;
use ash::vk;
use glam::{DVec2, Vec3};

/// Segments per drawn curve.
pub const CURVE_SEGMENTS: u32 = 96;
/// Teeth of a curvature comb.
pub const COMB_TEETH: u32 = 40;
/// Segments of the circle of curvature.
pub const CIRCLE_SEGMENTS: u32 = 64;
/// Control points of the three curves.
pub const BEZIER_POINTS: u32 = 5;
pub const BSPLINE_POINTS: u32 = 8;
pub const NURBS_POINTS: u32 = 5;
/// Longest comb tooth (world units).
const COMB_LENGTH: f64 = 0.7;
/// Half the size of a point marker (a cross).
const MARK: f64 = 0.06;

const CURVE: [f32; 3] = [0.1, 0.2, 0.6];
const POLYGON: [f32; 3] = [0.45, 0.45, 0.5];
const COMB: [f32; 3] = [0.95, 0.5, 0.1];
const CIRCLE: [f32; 3] = [0.1, 0.6, 0.25];
const POINT: [f32; 3] = [0.85, 0.1, 0.1];

/// One frame's segments: vertex pairs and how many segments each named part contributed.
#[derive(Clone, Debug, Default)]
pub struct CurveLines {
    pub vertices: Vec<LineVertex>,
    pub parts: Vec<(&'static str, u32)>,
}

impl CurveLines {
    fn part(&mut self, name: &'static str, f: impl FnOnce(&mut Vec<LineVertex>)) {
        let before = self.vertices.len();
        f(&mut self.vertices);
        let added = self.vertices.len() - before;
        debug_assert!(added % 2 == 0, "{name}: odd vertex count");
        self.parts.push((name, (added / 2) as u32));
    }
}

/// A point of the plane drawn at (x, 0, y).
fn at(p: DVec2) -> [f32; 3] {
    [p.x as f32, 0.0, p.y as f32]
}

fn segment(out: &mut Vec<LineVertex>, a: DVec2, b: DVec2, c: [f32; 3]) {
    out.push(LineVertex::new(at(a), c));
    out.push(LineVertex::new(at(b), c));
}

fn polyline(out: &mut Vec<LineVertex>, pts: &[DVec2], c: [f32; 3]) {
    for w in pts.windows(2) {
        segment(out, w[0], w[1], c);
    }
}

fn cross(out: &mut Vec<LineVertex>, p: DVec2, c: [f32; 3]) {
    segment(
        out,
        p - DVec2::new(MARK, MARK),
        p + DVec2::new(MARK, MARK),
        c,
    );
    segment(
        out,
        p - DVec2::new(MARK, -MARK),
        p + DVec2::new(MARK, -MARK),
        c,
    );
}

/// Samples `f(u)` = (point, first, second derivative) at `COMB_TEETH` parameters of `[a, b]` and draws the
/// curvature comb: teeth along −κ·n (n the left normal), scaled so the longest is `COMB_LENGTH`, and the
/// envelope through the tooth tips.
fn comb(out: &mut Vec<LineVertex>, a: f64, b: f64, f: impl Fn(f64) -> [DVec2; 3]) {
    let samples: Vec<(DVec2, DVec2, f64)> = (0..COMB_TEETH)
        .map(|i| {
            let u = a + (b - a) * i as f64 / (COMB_TEETH - 1) as f64;
            let [p, d1, d2] = f(u);
            let k = plane_curvature(d1, d2).unwrap_or(0.0);
            let n = d1.perp().normalize_or_zero();
            (p, n, k)
        })
        .collect();
    let kmax = samples.iter().fold(0.0f64, |m, s| m.max(s.2.abs()));
    let scale = if kmax > 0.0 { COMB_LENGTH / kmax } else { 0.0 };
    let tips: Vec<DVec2> = samples.iter().map(|&(p, n, k)| p - n * k * scale).collect();
    for (s, &tip) in samples.iter().zip(&tips) {
        segment(out, s.0, tip, COMB);
    }
    polyline(out, &tips, COMB);
}

fn sampled(a: f64, b: f64, f: impl Fn(f64) -> DVec2) -> Vec<DVec2> {
    (0..=CURVE_SEGMENTS)
        .map(|i| f(a + (b - a) * i as f64 / CURVE_SEGMENTS as f64))
        .collect()
}

/// The curves' control points and the NURBS weights: what the mouse edits while the scene is paused, and
/// what the animation moves while it plays (a Bézier point bobs, a B-spline point circles, the middle NURBS
/// weight breathes), on top of the edits.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveControls {
    /// Degree 4, in x ∈ [0, 3].
    pub bezier: Vec<DVec2>,
    /// Cubic, clamped uniform knots, in x ∈ [3.6, 6.6].
    pub bspline: Vec<DVec2>,
    /// Quadratic over a convex polygon (its curvature never vanishes), in x ∈ [7.2, 10.2].
    pub nurbs: Vec<DVec2>,
    /// The NURBS weights (positive).
    pub weights: Vec<f64>,
}

impl Default for CurveControls {
    fn default() -> Self {
        let pts = |v: &[(f64, f64)]| v.iter().map(|&(x, y)| DVec2::new(x, y)).collect();
        CurveControls {
            bezier: pts(&[(0.0, 0.0), (0.4, 1.8), (1.5, 2.2), (2.4, 0.2), (3.0, 1.4)]),
            bspline: pts(&[
                (3.6, 0.2),
                (3.9, 1.6),
                (4.5, 2.3),
                (5.0, 0.6),
                (5.5, 0.9),
                (5.9, 2.2),
                (6.3, 1.9),
                (6.6, 0.4),
            ]),
            nurbs: pts(&[(7.2, 0.2), (7.4, 2.0), (8.7, 2.6), (10.0, 2.0), (10.2, 0.2)]),
            weights: vec![1.0, 1.0, 2.0, 1.0, 1.0],
        }
    }
}

/// Lightest and heaviest NURBS weight the wheel sets.
pub const WEIGHT_RANGE: (f64, f64) = (0.05, 20.0);

impl CurveControls {
    /// The animation's offset of every control point at time `t`, in [`CurveControls::points`] order.
    fn offsets(t: f32) -> Vec<DVec2> {
        let time = t as f64;
        let mut o = vec![DVec2::ZERO; (BEZIER_POINTS + BSPLINE_POINTS + NURBS_POINTS) as usize];
        o[2] = DVec2::new(0.0, 0.3 * (0.7 * time).sin());
        o[BEZIER_POINTS as usize + 3] = DVec2::new((1.1 * time).cos(), (1.1 * time).sin()) * 0.35;
        o
    }

    /// The controls shown at time `t`: these with the animation's offsets, the middle NURBS weight
    /// breathing by ±80 %.
    pub fn at(&self, t: f32) -> CurveControls {
        let mut c = self.clone();
        let moved: Vec<DVec2> = self
            .points()
            .iter()
            .zip(Self::offsets(t))
            .map(|(p, o)| *p + o)
            .collect();
        c.set_points(&moved);
        c.weights[2] *= 1.0 + 0.8 * (0.6 * t as f64).sin();
        c
    }

    /// Every control point: the Bézier's, the B-spline's, then the NURBS's.
    pub fn points(&self) -> Vec<DVec2> {
        [&self.bezier[..], &self.bspline, &self.nurbs].concat()
    }

    /// Sets the points [`CurveControls::points`] lists (as many, same order).
    pub fn set_points(&mut self, pts: &[DVec2]) {
        let (b, s) = (self.bezier.len(), self.bspline.len());
        self.bezier.copy_from_slice(&pts[..b]);
        self.bspline.copy_from_slice(&pts[b..b + s]);
        self.nurbs.copy_from_slice(&pts[b + s..]);
    }

    /// Sets the points as shown at time `t` (the offsets of [`CurveControls::at`] taken off).
    pub fn set_points_at(&mut self, t: f32, pts: &[DVec2]) {
        let base: Vec<DVec2> = pts
            .iter()
            .zip(Self::offsets(t))
            .map(|(p, o)| *p - o)
            .collect();
        self.set_points(&base);
    }
}

/// The de Casteljau parameter at time `t`.
pub fn casteljau_t(t: f32) -> f64 {
    0.5 + 0.45 * (0.8 * t as f64).sin()
}

/// Builds every segment of the frame at time `t` (the built-in controls).
pub fn curve_lines(t: f32) -> crate::Result<CurveLines> {
    curve_lines_with(&CurveControls::default().at(t), t)
}

/// Builds every segment of the curves `c` (as shown: [`CurveControls::at`]), with the de Casteljau
/// construction and the circle of curvature at time `t`'s parameters.
pub fn curve_lines_with(c: &CurveControls, t: f32) -> crate::Result<CurveLines> {
    let time = t as f64;
    let mut out = CurveLines::default();

    let ctrl = c.bezier.clone();
    let bez = Bezier::new(ctrl.clone())?;
    out.part("bezier curve", |o| {
        polyline(o, &sampled(0.0, 1.0, |u| bez.eval(u)), CURVE)
    });
    out.part("bezier polygon", |o| polyline(o, &ctrl, POLYGON));
    let s = casteljau_t(t);
    out.part("de casteljau", |o| {
        let mut level = ctrl.clone();
        let mut shade = 0.0f32;
        while level.len() > 1 {
            level = level.windows(2).map(|w| w[0].lerp(w[1], s)).collect();
            shade += 1.0 / (BEZIER_POINTS - 1) as f32;
            if level.len() > 1 {
                polyline(
                    o,
                    &level,
                    [0.2 + 0.6 * shade, 0.7 - 0.5 * shade, 0.9 - 0.6 * shade],
                );
            }
        }
        // The construction's last point is the curve point (checked against the Bernstein form in tests).
        cross(o, level[0], POINT);
    });
    out.part("bezier comb", |o| {
        comb(o, 0.0, 1.0, |u| {
            let d = bez.derivs(u, 2);
            [d[0], d[1], d[2]]
        })
    });

    // Cubic B-spline with a clamped uniform knot vector; one control point circles (animated), which moves
    // only the spans it supports.
    let bctrl = c.bspline.clone();
    let bs = BSplineCurve::clamped_uniform(3, bctrl.clone())?;
    let (a, b) = bs.domain();
    out.part("bspline curve", |o| {
        polyline(o, &sampled(a, b, |u| bs.eval(u)), CURVE)
    });
    out.part("bspline polygon", |o| polyline(o, &bctrl, POLYGON));
    out.part("bspline comb", |o| {
        comb(o, a, b, |u| {
            let d = bs.derivs(u, 2);
            [d[0], d[1], d[2]]
        })
    });

    // Quadratic NURBS over a convex polygon (so its curvature never vanishes); the middle weight breathes
    // (animated: between 0.4 and 3.6 for the built-in 2).
    let nctrl = c.nurbs.clone();
    let nurbs = NurbsCurve::new(
        2,
        vec![0.0, 0.0, 0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0, 1.0, 1.0],
        nctrl.clone(),
        c.weights.clone(),
    )?;
    out.part("nurbs curve", |o| {
        polyline(o, &sampled(0.0, 1.0, |u| nurbs.eval(u)), CURVE)
    });
    out.part("nurbs polygon", |o| polyline(o, &nctrl, POLYGON));
    let u = 0.5 + 0.45 * (0.5 * time).cos();
    let d = nurbs.derivs(u, 2);
    out.part("circle of curvature", |o| {
        if let Some((c, r)) = circle_of_curvature(d[0], d[1], d[2]) {
            let pts: Vec<DVec2> = (0..=CIRCLE_SEGMENTS)
                .map(|i| {
                    let a = std::f64::consts::TAU * i as f64 / CIRCLE_SEGMENTS as f64;
                    c + r * DVec2::new(a.cos(), a.sin())
                })
                .collect();
            polyline(o, &pts, CIRCLE);
            segment(o, d[0], c, CIRCLE);
        }
        cross(o, d[0], POINT);
    });
    Ok(out)
}

/// The vertex count of every frame (all three curves have non-vanishing curvature where the circle is drawn).
pub fn expected_vertices() -> u32 {
    let n = BEZIER_POINTS - 1;
    let segments = 3 * CURVE_SEGMENTS                       // the three curves
        + (BEZIER_POINTS - 1) + (BSPLINE_POINTS - 1) + (NURBS_POINTS - 1) // control polygons
        + n * (n - 1) / 2 + 2                               // de Casteljau polygons + the point's cross
        + 2 * (2 * COMB_TEETH - 1)                          // two combs: teeth + envelope
        + CIRCLE_SEGMENTS + 1 + 2; // circle, radius, point's cross
    2 * segments
}

/// A square around each control point (the handles of a paused scene), the held one larger, in orange.
fn handle_marks(out: &mut Vec<LineVertex>, points: &[DVec2], held: Option<usize>) {
    for (i, &p) in points.iter().enumerate() {
        let (r, c) = if held == Some(i) {
            (2.0 * MARK, HELD)
        } else {
            (MARK, POLYGON)
        };
        let corners = [
            p + DVec2::new(-r, -r),
            p + DVec2::new(r, -r),
            p + DVec2::new(r, r),
            p + DVec2::new(-r, r),
            p + DVec2::new(-r, -r),
        ];
        polyline(out, &corners, c);
    }
}

/// The handle being dragged.
const HELD: [f32; 3] = [1.0, 0.45, 0.05];

/// The camera of the curves scene: the x–z plane head on (eye on −y, z up), the three panels in view.
pub fn framing() -> Orbit {
    Orbit {
        target: Vec3::new(5.1, 0.0, 1.3),
        yaw: -std::f32::consts::FRAC_PI_2,
        pitch: 0.0,
        distance: 9.5,
    }
}

/// The curves scene.
pub struct CurvesScene {
    lines: SceneLines,
    /// Vertices drawn in the last recorded frame.
    pub drawn: u32,
    /// The controls as edited (the animation plays on top of them).
    pub controls: CurveControls,
    held: Option<usize>,
}

impl CurvesScene {
    /// Builds the line pipeline for `format` targets.
    pub fn new(ctx: &Context, format: impl Into<ColorTarget>) -> anyhow::Result<Self> {
        let format: ColorTarget = format.into();
        Ok(CurvesScene {
            lines: SceneLines::new(ctx, format)?,
            drawn: 0,
            controls: CurveControls::default(),
            held: None,
        })
    }
}

impl Scene for CurvesScene {
    fn name(&self) -> String {
        "curves: Bézier (de Casteljau, comb), B-spline (comb), NURBS (circle of curvature)".into()
    }

    fn record(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        targets: &FrameTargets,
        t: f32,
        view: &ViewState,
        profiler: &mut Profiler,
    ) -> anyhow::Result<()> {
        let time = if view.animate { t } else { 0.0 };
        let shown = self.controls.at(time);
        let mut frame = curve_lines_with(&shown, time)?;
        if !view.animate {
            frame.part("handles", |o| handle_marks(o, &shown.points(), self.held));
        }
        let count = frame.vertices.len() as u32;
        self.lines.record(
            ctx,
            cmd,
            targets,
            view,
            profiler,
            "lines",
            Some([0.97, 0.97, 0.98, 1.0]),
            &frame.vertices,
        )?;
        self.drawn = count;
        Ok(())
    }

    fn framing(&self) -> Orbit {
        framing()
    }

    fn handles(&self, view: &ViewState) -> Vec<Vec3> {
        if view.animate {
            return Vec::new();
        }
        let shown = self.controls.at(0.0);
        shown
            .points()
            .iter()
            .map(|p| Vec3::new(p.x as f32, 0.0, p.y as f32))
            .collect()
    }

    fn set_handles(&mut self, positions: &[Vec3], held: Option<usize>) -> anyhow::Result<()> {
        let n = self.controls.points().len();
        anyhow::ensure!(
            positions.len() == n,
            "{} handles given, the curves have {n} control points",
            positions.len()
        );
        // Dragged in the view plane, which is the curves' plane y = 0 head on; off it (after an orbit)
        // the point is projected back onto the plane.
        let pts: Vec<DVec2> = positions
            .iter()
            .map(|p| DVec2::new(p.x as f64, p.z as f64))
            .collect();
        self.controls.set_points_at(0.0, &pts);
        self.held = held;
        Ok(())
    }

    fn wheel_held(&mut self, index: usize, steps: f32) -> anyhow::Result<Option<String>> {
        let first = (BEZIER_POINTS + BSPLINE_POINTS) as usize;
        let Some(j) = index.checked_sub(first) else {
            return Ok(None);
        };
        let Some(w) = self.controls.weights.get_mut(j) else {
            return Ok(None);
        };
        *w = (*w * 1.25f64.powf(steps as f64)).clamp(WEIGHT_RANGE.0, WEIGHT_RANGE.1);
        Ok(Some(format!("NURBS weight {j}: {w:.4}")))
    }
}

/// Builds the curves scene.
pub fn build(
    ctx: &Context,
    format: impl Into<ColorTarget>,
) -> anyhow::Result<Box<dyn super::scene::Scene>> {
    let format: ColorTarget = format.into();
    Ok(Box::new(CurvesScene::new(ctx, format)?))
}
