//! Bézier curves and curvature: closed-form vectors of docs/notes/mesh-matrices-and-curves.md §B.3, numpy
//! Bernstein sums (tests/fixtures/geom/bezier.json) and geomdl 5.4.0 elevation/split (ops.json).
//!
//! Tolerances: the notes print 6 significant digits for κ (hence 1e-6); everything computed by an oracle in
//! f64 is compared at 1e-12 (absolute for points, relative to max(1, |C′|, |C″|) for derivatives and
//! relative for curvature); f32 at 1e-5 × the control polygon's bbox diagonal.
use glam::{DVec2, DVec3, Vec2};
use gregvox::geom::bezier::Bezier;
use gregvox::geom::curvature::{circle_of_curvature, plane_curvature, space_curvature};
use serde_json::Value;

fn fixture(name: &str) -> Value {
    let path = format!("{}/tests/fixtures/geom/{name}", env!("CARGO_MANIFEST_DIR"));
    serde_json::from_str(&std::fs::read_to_string(&path).expect("fixture")).expect("json")
}

fn f64s(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn vec2s(v: &Value) -> Vec<DVec2> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|p| DVec2::from_slice(&f64s(p)))
        .collect()
}

fn vec3s(v: &Value) -> Vec<DVec3> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|p| DVec3::from_slice(&f64s(p)))
        .collect()
}

fn notes_cubic() -> Bezier<f64, DVec2> {
    Bezier::new(vec![
        DVec2::new(0., 0.),
        DVec2::new(1., 2.),
        DVec2::new(3., 2.),
        DVec2::new(4., 0.),
    ])
    .unwrap()
}

#[test]
fn notes_cubic_at_one_half() {
    let c = notes_cubic();
    let d = c.derivs(0.5, 2);
    assert_eq!(d[0], DVec2::new(2.0, 1.5));
    assert_eq!(c.eval_bernstein(0.5), DVec2::new(2.0, 1.5));
    assert_eq!(d[1], DVec2::new(4.5, 0.0));
    assert_eq!(d[2], DVec2::new(0.0, -12.0));
    let k = plane_curvature(d[1], d[2]).unwrap();
    assert!((k - (-0.592593)).abs() < 1e-6, "κ = {k}");
    assert!(
        (k - (-16.0 / 27.0)).abs() < 1e-15,
        "κ = −12·4.5/4.5³ = −16/27 exactly"
    );
    let (centre, radius) = circle_of_curvature(d[0], d[1], d[2]).unwrap();
    assert!((centre - DVec2::new(2.0, -0.1875)).length() < 1e-15);
    assert!((radius - 1.6875).abs() < 1e-15);
}

#[test]
fn bezier_curves_match_numpy_bernstein_sums() {
    let fx = fixture("bezier.json");
    let (mut mp, mut md, mut mk, mut m32) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for case in fx["cases"].as_array().unwrap() {
        let ctrl = vec2s(&case["ctrl"]);
        let c = Bezier::new(ctrl.clone()).unwrap();
        let c32 = Bezier::new(ctrl.iter().map(|p| p.as_vec2()).collect::<Vec<Vec2>>()).unwrap();
        let lo = ctrl.iter().fold(DVec2::INFINITY, |a, &b| a.min(b));
        let hi = ctrl.iter().fold(DVec2::NEG_INFINITY, |a, &b| a.max(b));
        let diag = (hi - lo).length();
        let (pts, d1, d2) = (
            vec2s(&case["points"]),
            vec2s(&case["d1"]),
            vec2s(&case["d2"]),
        );
        let kappa = f64s(&case["signed_curvature"]);
        for (i, &t) in f64s(&case["params"]).iter().enumerate() {
            let d = c.derivs(t, 2);
            let scale = 1f64.max(d1[i].length()).max(d2[i].length());
            mp = mp
                .max((d[0] - pts[i]).length())
                .max((c.eval_bernstein(t) - pts[i]).length());
            md = md
                .max((d[1] - d1[i]).length() / scale)
                .max((d[2] - d2[i]).length() / scale);
            let k = plane_curvature(d[1], d[2]).unwrap();
            mk = mk.max((k - kappa[i]).abs() / kappa[i].abs().max(1.0));
            m32 = m32.max((c32.eval(t as f32).as_dvec2() - pts[i]).length() / diag);
        }
    }
    eprintln!("Bézier degrees 1–7 × 101 params vs numpy: points {mp:.2e}, derivatives {md:.2e} rel, κ {mk:.2e} rel, f32 {m32:.2e} × diag");
    assert!(mp <= 1e-12 && md <= 1e-12 && mk <= 1e-12 && m32 <= 1e-5);
}

