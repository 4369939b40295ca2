//! Lecture kernels: Bresenham vs skimage 0.26.0 (tests/fixtures/geom/bresenham.json), Amanatides–Woo DDA
//! vs a brute-force segment/box test, ray–sphere and ray–triangle vs closed forms, shading and shadows.
use glam::{DVec3, IVec2, IVec3, UVec3};
use gregvox::geom::raster::{bresenham, dda_segment, dda_traverse, VoxelGrid};
use gregvox::geom::ray::{ray_sphere, ray_sphere_hit, ray_triangle};
use gregvox::geom::shading::{in_shadow_spheres, lambert, phong, phong_specular, reflect, Phong};
use serde_json::Value;
use std::collections::HashMap;

fn fixture(name: &str) -> Value {
    let path = format!("{}/tests/fixtures/geom/{name}", env!("CARGO_MANIFEST_DIR"));
    serde_json::from_str(&std::fs::read_to_string(&path).expect("fixture")).expect("json")
}

fn ints(v: &Value) -> Vec<i32> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_i64().unwrap() as i32)
        .collect()
}

fn pts(flat: &[i32]) -> Vec<IVec2> {
    flat.chunks(2).map(|c| IVec2::new(c[0], c[1])).collect()
}

#[test]
fn bresenham_equals_skimage_for_every_pair_in_minus8_8() {
    let fx = fixture("bresenham.json");
    // skimage's line depends on p1 − p0 only; the generator asserted that for all 17⁴ pairs
    assert_eq!(
        fx["translation_invariance_checked_pairs"].as_u64(),
        Some(83521)
    );
    let rel: HashMap<IVec2, Vec<IVec2>> = fx["offsets"]
        .as_array()
        .unwrap()
        .iter()
        .zip(fx["lines"].as_array().unwrap())
        .map(|(o, l)| {
            let o = ints(o);
            (IVec2::new(o[0], o[1]), pts(&ints(l)))
        })
        .collect();
    assert_eq!(rel.len(), 33 * 33);
    let mut pairs = 0;
    for x0 in -8..=8 {
        for y0 in -8..=8 {
            for x1 in -8..=8 {
                for y1 in -8..=8 {
                    let (p0, p1) = (IVec2::new(x0, y0), IVec2::new(x1, y1));
                    let want: Vec<IVec2> = rel[&(p1 - p0)].iter().map(|&d| p0 + d).collect();
                    let got = bresenham(p0, p1);
                    assert_eq!(got, want, "{p0} → {p1}");
                    assert_eq!(got.first(), Some(&p0));
                    assert_eq!(got.last(), Some(&p1));
                    pairs += 1;
                }
            }
        }
    }
    // and 2000 absolute pairs straight from skimage, no invariance assumed
    let sample = fx["absolute_sample"].as_array().unwrap();
    for s in sample {
        let (a, b) = (ints(&s["p0"]), ints(&s["p1"]));
        assert_eq!(
            bresenham(IVec2::new(a[0], a[1]), IVec2::new(b[0], b[1])),
            pts(&ints(&s["line"]))
        );
    }
    eprintln!("Bresenham = skimage.draw.line on all {pairs} end-point pairs in [−8,8]² and {} absolute samples", sample.len());
    assert_eq!(pairs, 83521);
}

#[test]
fn bresenham_reversal_differs_in_tie_cases_like_skimage() {
    let mut asymmetric = 0;
    for dx in -8..=8 {
        for dy in -8..=8 {
            let (a, b) = (IVec2::ZERO, IVec2::new(dx, dy));
            let mut back = bresenham(b, a);
            back.reverse();
            asymmetric += (bresenham(a, b) != back) as i32;
        }
    }
    // counted with skimage 0.26.0 on the same 289 offsets (see raster.rs module docs)
    assert_eq!(asymmetric, 112);
}

