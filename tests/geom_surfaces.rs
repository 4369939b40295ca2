//! Tensor-product surfaces vs geomdl 5.4.0 (tests/fixtures/geom/surfaces.json: B-spline and NURBS, degrees
//! 1–5 per direction, random clamped knots, weights in [0.5, 2], Bézier and rational Bézier patches; 101
//! (u, v) per case incl. the 4 corners), and normals/curvature vs closed forms (sphere, cylinder).
//!
//! Tolerances: positions ≤ 1e-12 absolute (f64); derivatives ≤ 1e-12 relative to the largest derivative
//! magnitude at that (u, v) (they scale with 1/knot gap); f32 positions ≤ 1e-5 × control-net bbox diagonal;
//! curvature of exact conics ≤ 1e-12.
use glam::{DVec3, Vec3};
use gregvox::geom::surface::NurbsSurface;
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

#[test]
fn surfaces_match_geomdl() {
    let fx = fixture("surfaces.json");
    let cases = fx["cases"].as_array().unwrap();
    let (mut mp, mut md, mut m32) = (0.0f64, 0.0f64, 0.0f64);
    let mut kinds = std::collections::BTreeSet::new();
    for (ci, c) in cases.iter().enumerate() {
        let deg = [
            c["degree_u"].as_u64().unwrap() as usize,
            c["degree_v"].as_u64().unwrap() as usize,
        ];
        let size = [
            c["size_u"].as_u64().unwrap() as usize,
            c["size_v"].as_u64().unwrap() as usize,
        ];
        let ctrl = vec3s(&c["ctrl"]);
        let weights = c["weights"].as_array().map(|_| f64s(&c["weights"]));
        let bezier = c["knots_kind"] == "bezier";
        kinds.insert((c["kind"].as_str().unwrap().to_string(), bezier));
        let s = match (bezier, &weights) {
            (true, None) => NurbsSurface::bezier(size, ctrl.clone()).unwrap(),
            (true, Some(w)) => {
                NurbsSurface::rational_bezier(size, ctrl.clone(), w.clone()).unwrap()
            }
            _ => NurbsSurface::new(
                deg,
                size,
                f64s(&c["knots_u"]),
                f64s(&c["knots_v"]),
                ctrl.clone(),
                weights.clone(),
            )
            .unwrap(),
        };
        assert_eq!(s.degree(), deg);
        let s32 = NurbsSurface::new(
            deg,
            size,
            f64s(&c["knots_u"]).iter().map(|&k| k as f32).collect(),
            f64s(&c["knots_v"]).iter().map(|&k| k as f32).collect(),
            ctrl.iter().map(|p| p.as_vec3()).collect::<Vec<Vec3>>(),
            weights
                .as_ref()
                .map(|w| w.iter().map(|&x| x as f32).collect()),
        )
        .unwrap();
        let lo = ctrl.iter().fold(DVec3::INFINITY, |a, &b| a.min(b));
        let hi = ctrl.iter().fold(DVec3::NEG_INFINITY, |a, &b| a.max(b));
        let diag = (hi - lo).length();
        let want: Vec<Vec<DVec3>> = ["p", "su", "sv", "suu", "suv", "svv"]
            .iter()
            .map(|k| vec3s(&c[*k]))
            .collect();
        let params = c["params"].as_array().unwrap();
        assert!(params.len() >= 101);
        for (i, uv) in params.iter().enumerate() {
            let uv = f64s(uv);
            let d = s.derivs(uv[0], uv[1]);
            let got = [d.p, d.su, d.sv, d.suu, d.suv, d.svv];
            let ep = (got[0] - want[0][i]).length();
            let scale = (1..6).map(|k| want[k][i].length()).fold(1.0f64, f64::max);
            let ed = (1..6)
                .map(|k| (got[k] - want[k][i]).length() / scale)
                .fold(0.0f64, f64::max);
            assert!(
                ep <= 1e-12 && ed <= 1e-12,
                "case {ci} at {uv:?}: |ΔS| {ep:e}, derivatives {ed:e}"
            );
            let e32 =
                (s32.eval(uv[0] as f32, uv[1] as f32).as_dvec3() - want[0][i]).length() / diag;
            assert!(e32 <= 1e-5, "case {ci} f32 at {uv:?}: {e32:e}");
            (mp, md, m32) = (mp.max(ep), md.max(ed), m32.max(e32));
        }
    }
    assert_eq!(
        kinds.len(),
        4,
        "B-spline, NURBS, Bézier, rational Bézier all covered: {kinds:?}"
    );
    eprintln!(
        "surfaces vs geomdl ({} cases × 101 (u,v)): f64 |ΔS| {mp:.2e}, derivatives (1st+2nd) {md:.2e} rel; f32 {m32:.2e} × diag",
        cases.len()
    );
}

