//! B-spline, NURBS and rational Bézier curves against geomdl 5.4.0 (tests/fixtures/geom/curves.json,
//! ops.json; regenerate with tests/oracle/gen_geom.py).
//!
//! Tolerances: f64 positions ≤ 1e-12 absolute (the figure; geomdl and splipy agree to 1.8e-15);
//! derivatives ≤ 1e-12 relative to max(1, |C′|, |C″|) because their magnitude grows with 1/(knot gap);
//! f32 positions ≤ 1e-5 × the control polygon's bounding-box diagonal.
use glam::{DVec2, DVec3, Vec3};
use gregvox::geom::bezier::RationalBezier;
use gregvox::geom::bspline::BSplineCurve;
use gregvox::geom::nurbs::NurbsCurve;
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

fn vec3s(v: &Value) -> Vec<DVec3> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|p| DVec3::from_slice(&f64s(p)))
        .collect()
}

fn bbox_diag(p: &[DVec3]) -> f64 {
    let lo = p.iter().fold(DVec3::splat(f64::INFINITY), |a, &b| a.min(b));
    let hi = p
        .iter()
        .fold(DVec3::splat(f64::NEG_INFINITY), |a, &b| a.max(b));
    (hi - lo).length()
}

enum Curve64 {
    B(BSplineCurve<f64, DVec3>),
    N(NurbsCurve<f64, DVec3>),
}

#[test]
fn curves_match_geomdl_f64_and_f32() {
    let fx = fixture("curves.json");
    let cases = fx["cases"].as_array().unwrap();
    assert!(cases.len() >= 30, "fixture has {} cases", cases.len());
    let (mut max_p, mut max_d1, mut max_d2, mut max_f32) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut degrees = std::collections::BTreeSet::new();
    for (ci, c) in cases.iter().enumerate() {
        let p = c["degree"].as_u64().unwrap() as usize;
        degrees.insert(p);
        let knots = f64s(&c["knots"]);
        let ctrl = vec3s(&c["ctrl"]);
        let params = f64s(&c["params"]);
        assert!(params.len() >= 101);
        let (pts, d1, d2) = (vec3s(&c["points"]), vec3s(&c["d1"]), vec3s(&c["d2"]));
        let diag = bbox_diag(&ctrl);
        let kind = c["kind"].as_str().unwrap();
        let curve = if kind == "bspline" {
            Curve64::B(BSplineCurve::new(p, knots.clone(), ctrl.clone()).unwrap())
        } else {
            Curve64::N(
                NurbsCurve::new(p, knots.clone(), ctrl.clone(), f64s(&c["weights"])).unwrap(),
            )
        };
        let ctrl32: Vec<Vec3> = ctrl.iter().map(|p| p.as_vec3()).collect();
        let knots32: Vec<f32> = knots.iter().map(|&k| k as f32).collect();
        let w32: Option<Vec<f32>> = c["weights"]
            .as_array()
            .map(|w| w.iter().map(|x| x.as_f64().unwrap() as f32).collect());
        // rational Bézier: the same fixture through the Bézier-specific type
        let rb = (c["knots_kind"] == "bezier" && kind == "nurbs")
            .then(|| RationalBezier::new(&ctrl, &f64s(&c["weights"])).unwrap());
        for (k, &u) in params.iter().enumerate() {
            let d = match &curve {
                Curve64::B(b) => b.derivs(u, 2),
                Curve64::N(n) => n.derivs(u, 2),
            };
            let scale = 1f64.max(d1[k].length()).max(d2[k].length());
            let ep = (d[0] - pts[k]).length();
            let e1 = (d[1] - d1[k]).length() / scale;
            let e2 = (d[2] - d2[k]).length() / scale;
            assert!(
                ep <= 1e-12,
                "case {ci} ({kind}, p={p}) u={u}: |ΔC| = {ep:e}"
            );
            assert!(
                e1 <= 1e-12 && e2 <= 1e-12,
                "case {ci} ({kind}, p={p}) u={u}: ΔC' {e1:e} ΔC'' {e2:e}"
            );
            (max_p, max_d1, max_d2) = (max_p.max(ep), max_d1.max(e1), max_d2.max(e2));
            if let Some(rb) = &rb {
                let r = rb.derivs2(u);
                assert!(
                    (r[0] - pts[k]).length() <= 1e-12 && (r[1] - d1[k]).length() / scale <= 1e-12
                );
            }
            let p32 = match &w32 {
                None => BSplineCurve::new(p, knots32.clone(), ctrl32.clone())
                    .unwrap()
                    .eval(u as f32),
                Some(w) => NurbsCurve::new(p, knots32.clone(), ctrl32.clone(), w.clone())
                    .unwrap()
                    .eval(u as f32),
            };
            let e32 = (p32.as_dvec3() - pts[k]).length() / diag;
            assert!(e32 <= 1e-5, "case {ci} f32 u={u}: {e32:e} × diag");
            max_f32 = max_f32.max(e32);
        }
    }
    assert_eq!(degrees.into_iter().collect::<Vec<_>>(), vec![1, 2, 3, 4, 5]);
    eprintln!(
        "curves vs geomdl ({} cases × ≥101 params): f64 max |ΔC| {max_p:.2e}, ΔC' {max_d1:.2e} rel, ΔC'' {max_d2:.2e} rel; f32 max {max_f32:.2e} × diag",
        cases.len()
    );
}