#[test]
fn bresenham_lines_are_8_connected_and_cover_the_major_axis() {
    for (a, b) in [
        (IVec2::new(-100, 3), IVec2::new(250, -40)),
        (IVec2::new(5, 5), IVec2::new(5, 5)),
        (IVec2::new(0, 0), IVec2::new(-3, 90)),
    ] {
        let l = bresenham(a, b);
        let d = (b - a).abs();
        assert_eq!(l.len() as i32, d.x.max(d.y) + 1);
        assert!(l.windows(2).all(|w| (w[1] - w[0]).abs().max_element() == 1));
    }
}

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
}

/// Every voxel whose box the segment crosses over a parameter interval of positive length (brute force,
/// Liang–Barsky clipping written independently of the library's `ray_box`).
fn brute_force(g: &VoxelGrid, p0: DVec3, p1: DVec3) -> Vec<IVec3> {
    let d = p1 - p0;
    let mut out = Vec::new();
    for i in 0..g.dims.x as i32 {
        for j in 0..g.dims.y as i32 {
            for k in 0..g.dims.z as i32 {
                let v = IVec3::new(i, j, k);
                let lo = g.origin + v.as_dvec3() * g.cell;
                let hi = lo + DVec3::splat(g.cell);
                let (mut t0, mut t1) = (0.0f64, 1.0f64);
                let mut inside = true;
                for (pp, q) in [
                    (-d.x, p0.x - lo.x),
                    (d.x, hi.x - p0.x),
                    (-d.y, p0.y - lo.y),
                    (d.y, hi.y - p0.y),
                    (-d.z, p0.z - lo.z),
                    (d.z, hi.z - p0.z),
                ] {
                    if pp == 0.0 {
                        inside &= q >= 0.0;
                    } else if pp < 0.0 {
                        t0 = t0.max(q / pp);
                    } else {
                        t1 = t1.min(q / pp);
                    }
                }
                if inside && t1 > t0 {
                    out.push(v);
                }
            }
        }
    }
    out
}

#[test]
fn dda_through_voxel_edges_steps_diagonally() {
    // a ray exactly through the edges x = y = k: the voxels (k+1, k) and (k, k+1) touch it in a point only
    let g = VoxelGrid::new(DVec3::ZERO, 1.0, UVec3::new(4, 4, 1)).unwrap();
    let v = dda_segment(&g, DVec3::new(0.0, 0.0, 0.5), DVec3::new(4.0, 4.0, 0.5));
    assert_eq!(v, (0..4).map(|k| IVec3::new(k, k, 0)).collect::<Vec<_>>());
    assert_eq!(
        brute_force(&g, DVec3::new(0.0, 0.0, 0.5), DVec3::new(4.0, 4.0, 0.5)),
        v
    );
    // grid-aligned start on a voxel face, going −x
    let v = dda_segment(&g, DVec3::new(3.0, 0.5, 0.5), DVec3::new(-1.0, 0.5, 0.5));
    assert_eq!(
        v,
        vec![
            IVec3::new(2, 0, 0),
            IVec3::new(1, 0, 0),
            IVec3::new(0, 0, 0)
        ]
    );
}

