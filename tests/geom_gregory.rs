//! The Gregory patch (docs/notes/gregory.md §1) and the Chiyokura–Kimura correction (§2), as specifications.
//!
//! Tolerances: exact derivatives vs central differences ≤ 1e-6 relative (the figure; h = 1e-5 gives
//! truncation ~h² and rounding ~1e-16/h, both ≪ 1e-6); equal pairs = Bézier to 1e-14 × size (same maths,
//! different summation order); G1 after the correction ≤ 1e-9 rad at 33 samples (the notes measure
//! 4.4e-16 residuals); the negative control must jump by more than 1e-3 rad.
use glam::{DVec3, Vec3};
use gregvox::geom::compat::{chiyokura_kimura, ck_correct_edge, Edge};
use gregvox::geom::gregory::{PatchF64, BEZIER_GRID};
use gregvox::geom::surface::NurbsSurface;

/// Deterministic xorshift generator in [0, 1) (no rand dependency in tests).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn sym(&mut self, a: f64) -> f64 {
        (2.0 * self.next() - 1.0) * a
    }
    fn vec(&mut self, a: f64) -> DVec3 {
        DVec3::new(self.sym(a), self.sym(a), self.sym(a))
    }
}

/// A bumpy bicubic Bézier grid over [x0, x0+1] × [y0, y0+1].
fn bumpy_grid(rng: &mut Rng, x0: f64, y0: f64) -> [[DVec3; 4]; 4] {
    std::array::from_fn(|j| {
        std::array::from_fn(|i| {
            DVec3::new(x0 + i as f64 / 3.0, y0 + j as f64 / 3.0, 0.0) + rng.vec(0.25)
        })
    })
}

/// A genuine Gregory patch: a bumpy Bézier grid whose interior pairs are pulled apart.
fn random_gregory(rng: &mut Rng) -> PatchF64 {
    let mut g = PatchF64::from_bezier(&bumpy_grid(rng, 0.0, 0.0));
    for row in &BEZIER_GRID[1..3] {
        for &[a, b] in &row[1..3] {
            g.cv[a] += rng.vec(0.2);
            g.cv[b] += rng.vec(0.2);
        }
    }
    g
}

fn rel(a: DVec3, b: DVec3, scale: f64) -> f64 {
    (a - b).length() / scale.max(1e-300)
}

#[test]
fn exact_derivatives_match_central_differences() {
    let mut rng = Rng(0x9E3779B97F4A7C15);
    let h = 1e-5;
    let (mut max1, mut max2) = (0.0f64, 0.0f64);
    let mut params: Vec<(f64, f64)> = (1..20)
        .flat_map(|i| (1..20).map(move |j| (i as f64 / 20.0, j as f64 / 20.0)))
        .collect();
    params.extend([(0.01, 0.5), (0.5, 0.99), (0.99, 0.02), (0.3, 0.005)]);
    for _ in 0..10 {
        let g = random_gregory(&mut rng);
        for &(u, v) in &params {
            let (_, su, sv) = g.eval(u, v);
            let [suu, suv, svv] = g.second_derivatives(u, v);
            let p = |u, v| g.eval(u, v).0;
            let fd_u = (p(u + h, v) - p(u - h, v)) / (2.0 * h);
            let fd_v = (p(u, v + h) - p(u, v - h)) / (2.0 * h);
            let s1 = su.length().max(sv.length());
            let e1 = rel(su, fd_u, s1).max(rel(sv, fd_v, s1));
            assert!(e1 <= 1e-6, "first derivatives at ({u}, {v}): {e1:e}");
            // second derivatives against central differences of the exact first derivatives
            let d = |u, v| g.eval(u, v);
            let fd_uu = (d(u + h, v).1 - d(u - h, v).1) / (2.0 * h);
            let fd_uv = (d(u, v + h).1 - d(u, v - h).1) / (2.0 * h);
            let fd_vu = (d(u + h, v).2 - d(u - h, v).2) / (2.0 * h);
            let fd_vv = (d(u, v + h).2 - d(u, v - h).2) / (2.0 * h);
            let s2 = suu.length().max(suv.length()).max(svv.length());
            let e2 = rel(suu, fd_uu, s2)
                .max(rel(suv, fd_uv, s2))
                .max(rel(suv, fd_vu, s2))
                .max(rel(svv, fd_vv, s2));
            assert!(e2 <= 1e-6, "second derivatives at ({u}, {v}): {e2:e}");
            max1 = max1.max(e1);
            max2 = max2.max(e2);
        }
    }
    eprintln!("Gregory exact derivatives vs central differences (10 patches × {} params): first {max1:.2e}, second {max2:.2e} relative", params.len());
}