#[test]
fn degree_elevation_matches_notes_and_geomdl() {
    let q = Bezier::new(vec![
        DVec2::new(0., 0.),
        DVec2::new(1., 2.),
        DVec2::new(2., 0.),
    ])
    .unwrap()
    .elevate();
    let want = [
        DVec2::new(0., 0.),
        DVec2::new(2. / 3., 4. / 3.),
        DVec2::new(4. / 3., 4. / 3.),
        DVec2::new(2., 0.),
    ];
    assert!(q
        .ctrl()
        .iter()
        .zip(want)
        .all(|(a, b)| (*a - b).length() < 1e-15));
    let c = Bezier::new(vec![
        DVec2::new(0., 0.),
        DVec2::new(1., 3.),
        DVec2::new(3., 3.),
        DVec2::new(4., 0.),
    ])
    .unwrap()
    .elevate();
    let want = [[0., 0.], [0.75, 2.25], [2., 3.], [3.25, 2.25], [4., 0.]].map(DVec2::from);
    assert!(c
        .ctrl()
        .iter()
        .zip(want)
        .all(|(a, b)| (*a - b).length() < 1e-15));
    let fx = fixture("ops.json");
    let mut max = 0.0f64;
    for e in fx["elevation"].as_array().unwrap() {
        let mut b = Bezier::new(vec3s(&e["ctrl"])).unwrap();
        let orig = b.clone();
        for _ in 0..e["times"].as_u64().unwrap() {
            b = b.elevate();
        }
        let want = vec3s(&e["elevated"]);
        assert_eq!(b.ctrl().len(), want.len());
        for (x, y) in b.ctrl().iter().zip(&want) {
            max = max.max((*x - *y).length());
        }
        // same curve
        for k in 0..=20 {
            let t = k as f64 / 20.0;
            assert!((b.eval(t) - orig.eval(t)).length() < 1e-14);
        }
    }
    eprintln!("degree elevation vs geomdl: max {max:.2e}");
    assert!(max <= 1e-12);
}

#[test]
fn split_matches_geomdl_bezier_split() {
    let fx = fixture("ops.json");
    let mut max = 0.0f64;
    let mut n = 0;
    for s in fx["split"].as_array().unwrap() {
        let p = s["degree"].as_u64().unwrap() as usize;
        let ctrl = vec3s(&s["ctrl"]);
        if ctrl.len() != p + 1 {
            continue; // B-spline cases are in geom_bspline_nurbs.rs
        }
        let (a, b) = Bezier::new(ctrl).unwrap().split(s["u"].as_f64().unwrap());
        for (piece, want) in [(&a, vec3s(&s["left_ctrl"])), (&b, vec3s(&s["right_ctrl"]))] {
            for (x, y) in piece.ctrl().iter().zip(&want) {
                max = max.max((*x - *y).length());
            }
        }
        n += 1;
    }
    eprintln!(
        "de Casteljau split vs geomdl split_curve ({n} Bézier curves, degrees 1–5): max {max:.2e}"
    );
    assert_eq!(n, 5);
    assert!(max <= 1e-12);
    // the halves reproduce the curve: C(t·s) on the left piece
    let c = notes_cubic();
    let (l, r) = c.split(0.3);
    for k in 0..=10 {
        let s = k as f64 / 10.0;
        assert!((l.eval(s) - c.eval(0.3 * s)).length() < 1e-15);
        assert!((r.eval(s) - c.eval(0.3 + 0.7 * s)).length() < 1e-15);
    }
}

#[test]
fn space_curve_curvature_of_the_twisted_cubic() {
    // (t, t², t³) in Bézier form; κ = |r′×r″|/|r′|³ with r′ = (1, 2t, 3t²), r″ = (0, 2, 6t)
    let c = Bezier::new(vec![
        DVec3::ZERO,
        DVec3::new(1. / 3., 0., 0.),
        DVec3::new(2. / 3., 1. / 3., 0.),
        DVec3::ONE,
    ])
    .unwrap();
    let mut max = 0.0f64;
    for k in 0..=50 {
        let t = k as f64 / 50.0;
        let d = c.derivs(t, 2);
        let (r1, r2) = (
            DVec3::new(1., 2. * t, 3. * t * t),
            DVec3::new(0., 2., 6. * t),
        );
        let want = r1.cross(r2).length() / r1.length().powi(3);
        max = max.max((space_curvature(d[1], d[2]).unwrap() - want).abs());
    }
    eprintln!("twisted cubic curvature vs closed form: {max:.2e}");
    assert!(max <= 1e-13);
    assert!((space_curvature(DVec3::X, DVec3::new(0., 2., 0.)).unwrap() - 2.0).abs() < 1e-15);
}

#[test]
fn degenerate_curvature_is_none_not_nan() {
    // a cusp: r′ = 0
    assert_eq!(plane_curvature(DVec2::ZERO, DVec2::X), None);
    assert_eq!(space_curvature(DVec3::ZERO, DVec3::X), None);
    // straight line: κ = 0, no circle
    assert_eq!(plane_curvature(DVec2::X, DVec2::X), Some(0.0));
    assert_eq!(circle_of_curvature(DVec2::ZERO, DVec2::X, DVec2::X), None);
    // a constant curve's hodograph is the zero curve, not an error
    let c = Bezier::<f64, DVec2>::new(vec![DVec2::ONE]).unwrap();
    assert_eq!(c.derivative().eval(0.3), DVec2::ZERO);
    assert!(Bezier::<f64, DVec2>::new(vec![]).is_err());
    assert!(Bezier::new(vec![DVec2::new(f64::NAN, 0.0)]).is_err());
    // parameters out of range clamp
    assert_eq!(notes_cubic().eval(2.0), DVec2::new(4.0, 0.0));
}