#[test]
fn dda_visits_exactly_the_brute_force_voxels() {
    let g = VoxelGrid::new(DVec3::new(-1.3, 0.2, 0.7), 0.37, UVec3::new(9, 7, 8)).unwrap();
    let hi = g.origin + g.dims.as_dvec3() * g.cell;
    let mut rng = Rng(0xDDA);
    let mut total = 0;
    for case in 0..3000 {
        // segments inside, crossing in and out, missing; every 4th one axis-parallel in one or two axes
        let mut p = |_| {
            DVec3::new(
                rng.range(g.origin.x - 1.0, hi.x + 1.0),
                rng.range(g.origin.y - 1.0, hi.y + 1.0),
                rng.range(g.origin.z - 1.0, hi.z + 1.0),
            )
        };
        let p0 = p(0);
        let mut p1 = p(1);
        match case % 4 {
            1 => p1.y = p0.y,
            2 => {
                p1.x = p0.x;
                p1.z = p0.z;
            }
            _ => {}
        }
        let got = dda_segment(&g, p0, p1);
        let mut want = brute_force(&g, p0, p1);
        let mut sorted = got.clone();
        sorted.sort_by_key(|v| (v.x, v.y, v.z));
        want.sort_by_key(|v| (v.x, v.y, v.z));
        assert_eq!(sorted, want, "segment {p0} → {p1}");
        // in order along the segment, face-adjacent steps, no repeats
        assert!(
            got.windows(2)
                .all(|w| (w[1] - w[0]).abs().element_sum() == 1),
            "{got:?}"
        );
        total += got.len();
    }
    eprintln!("DDA = brute force on 3000 random segments ({total} voxels visited)");
    assert!(total > 10_000);
}

#[test]
fn dda_stops_early_and_reports_entry_parameters() {
    let g = VoxelGrid::new(DVec3::ZERO, 1.0, UVec3::splat(8)).unwrap();
    let mut seen = Vec::new();
    dda_traverse(
        &g,
        DVec3::new(0.5, 0.5, -2.0),
        DVec3::Z * 2.0,
        0.0,
        f64::INFINITY,
        |v, t0, t1| {
            seen.push((v.z, t0, t1));
            v.z < 3
        },
    );
    assert_eq!(
        seen,
        vec![(0, 1.0, 1.5), (1, 1.5, 2.0), (2, 2.0, 2.5), (3, 2.5, 3.0)]
    );
    // degenerate rays visit nothing
    let mut n = 0;
    dda_traverse(&g, DVec3::ONE, DVec3::ZERO, 0.0, 1.0, |_, _, _| {
        n += 1;
        true
    });
    dda_traverse(&g, DVec3::NAN, DVec3::X, 0.0, 1.0, |_, _, _| {
        n += 1;
        true
    });
    assert_eq!(n, 0);
}

#[test]
fn ray_sphere_closed_forms() {
    let c = DVec3::new(1.0, -2.0, 0.5);
    let r = 1.5;
    // hit: along the axis through the centre, roots at distance d ∓ r
    let o = c - DVec3::new(0.0, 0.0, 10.0);
    let (t0, t1) = ray_sphere(o, DVec3::Z, c, r).unwrap();
    assert!((t0 - 8.5).abs() <= 1e-12 && (t1 - 11.5).abs() <= 1e-12);
    // non-unit direction: parameters scale by 1/|d|
    let (s0, s1) = ray_sphere(o, DVec3::Z * 4.0, c, r).unwrap();
    assert!((s0 - 8.5 / 4.0).abs() <= 1e-12 && (s1 - 11.5 / 4.0).abs() <= 1e-12);
    // miss and tangent (offset exactly r: one double root)
    assert!(ray_sphere(o + DVec3::X * 1.6, DVec3::Z, c, r).is_none());
    let (a, b) = ray_sphere(o + DVec3::X * r, DVec3::Z, c, r).unwrap();
    assert!((a - 10.0).abs() <= 1e-12 && (b - 10.0).abs() <= 1e-12);
    // origin inside: one negative and one positive root; nearest forward hit is the positive one
    let (n0, n1) = ray_sphere(c, DVec3::Y, c, r).unwrap();
    assert!((n0 + r).abs() <= 1e-12 && (n1 - r).abs() <= 1e-12);
    assert!((ray_sphere_hit(c, DVec3::Y, c, r, 1e-9).unwrap() - r).abs() <= 1e-12);
    // cancellation-free far away: sphere at distance 1e8
    let (f0, _) = ray_sphere(DVec3::ZERO, DVec3::X, DVec3::new(1e8, 0.0, 0.0), 1.0).unwrap();
    assert!((f0 - (1e8 - 1.0)).abs() <= 1e-7);
    // random: hits lie on the sphere
    let mut rng = Rng(3);
    let mut max = 0.0f64;
    for _ in 0..1000 {
        let o = DVec3::new(rng.range(-5., 5.), rng.range(-5., 5.), rng.range(-5., 5.));
        let d = DVec3::new(rng.range(-1., 1.), rng.range(-1., 1.), rng.range(-1., 1.));
        if let Some((t0, t1)) = ray_sphere(o, d, c, r) {
            for t in [t0, t1] {
                max = max.max(((o + d * t - c).length() - r).abs());
            }
        }
    }
    eprintln!("ray–sphere: random hits off the sphere by ≤ {max:.2e}");
    assert!(max <= 1e-12);
}