#[test]
fn approximate_derivatives_are_exact_on_edges_only() {
    let mut rng = Rng(7);
    let g = random_gregory(&mut rng);
    let mut max_edge = 0.0f64;
    for k in 0..=32 {
        let t = k as f64 / 32.0;
        for (u, v) in [(t, 0.0), (1.0, t), (t, 1.0), (0.0, t)] {
            let (e, a) = (g.eval(u, v), g.approx_derivatives(u, v));
            max_edge = max_edge.max((e.1 - a.1).length()).max((e.2 - a.2).length());
        }
    }
    let inside = (g.eval(0.4, 0.6).1 - g.approx_derivatives(0.4, 0.6).1).length();
    eprintln!(
        "approximate vs exact derivatives: edges {max_edge:.2e}, inside (0.4, 0.6) {inside:.2e}"
    );
    assert!(max_edge <= 1e-13);
    assert!(
        inside > 1e-3,
        "a genuine Gregory patch must show the frozen-Q error inside"
    );
}

#[test]
fn equal_pairs_give_the_bezier_patch() {
    let mut rng = Rng(42);
    let mut max = 0.0f64;
    for _ in 0..5 {
        let b = bumpy_grid(&mut rng, 0.0, 0.0);
        let g = PatchF64::from_bezier(&b);
        assert_eq!(g.to_bezier(), Some(b));
        // geomdl's order: ctrl[i * size_v + j], i along u
        let flat: Vec<DVec3> = (0..4).flat_map(|i| (0..4).map(move |j| b[j][i])).collect();
        let s = NurbsSurface::bezier([4, 4], flat).unwrap();
        for i in 0..=10 {
            for j in 0..=10 {
                let (u, v) = (i as f64 / 10.0, j as f64 / 10.0);
                let d = s.derivs(u, v);
                let (p, su, sv) = g.eval(u, v);
                let [suu, suv, svv] = g.second_derivatives(u, v);
                for (x, y) in [
                    (p, d.p),
                    (su, d.su),
                    (sv, d.sv),
                    (suu, d.suu),
                    (suv, d.suv),
                    (svv, d.svv),
                ] {
                    max = max.max((x - y).length());
                }
            }
        }
    }
    eprintln!("Gregory with equal pairs vs Bézier (position, 1st, 2nd derivatives): max {max:.2e}");
    assert!(max <= 1e-13);
}

#[test]
fn corners_never_produce_nan_or_inf() {
    let mut rng = Rng(99);
    let ts = [0.0, 1e-7, 1e-4, 1.0 - 1e-7, 1.0];
    let mut max_jump = 0.0f64;
    for _ in 0..10 {
        let g = random_gregory(&mut rng);
        let g32 = g.to_gpu();
        for &u in &ts {
            for &v in &ts {
                let (p, su, sv) = g.eval(u, v);
                let a = g.approx_derivatives(u, v);
                let sec = g.second_derivatives(u, v);
                let n = g.normal(u, v);
                for x in [p, su, sv, a.0, a.1, a.2, sec[0], sec[1], sec[2], n] {
                    assert!(x.is_finite(), "f64 non-finite at ({u}, {v})");
                }
                assert!((n.length() - 1.0).abs() < 1e-12);
                let (uf, vf) = (u as f32, v as f32);
                let (p32, su32, sv32) = g32.eval(uf, vf);
                let sec32 = g32.second_derivatives(uf, vf);
                let n32 = g32.normal(uf, vf);
                for x in [p32, su32, sv32, sec32[0], sec32[1], sec32[2], n32] {
                    assert!(x.is_finite(), "f32 non-finite at ({u}, {v})");
                }
                // the guarded points are continuous: the position next to a corner is the corner's to ~d
                let (cu, cv) = (u.round(), v.round());
                if (u - cu).abs() < 1e-6 && (v - cv).abs() < 1e-6 {
                    max_jump = max_jump.max((p - g.eval(cu, cv).0).length());
                }
            }
        }
        // extreme f32 inputs: far below the guard, and out of range / NaN (clamped)
        for (u, v) in [
            (1e-30f32, 1e-30f32),
            (1e-20, 0.0),
            (-1.0, 2.0),
            (f32::NAN, 0.5),
        ] {
            let (p, su, sv) = g32.eval(u, v);
            assert!(
                p.is_finite() && su.is_finite() && sv.is_finite() && g32.normal(u, v).is_finite()
            );
        }
    }
    eprintln!("corner samples: all finite; |S(near corner) − S(corner)| ≤ {max_jump:.2e}");
    assert!(max_jump < 1e-5);
}