#[test]
fn notes_vectors_bspline_and_nurbs_at_0_3() {
    let pts: Vec<DVec3> = [
        [0., 0., 0.],
        [1., 2., 0.],
        [3., 3., 1.],
        [4., 1., 2.],
        [6., 0., 1.],
        [7., 2., 0.],
        [9., 3., 1.],
    ]
    .map(DVec3::from)
    .to_vec();
    let knots = vec![0., 0., 0., 0., 0.25, 0.5, 0.75, 1., 1., 1., 1.];
    let b = BSplineCurve::new(3, knots.clone(), pts.clone()).unwrap();
    // the notes print 10 significant digits
    assert!(
        (b.eval(0.3) - DVec3::new(3.030666667, 2.302666667, 1.154666667))
            .abs()
            .max_element()
            < 5e-10
    );
    let n = NurbsCurve::new(3, knots, pts, vec![1., 0.5, 2., 1., 3., 0.7, 1.]).unwrap();
    assert!(
        (n.eval(0.3) - DVec3::new(3.109170306, 2.579912664, 1.143231441))
            .abs()
            .max_element()
            < 5e-10
    );
}

#[test]
fn quarter_circle_has_unit_radius() {
    let w = std::f64::consts::FRAC_1_SQRT_2;
    let q = NurbsCurve::new(
        2,
        vec![0., 0., 0., 1., 1., 1.],
        vec![DVec2::X, DVec2::ONE, DVec2::Y],
        vec![1., w, 1.],
    )
    .unwrap();
    let mut max = 0.0f64;
    for i in 0..=1000 {
        let u = i as f64 / 1000.0;
        max = max.max((q.eval(u).length() - 1.0).abs());
    }
    eprintln!("quarter circle: max ||C(u)| − 1| = {max:.2e} over 1001 params");
    assert!(max <= 1e-12);
    assert!((q.eval(0.0) - DVec2::X).length() == 0.0 && (q.eval(1.0) - DVec2::Y).length() == 0.0);
}

#[test]
fn knot_insertion_matches_geomdl() {
    let fx = fixture("ops.json");
    let mut max = 0.0f64;
    for (ci, c) in fx["insert"].as_array().unwrap().iter().enumerate() {
        let p = c["degree"].as_u64().unwrap() as usize;
        let (u, r) = (
            c["u"].as_f64().unwrap(),
            c["times"].as_u64().unwrap() as usize,
        );
        let (knots, ctrl) = (f64s(&c["knots"]), vec3s(&c["ctrl"]));
        let want_k = f64s(&c["new_knots"]);
        let want_p = vec3s(&c["new_ctrl"]);
        let (got_k, got_p, got_w) = if c["kind"] == "bspline" {
            let d = BSplineCurve::new(p, knots, ctrl)
                .unwrap()
                .insert_knot(u, r)
                .unwrap();
            (d.knots().to_vec(), d.ctrl().to_vec(), None)
        } else {
            let d = NurbsCurve::new(p, knots, ctrl, f64s(&c["weights"]))
                .unwrap()
                .insert_knot(u, r)
                .unwrap();
            (
                d.knots().to_vec(),
                d.ctrl().to_vec(),
                Some(d.weights().to_vec()),
            )
        };
        assert_eq!(got_k.len(), want_k.len(), "case {ci}");
        for (a, b) in got_k.iter().zip(&want_k) {
            assert!(
                (a - b).abs() <= 1e-14,
                "case {ci} knots {got_k:?} vs {want_k:?}"
            );
        }
        assert_eq!(got_p.len(), want_p.len());
        for (a, b) in got_p.iter().zip(&want_p) {
            max = max.max((*a - *b).length());
        }
        if let Some(w) = got_w {
            for (a, b) in w.iter().zip(f64s(&c["new_weights"])) {
                max = max.max((a - b).abs());
            }
        }
    }
    eprintln!("knot insertion vs geomdl: max control point / weight error {max:.2e}");
    assert!(max <= 1e-12);
}