#[test]
fn ray_triangle_closed_forms() {
    let (a, b, c) = (
        DVec3::new(0., 0., 1.),
        DVec3::new(2., 0., 1.),
        DVec3::new(0., 2., 1.),
    );
    let h = ray_triangle(DVec3::new(0.5, 0.5, -1.0), DVec3::Z, a, b, c).unwrap();
    assert!(
        (h.t - 2.0).abs() <= 1e-12 && (h.u - 0.25).abs() <= 1e-12 && (h.v - 0.25).abs() <= 1e-12
    );
    // two-sided
    assert!(ray_triangle(DVec3::new(0.5, 0.5, 3.0), -DVec3::Z, a, b, c).is_some());
    // outside, behind, parallel, degenerate
    assert!(ray_triangle(DVec3::new(1.5, 1.5, -1.0), DVec3::Z, a, b, c).is_none());
    assert!(ray_triangle(DVec3::new(0.5, 0.5, 2.0), DVec3::Z, a, b, c).is_none());
    assert!(ray_triangle(DVec3::new(0.5, 0.5, 1.0), DVec3::X, a, b, c).is_none());
    assert!(ray_triangle(DVec3::new(0.5, 0.5, -1.0), DVec3::Z, a, b, b).is_none());
    // random hits: the barycentric point equals the ray point
    let mut rng = Rng(17);
    let mut max = 0.0f64;
    let mut hits = 0;
    for _ in 0..1000 {
        let o = DVec3::new(rng.range(-1., 3.), rng.range(-1., 3.), rng.range(-3., -1.));
        let d = DVec3::new(rng.range(-0.3, 0.3), rng.range(-0.3, 0.3), 1.0);
        if let Some(h) = ray_triangle(o, d, a, b, c) {
            let p = a * (1.0 - h.u - h.v) + b * h.u + c * h.v;
            max = max.max((p - (o + d * h.t)).length());
            hits += 1;
        }
    }
    eprintln!("ray–triangle: {hits} random hits, barycentric vs ray point ≤ {max:.2e}");
    assert!(hits > 100 && max <= 1e-12);
}

#[test]
fn shading_terms() {
    let n = DVec3::Z;
    let l = DVec3::new(0.6, 0.0, 0.8);
    assert!((lambert(n, l) - 0.8).abs() <= 1e-15);
    assert_eq!(lambert(n, -l), 0.0);
    let r = reflect(l, n);
    assert!((r - DVec3::new(-0.6, 0.0, 0.8)).length() <= 1e-15);
    assert!((r.length() - 1.0).abs() <= 1e-15);
    // the highlight peaks in the mirror direction and is 0 behind the surface
    assert!((phong_specular(n, l, r, 32.0) - 1.0).abs() <= 1e-12);
    assert!(phong_specular(n, l, DVec3::Z, 32.0) < phong_specular(n, l, r, 32.0));
    assert_eq!(
        phong_specular(
            n,
            DVec3::new(0.6, 0.0, -0.8),
            DVec3::new(-0.6, 0.0, -0.8),
            32.0
        ),
        0.0
    );
    let m = Phong {
        ka: 0.1,
        kd: 0.5,
        ks: 0.4,
        shininess: 8.0,
    };
    let i = phong(&m, n, l, DVec3::Z, 0.5, 2.0, true);
    let want = 0.1 * 0.5 + 2.0 * (0.5 * 0.8 + 0.4 * 0.8f64.powf(8.0)); // r·v = 0.8
    assert!((i - want).abs() <= 1e-12, "{i} vs {want}");
}