#[test]
fn f32_patch_matches_f64_reference() {
    let mut rng = Rng(5);
    let (mut max, mut max_d, mut max_n) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..10 {
        let g = random_gregory(&mut rng);
        let g32 = g.to_gpu();
        let g64 = g32.to_f64(); // the same (rounded) points in f64
        for i in 0..=16 {
            for j in 0..=16 {
                let (u, v) = (i as f32 / 16.0, j as f32 / 16.0);
                let (p, su, sv) = g32.eval(u, v);
                let (q, qu, qv) = g64.eval(u as f64, v as f64);
                max = max.max((p.as_dvec3() - q).length());
                let sd = qu.length().max(qv.length());
                max_d = max_d
                    .max((su.as_dvec3() - qu).length() / sd)
                    .max((sv.as_dvec3() - qv).length() / sd);
                let (n, m) = (g32.normal(u, v).as_dvec3(), g64.normal(u as f64, v as f64));
                max_n = max_n.max(n.cross(m).length().atan2(n.dot(m)));
            }
        }
    }
    eprintln!(
        "f32 Gregory vs f64 reference (17² × 10 patches incl. edges/corners): |ΔP| {max:.2e} (patch size ~1.5), derivatives {max_d:.2e} rel, normals {max_n:.2e} rad"
    );
    assert!(max <= 1e-6 && max_d <= 1e-5 && max_n <= 1e-5);
}

#[test]
fn degenerate_normals_fall_back() {
    // a triangle as a quad: the whole v = 1 edge collapsed to the apex (0.5, 1, 0)
    let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| {
        std::array::from_fn(|i| {
            let (x, y) = (i as f64 / 3.0, j as f64 / 3.0);
            DVec3::new(0.5 + (x - 0.5) * (1.0 - y), y, 0.3 * x * y * (1.0 - y))
        })
    });
    let g = PatchF64::from_bezier(&b);
    for k in 0..=8 {
        let u = k as f64 / 8.0;
        let (_, su, _) = g.eval(u, 1.0);
        assert!(su.length() < 1e-14, "S_u vanishes on the collapsed edge");
        let n = g.normal(u, 1.0);
        assert!(n.is_finite() && (n.length() - 1.0).abs() < 1e-12);
        assert!(
            n.z > 0.9,
            "fallback normal {n} must face +z like the rest of the patch"
        );
        let n32 = g.to_gpu().normal(u as f32, 1.0);
        assert!((n32.as_dvec3() - n).length() < 1e-5);
    }
    // the flat triangle: S_u on the collapsed edge is rounding noise (~1e-17), whose direction must not be
    // trusted (an angle-only test would return −Z here); the fallback gives +Z to rounding
    let flat: [[DVec3; 4]; 4] = std::array::from_fn(|j| {
        std::array::from_fn(|i| {
            let (x, y) = (i as f64 / 3.0, j as f64 / 3.0);
            DVec3::new(0.5 + (x - 0.5) * (1.0 - y), y, 0.0)
        })
    });
    let g = PatchF64::from_bezier(&flat);
    for k in 0..=8 {
        let u = k as f64 / 8.0;
        assert!(
            (g.normal(u, 1.0) - DVec3::Z).length() < 1e-12,
            "u = {u}: {}",
            g.normal(u, 1.0)
        );
        assert!((g.to_gpu().normal(u as f32, 1.0) - Vec3::Z).length() < 1e-6);
    }
    // everything collapsed: +Z by convention, never NaN
    let z = PatchF64 {
        cv: [DVec3::ONE; 20],
    };
    assert_eq!(z.normal(0.3, 0.3), DVec3::Z);
    assert_eq!(z.to_gpu().normal(0.0, 0.0), Vec3::Z);
}