#[test]
fn split_matches_geomdl() {
    let fx = fixture("ops.json");
    let mut max = 0.0f64;
    for (ci, c) in fx["split"].as_array().unwrap().iter().enumerate() {
        let p = c["degree"].as_u64().unwrap() as usize;
        let curve = BSplineCurve::new(p, f64s(&c["knots"]), vec3s(&c["ctrl"])).unwrap();
        let u = c["u"].as_f64().unwrap();
        let (a, b) = curve.split(u).unwrap();
        for (piece, side) in [(&a, "left"), (&b, "right")] {
            let want_p = vec3s(&c[format!("{side}_ctrl")]);
            let want_k = f64s(&c[format!("{side}_knots")]);
            assert_eq!(piece.ctrl().len(), want_p.len(), "case {ci} {side}");
            for (x, y) in piece.ctrl().iter().zip(&want_p) {
                max = max.max((*x - *y).length());
            }
            // geomdl reparameterises each piece to [0, 1]; compare after the same affine map
            let (lo, hi) = piece.domain();
            for (x, y) in piece.knots().iter().zip(&want_k) {
                assert!(
                    ((x - lo) / (hi - lo) - y).abs() <= 1e-12,
                    "case {ci} {side} knots"
                );
            }
        }
    }
    eprintln!("B-spline split vs geomdl: max control point error {max:.2e}");
    assert!(max <= 1e-12);
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let pts = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
    for (degree, knots, why) in [
        (2usize, vec![0., 0., 0., 1., 1.], "too few knots"),
        (2, vec![0., 0., 0.5, 0.2, 1., 1.], "decreasing"),
        (0, vec![0., 0.3, 0.6, 1.], "degree 0"),
        (3, vec![0., 0., 0., 0., 1., 1., 1.], "degree > n - 1"),
        (2, vec![0., 0., 0., f64::NAN, 1., 1.], "NaN knot"),
        (1, vec![0., 1., 1., 1., 1.], "empty domain"),
    ] {
        let e = BSplineCurve::new(degree, knots, pts.clone());
        assert!(e.is_err(), "{why} accepted");
        eprintln!("{why}: {}", e.unwrap_err());
    }
    let k = vec![0., 0., 0., 1., 1., 1.];
    assert!(NurbsCurve::new(2, k.clone(), pts.clone(), vec![1., 1.]).is_err());
    assert!(NurbsCurve::new(2, k.clone(), pts.clone(), vec![1., 0., 1.]).is_err());
    assert!(BSplineCurve::new(2, k.clone(), vec![DVec3::ZERO, DVec3::NAN, DVec3::X]).is_err());
    let c = BSplineCurve::new(2, k, pts).unwrap();
    assert!(c.insert_knot(1.5, 1).is_err());
    assert!(c.insert_knot(0.5, 3).is_err());
    assert!(c.split(0.0).is_err());
    // out-of-domain and NaN parameters clamp instead of producing NaN
    assert_eq!(c.eval(-1.0), DVec3::ZERO);
    assert!(c.eval(f64::NAN).is_finite());
}

/// The textbook recursion N_{i,0} = [U_i ≤ u < U_{i+1}], N_{i,p} = ω N_{i,p−1} + (1−ω') N_{i+1,p−1}
/// with 0/0 := 0: slow, but independent of the library's triangular scheme.
fn cox_de_boor(i: usize, p: usize, u: f64, k: &[f64]) -> f64 {
    if p == 0 {
        return if k[i] <= u && u < k[i + 1] { 1.0 } else { 0.0 };
    }
    let a = if k[i + p] > k[i] {
        (u - k[i]) / (k[i + p] - k[i])
    } else {
        0.0
    };
    let b = if k[i + p + 1] > k[i + 1] {
        (k[i + p + 1] - u) / (k[i + p + 1] - k[i + 1])
    } else {
        0.0
    };
    a * cox_de_boor(i, p - 1, u, k) + b * cox_de_boor(i + 1, p - 1, u, k)
}

#[test]
fn unclamped_and_repeated_knots_match_the_recursive_definition() {
    let ctrl: Vec<DVec3> = (0..9)
        .map(|i| DVec3::new(i as f64, ((i * 7) % 5) as f64 - 2.0, ((i * 3) % 4) as f64))
        .collect();
    let cases: Vec<(usize, Vec<f64>)> = vec![
        // uniform, unclamped: domain [U[p], U[n]] = [3, 9]
        (3, (0..13).map(|i| i as f64).collect()),
        // arbitrary non-decreasing, interior knot of multiplicity 2 and one of multiplicity p, not clamped
        (
            3,
            vec![
                -1.0, 0.0, 0.5, 1.0, 2.0, 2.0, 3.5, 3.5, 3.5, 4.0, 6.0, 7.0, 7.5,
            ],
        ),
        (
            2,
            vec![0.0, 0.0, 1.0, 1.0, 2.0, 3.0, 3.0, 3.0, 5.0, 6.0, 6.0, 6.0],
        ),
        (
            5,
            vec![
                0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0,
            ],
        ),
    ];
    let mut max = 0.0f64;
    for (p, knots) in cases {
        let c = BSplineCurve::new(p, knots.clone(), ctrl.clone()).unwrap();
        let (a, b) = c.domain();
        for s in 0..=200 {
            // the half-open recursion is right-continuous: stay below the domain's end
            let u = a + (b - a) * (s as f64 / 200.0) * (1.0 - 1e-12);
            let want: DVec3 = (0..ctrl.len())
                .map(|i| ctrl[i] * cox_de_boor(i, p, u, &knots))
                .sum();
            max = max.max((c.eval(u) - want).length());
        }
    }
    eprintln!("unclamped / repeated knots vs recursive Cox–de Boor: max {max:.2e}");
    assert!(max <= 1e-12);
}