/// The unit sphere's first octant as a rational biquadratic: meridian quarter circle (x = r, z) in u,
/// revolved by 90° about z in v. Pole (degenerate edge) at u = 1.
fn sphere_octant() -> NurbsSurface<f64, DVec3> {
    let w = std::f64::consts::FRAC_1_SQRT_2;
    let meridian = [(1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]; // (r, z)
    let around = [(1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]; // (cx, cy)
    let wt = [1.0, w, 1.0];
    let mut ctrl = Vec::new();
    let mut weights = Vec::new();
    for (i, &(r, z)) in meridian.iter().enumerate() {
        for (j, &(cx, cy)) in around.iter().enumerate() {
            ctrl.push(DVec3::new(r * cx, r * cy, z));
            weights.push(wt[i] * wt[j]);
        }
    }
    NurbsSurface::rational_bezier([3, 3], ctrl, weights).unwrap()
}

#[test]
fn sphere_normals_and_curvature() {
    let s = sphere_octant();
    let (mut mr, mut mk, mut mn) = (0.0f64, 0.0f64, 0.0f64);
    for i in 1..20 {
        for j in 0..=20 {
            let (u, v) = (i as f64 / 20.0, j as f64 / 20.0);
            let d = s.derivs(u, v);
            mr = mr.max((d.p.length() - 1.0).abs());
            let n = d.normal().unwrap();
            // S_u points up the meridian, S_v around z: S_u × S_v points inwards, so n = −p
            mn = mn.max((n + d.p).length());
            let (k, h) = d.curvature().unwrap();
            mk = mk.max((k - 1.0).abs()).max((h - 1.0).abs()); // bends towards n: H = +1
        }
    }
    eprintln!("sphere octant (rational biquadratic): ||S| − 1| {mr:.2e}, normal {mn:.2e}, |K − 1|, |H − 1| {mk:.2e}");
    assert!(mr <= 1e-14 && mn <= 1e-13 && mk <= 1e-12);
}

#[test]
fn cylinder_curvature() {
    // radius 2: K = 0, |H| = 1/(2R) = 1/4
    let w = std::f64::consts::FRAC_1_SQRT_2;
    let r = 2.0;
    let ctrl = vec![
        DVec3::new(r, 0., 0.),
        DVec3::new(r, 0., 3.),
        DVec3::new(r, r, 0.),
        DVec3::new(r, r, 3.),
        DVec3::new(0., r, 0.),
        DVec3::new(0., r, 3.),
    ];
    let s = NurbsSurface::rational_bezier([3, 2], ctrl, vec![1., 1., w, w, 1., 1.]).unwrap();
    let mut max = 0.0f64;
    for i in 0..=10 {
        let d = s.derivs(i as f64 / 10.0, 0.37);
        let (k, h) = d.curvature().unwrap();
        max = max.max(k.abs()).max((h.abs() - 0.25).abs());
    }
    assert!(max <= 1e-14, "{max:e}");
}

#[test]
fn bad_surface_input_is_an_error() {
    let k = vec![0., 0., 1., 1.];
    let four = vec![DVec3::ZERO; 4];
    assert!(NurbsSurface::new(
        [1, 1],
        [2, 2],
        k.clone(),
        k.clone(),
        four.clone(),
        Some(vec![1.; 3])
    )
    .is_err());
    assert!(NurbsSurface::new(
        [1, 1],
        [2, 2],
        k.clone(),
        k.clone(),
        four.clone(),
        Some(vec![1., 1., -1., 1.])
    )
    .is_err());
    assert!(NurbsSurface::new(
        [1, 1],
        [2, 2],
        k.clone(),
        vec![0., 1., 0., 1.],
        four.clone(),
        None
    )
    .is_err());
    assert!(NurbsSurface::new([2, 1], [2, 2], k.clone(), k.clone(), four.clone(), None).is_err());
    assert!(NurbsSurface::<f64, DVec3>::bezier([0, 2], vec![]).is_err());
    let e = NurbsSurface::new([1, 1], [2, 3], k.clone(), k, four, None).unwrap_err();
    eprintln!("{e}");
}

#[test]
fn affine_and_projective_invariance() {
    use glam::{DMat4, DQuat};
    use gregvox::geom::nurbs::NurbsCurve;
    use gregvox::geom::transform::{transform_points, transform_rational};
    let m = DMat4::from_scale_rotation_translation(
        DVec3::new(2.0, 0.5, 1.5),
        DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1),
        DVec3::new(1.0, -2.0, 3.0),
    );
    let ctrl = vec![
        DVec3::ZERO,
        DVec3::new(1., 2., 0.),
        DVec3::new(3., 3., 1.),
        DVec3::new(4., 1., 2.),
        DVec3::new(6., 0., 1.),
    ];
    let w = vec![1., 0.5, 2., 1., 3.];
    let knots = vec![0., 0., 0., 0., 0.5, 1., 1., 1., 1.];
    let c = NurbsCurve::new(3, knots.clone(), ctrl.clone(), w.clone()).unwrap();
    let ct = NurbsCurve::new(3, knots.clone(), transform_points(&m, &ctrl), w.clone()).unwrap();
    // a genuinely projective map (perspective row): the weights must change with the points
    let mut pm = DMat4::IDENTITY;
    pm.x_axis.w = 0.05;
    pm.z_axis.w = 0.1;
    let (pp, pw) = transform_rational(&pm, &ctrl, &w).unwrap();
    let cp = NurbsCurve::new(3, knots, pp, pw).unwrap();
    let (mut ea, mut ep) = (0.0f64, 0.0f64);
    for k in 0..=100 {
        let u = k as f64 / 100.0;
        ea = ea.max((ct.eval(u) - m.transform_point3(c.eval(u))).length());
        let h = pm * c.eval(u).extend(1.0);
        let want = h.truncate() / h.w;
        ep = ep.max((cp.eval(u) - want).length());
    }
    eprintln!("NURBS affine invariance {ea:.2e}, projective invariance {ep:.2e}");
    assert!(ea <= 1e-13 && ep <= 1e-13);
    // a weight pushed through the plane at infinity is an error
    let mut bad = DMat4::IDENTITY;
    bad.x_axis.w = -1.0;
    assert!(transform_rational(&bad, &ctrl, &w).is_err());
}