/// Two patches sharing A's edge `ea` and B's edge `eb`, corners made G1 with the given (k, h), the rest
/// random: returns (A, B, reversed).
fn shared_pair(
    rng: &mut Rng,
    ea: Edge,
    eb: Edge,
    reversed: bool,
    kh: [(f64, f64); 2],
) -> (PatchF64, PatchF64) {
    let a = random_gregory(rng);
    let mut bgrid = bumpy_grid(rng, 0.0, -1.0);
    if reversed {
        bgrid = std::array::from_fn(|j| std::array::from_fn(|i| bgrid[3 - j][3 - i]));
    }
    let mut b = PatchF64::from_bezier(&bgrid);
    for row in &BEZIER_GRID[1..3] {
        for &[x, y] in &row[1..3] {
            b.cv[x] += rng.vec(0.2);
            b.cv[y] += rng.vec(0.2);
        }
    }
    let (pa, ia) = (ea.boundary(), ea.inner());
    let (mut pb, mut ib) = (eb.boundary(), eb.inner());
    if reversed {
        pb.reverse();
        ib.reverse();
    }
    for s in 0..4 {
        b.cv[pb[s]] = a.cv[pa[s]];
    }
    let p: [DVec3; 4] = pa.map(|i| a.cv[i]);
    let (a0, a3) = (a.cv[ia[0]] - p[0], a.cv[ia[3]] - p[3]);
    b.cv[ib[0]] = p[0] + a0 * kh[0].0 + (p[1] - p[0]) * kh[0].1;
    b.cv[ib[3]] = p[3] + a3 * kh[1].0 + (p[3] - p[2]) * kh[1].1;
    (a, b)
}

/// Max angle between the unit normals of A and B at 33 samples of the shared edge (and the position gap).
fn normal_jump(a: &PatchF64, ea: Edge, b: &PatchF64, eb: Edge, reversed: bool) -> (f64, f64) {
    let (mut jump, mut gap) = (0.0f64, 0.0f64);
    for k in 0..=32 {
        let t = k as f64 / 32.0;
        let (ua, va) = ea.uv(t);
        let (ub, vb) = eb.uv(if reversed { 1.0 - t } else { t });
        let (na, nb) = (a.normal(ua, va), b.normal(ub, vb));
        jump = jump.max(na.cross(nb).length().atan2(na.dot(nb)));
        gap = gap.max((a.eval(ua, va).0 - b.eval(ub, vb).0).length());
    }
    (jump, gap)
}

#[test]
fn chiyokura_kimura_makes_the_shared_edge_g1() {
    let mut rng = Rng(2024);
    let configs = [
        (Edge::V0, Edge::V1, false, [(-0.7, 0.2), (-1.3, -0.1)]),
        (Edge::V0, Edge::V0, true, [(-1.0, 0.0), (-0.5, 0.4)]),
        (Edge::V0, Edge::V1, false, [(-2.0, -0.3), (-0.8, 0.25)]),
    ];
    let (mut worst_after, mut least_before) = (0.0f64, f64::INFINITY);
    for (ci, &(ea, eb, rev, kh)) in configs.iter().enumerate() {
        for _ in 0..5 {
            let (mut a, mut b) = shared_pair(&mut rng, ea, eb, rev, kh);
            let (before, gap0) = normal_jump(&a, ea, &b, eb, rev);
            let s = ck_correct_edge(&mut a, ea, &mut b, eb).unwrap();
            let (after, gap) = normal_jump(&a, ea, &b, eb, rev);
            assert!(gap0 <= 1e-15 && gap <= 1e-15, "C0 gap {gap0:e} / {gap:e}");
            assert!(s.corner_residual[0] < 1e-12 && s.corner_residual[1] < 1e-12);
            assert!(
                (s.k[0] - kh[0].0).abs() < 1e-12 && (s.h[1] - kh[1].1).abs() < 1e-12,
                "config {ci}: {s:?}"
            );
            assert!(
                after <= 1e-9,
                "config {ci}: normal jump after correction {after:e} rad"
            );
            assert!(
                before > 1e-3,
                "config {ci}: negative control jump {before:e} rad is not measurable"
            );
            worst_after = worst_after.max(after);
            least_before = least_before.min(before);
        }
    }
    eprintln!(
        "Chiyokura–Kimura, 15 bent patch pairs × 33 samples: max normal jump after {worst_after:.2e} rad; before (negative control) ≥ {least_before:.2e} rad"
    );
}