#[test]
fn hard_shadows_behind_an_occluding_sphere() {
    let light = DVec3::new(0.0, 10.0, 0.0);
    let spheres = [(DVec3::new(0.0, 5.0, 0.0), 1.0)];
    // on the floor y = 0 under the sphere: shadowed; far to the side: lit
    assert!(in_shadow_spheres(
        DVec3::ZERO,
        DVec3::Y,
        light,
        1e-4,
        &spheres
    ));
    assert!(!in_shadow_spheres(
        DVec3::new(5.0, 0.0, 0.0),
        DVec3::Y,
        light,
        1e-4,
        &spheres
    ));
    // a light between the point and the sphere: not shadowed (occluder beyond the light)
    assert!(!in_shadow_spheres(
        DVec3::ZERO,
        DVec3::Y,
        DVec3::new(0.0, 2.0, 0.0),
        1e-4,
        &spheres
    ));
    // no acne: a point on the sphere's lit top does not shadow itself thanks to the ε offset
    let top = DVec3::new(0.0, 6.0, 0.0);
    assert!(!in_shadow_spheres(top, DVec3::Y, light, 1e-4, &spheres));
    // penumbra-free boundary: the shadow's edge on the floor is the tangent cone, radius 10/√(25−1)·1
    let edge = 10.0 / (24.0f64).sqrt();
    assert!(in_shadow_spheres(
        DVec3::new(edge - 1e-3, 0.0, 0.0),
        DVec3::Y,
        light,
        1e-4,
        &spheres
    ));
    assert!(!in_shadow_spheres(
        DVec3::new(edge + 1e-3, 0.0, 0.0),
        DVec3::Y,
        light,
        1e-4,
        &spheres
    ));
}

#[test]
fn dda_matches_brute_force_on_lattice_segments_with_ties() {
    // end points on a quarter-cell lattice: many segments pass exactly through voxel edges and corners.
    // Dyadic inputs make every crossing parameter a correctly rounded quotient of exact numbers, so equal
    // crossings compare equal in both implementations and the tie rule is tested, not rounding luck.
    let g = VoxelGrid::new(DVec3::ZERO, 1.0, UVec3::splat(6)).unwrap();
    let mut rng = Rng(0x1A77);
    let mut q = || (rng.range(-4.0, 28.0)).floor() * 0.25;
    let (mut n, mut ties) = (0, 0);
    while n < 3000 {
        let p0 = DVec3::new(q(), q(), q());
        let p1 = DVec3::new(q(), q(), q());
        let d = p1 - p0;
        // a segment lying in a voxel face plane touches two voxel rows: ambiguous by definition, skip
        if (0..3).any(|a| d[a] == 0.0 && p0[a].fract() == 0.0) || d == DVec3::ZERO {
            continue;
        }
        let got = dda_segment(&g, p0, p1);
        let mut sorted = got.clone();
        sorted.sort_by_key(|v| (v.x, v.y, v.z));
        let mut want = brute_force(&g, p0, p1);
        want.sort_by_key(|v| (v.x, v.y, v.z));
        assert_eq!(sorted, want, "segment {p0} → {p1}");
        ties += got
            .windows(2)
            .filter(|w| (w[1] - w[0]).abs().element_sum() > 1)
            .count();
        n += 1;
    }
    eprintln!(
        "DDA = brute force on {n} lattice segments ({ties} diagonal steps through edges/corners)"
    );
    assert!(ties > 50, "the lattice must exercise ties");
}