#[test]
fn chiyokura_kimura_residual_is_zero_for_all_t() {
    // B(t) − k(t)A(t) − h(t)C(t) on the Bézier forms, directly
    let mut rng = Rng(11);
    let p: [DVec3; 4] = std::array::from_fn(|i| DVec3::new(i as f64, 0.0, 0.0) + rng.vec(0.3));
    let (a0, a3) = (DVec3::Y + rng.vec(0.3), DVec3::Y + rng.vec(0.3));
    let b0 = a0 * -0.6 + (p[1] - p[0]) * 0.3;
    let b3 = a3 * -1.4 + (p[3] - p[2]) * -0.2;
    let s = chiyokura_kimura(&p, a0, a3, b0, b3).unwrap();
    let c = [p[1] - p[0], p[2] - p[1], p[3] - p[2]];
    let a = [a0, s.a_face[0] - p[1], s.a_face[1] - p[2], a3];
    let b = [b0, s.b_face[0] - p[1], s.b_face[1] - p[2], b3];
    let bern3 = |t: f64| {
        [
            (1. - t).powi(3),
            3. * t * (1. - t).powi(2),
            3. * t * t * (1. - t),
            t.powi(3),
        ]
    };
    let mut max = 0.0f64;
    for k in 0..=100 {
        let t = k as f64 / 100.0;
        let w = bern3(t);
        let at: DVec3 = (0..4).map(|i| a[i] * w[i]).sum();
        let bt: DVec3 = (0..4).map(|i| b[i] * w[i]).sum();
        let ct = c[0] * (1. - t).powi(2) + c[1] * (2. * t * (1. - t)) + c[2] * t * t;
        let kt = s.k[0] * (1. - t) + s.k[1] * t;
        let ht = s.h[0] * (1. - t) + s.h[1] * t;
        max = max.max((bt - at * kt - ct * ht).length());
    }
    eprintln!("CK residual |B(t) − k(t)A(t) − h(t)C(t)| over 101 t: {max:.2e}");
    assert!(max <= 1e-14);
    // degenerate input is an error, not a panic
    assert!(chiyokura_kimura(&p, c[0], a3, b0, b3).is_err());
    assert!(chiyokura_kimura(&p, DVec3::NAN, a3, b0, b3).is_err());
}

/// The 20-point layout, checked from OpenSubdiv's *definitions* rather than from our own table: corners
/// CCW (0,0), (1,0), (1,1), (0,1); corner i owns [P, Ep, Em, Fp, Fm] at 5i..5i+4; Ep_i lies on the edge
/// towards corner i+1, Em_i on the edge towards corner i−1; Fp_i sets the cross-boundary derivative of the
/// Ep edge only, Fm_i that of the Em edge only (the Gregory decoupling).
#[test]
fn layout_follows_opensubdiv_gregory_basis_semantics() {
    // edge k joins corner k to corner k+1
    let edge_uv = |k: usize, t: f64| match k {
        0 => (t, 0.0),
        1 => (1.0, t),
        2 => (1.0 - t, 1.0),
        _ => (0.0, 1.0 - t),
    };
    let mut rng = Rng(31337);
    let g = random_gregory(&mut rng);
    // per edge: max change of the position and of the cross-boundary derivative over interior samples
    let changes = |h: &PatchF64| -> [(f64, f64); 4] {
        std::array::from_fn(|k| {
            let (mut dp, mut dx) = (0.0f64, 0.0f64);
            for s in 1..16 {
                let (u, v) = edge_uv(k, s as f64 / 16.0);
                let (a, b) = (g.eval(u, v), h.eval(u, v));
                let cross = |e: (DVec3, DVec3, DVec3)| if k % 2 == 0 { e.2 } else { e.1 };
                dp = dp.max((a.0 - b.0).length());
                dx = dx.max((cross(a) - cross(b)).length());
            }
            (dp, dx)
        })
    };
    for i in 0..4 {
        let (ep_edge, em_edge) = (i, (i + 3) % 4);
        for (slot, what) in [(1, "Ep"), (2, "Em"), (3, "Fp"), (4, "Fm")] {
            let mut h = g;
            h.cv[5 * i + slot] += DVec3::new(0.1, -0.2, 0.3);
            let c = changes(&h);
            let own = if slot == 1 || slot == 3 {
                ep_edge
            } else {
                em_edge
            };
            for (k, &(dp, dx)) in c.iter().enumerate() {
                let on_boundary = slot <= 2; // edge points move the boundary curve itself
                if k == own {
                    assert!(
                        dx > 1e-3,
                        "{what}{i} must steer edge {k}'s cross derivative"
                    );
                    assert_eq!(
                        dp > 1e-3,
                        on_boundary,
                        "{what}{i}: edge {k} position change {dp:e}"
                    );
                } else if slot >= 3 {
                    assert!(
                        dp < 1e-15 && dx < 1e-15,
                        "{what}{i} leaks into edge {k}: {dp:e} {dx:e}"
                    );
                }
            }
        }
    }
}
