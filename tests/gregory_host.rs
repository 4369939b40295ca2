//! The host Gregory evaluator (surface::gregory_host), the kernel CPU devices use: the f32 mirror's bits,
//! the same bits at every SIMD width and thread count, bit-identical shared edges, the Vulkan kernel's
//! results within f32 rounding (also under deformation), and bad layouts refused; the host curvature
//! kernel against the curvature pass and the CPU's fundamental forms, at the same bits at every width.
mod common;

use common::{angle, gregory_points, random_patch, with_gpu};
use glam::{DVec3, Vec3};
use gregvox::engine::cage::{builtin_cage, cage_topology, icosphere_quad_cage};
use gregvox::engine::gregory::{Evaluator, GregorySurface};
use gregvox::geom::gregory::{bezier_net_generic, eval_generic, normal_from_net_f32, PatchF64};
use gregvox::passes::cage_deform::{DeformParams, Deformation};
use gregvox::surface::gregory_host::{curvature, evaluate, HostPatches, HostSimd, HostVertex};
use gregvox::surface::Tangents;

/// Points of separate patches (row 20·p + k) and their trivial layout.
fn separate(patches: &[PatchF64]) -> (Vec<[f32; 4]>, Vec<[u32; 20]>) {
    let rows = (0..patches.len() as u32)
        .map(|p| std::array::from_fn(|k| 20 * p + k as u32))
        .collect();
    (gregory_points(patches), rows)
}

fn run(p: &HostPatches, level: u32, canonical: bool, simd: HostSimd) -> Vec<HostVertex> {
    let per = ((level + 1) * (level + 1)) as usize;
    let mut out = vec![[f32::NAN; 8]; per * p.patch_points.len()];
    evaluate(p, level, canonical, simd, &mut out).unwrap();
    out
}

/// Bits with −0.0 read as 0.0.
fn key(x: &[f32]) -> Vec<u32> {
    x.iter().map(|v| (v + 0.0).to_bits()).collect()
}

/// The hi + lo points of W·cage (the layout of the device's points pass) with the topology's rows.
fn cage_points(mesh: &gregvox::mesh::Mesh) -> (Vec<[f32; 4]>, Vec<[u32; 20]>, Vec<u32>) {
    let (topo, cage, _) = cage_topology(mesh, Tangents::OpenSubdiv).unwrap();
    let pts = topo.w.spmv(&cage);
    let n = pts.len();
    let mut buf = vec![[0.0f32; 4]; 2 * n];
    for (r, p) in pts.iter().enumerate() {
        let hi = p.as_vec3();
        let lo = *p - hi.as_dvec3();
        buf[r] = [hi.x, hi.y, hi.z, 1.0];
        buf[n + r] = [lo.x as f32, lo.y as f32, lo.z as f32, 0.0];
    }
    (buf, topo.patch_points, topo.patch_flags)
}

#[test]
fn host_kernel_writes_the_f32_mirror_of_the_patch_local_points_bit_for_bit() {
    let patches: Vec<PatchF64> = (0..13).map(random_patch).collect();
    let (points, rows) = separate(&patches);
    let flags = vec![0; patches.len()];
    let hp = HostPatches {
        points: &points,
        residual_rows: 0,
        patch_points: &rows,
        patch_flags: &flags,
    };
    for level in [1, 3, 4, 7, 16] {
        let out = run(&hp, level, false, HostSimd::Auto);
        let n = (level + 1) as usize;
        for (p, patch) in patches.iter().enumerate() {
            let world = patch.to_gpu().points();
            let local: [Vec3; 20] = std::array::from_fn(|k| world[k] - world[0]);
            for j in 0..n {
                for i in 0..n {
                    let (u, v) = (i as f32 / level as f32, j as f32 / level as f32);
                    let e = eval_generic(&local, u, v, true, false);
                    let nrm =
                        normal_from_net_f32(&bezier_net_generic(&local, u, v), e.su, e.sv, u, v);
                    let got = out[p * n * n + j * n + i];
                    let want_p = (e.p + world[0]).to_array();
                    assert_eq!(
                        key(&got[..3]),
                        key(&want_p),
                        "position, patch {p}, L {level}, ({i}, {j})"
                    );
                    assert_eq!(
                        key(&got[4..7]),
                        key(&nrm.to_array()),
                        "normal, patch {p}, L {level}, ({i}, {j})"
                    );
                    assert_eq!((got[3], got[7]), (1.0, 0.0));
                }
            }
        }
    }
}

#[test]
fn every_simd_width_and_thread_count_writes_the_same_bits() {
    let (points, rows, flags) = cage_points(&icosphere_quad_cage(1));
    let hp = HostPatches {
        points: &points,
        residual_rows: (points.len() / 2) as u32,
        patch_points: &rows,
        patch_flags: &flags,
    };
    for level in [1, 4, 9, 33] {
        let auto = run(&hp, level, true, HostSimd::Auto);
        let baseline = run(&hp, level, true, HostSimd::Baseline);
        let one_thread = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| run(&hp, level, true, HostSimd::Auto));
        let bits =
            |v: &[HostVertex]| -> Vec<u32> { v.iter().flatten().map(|x| x.to_bits()).collect() };
        assert!(auto.iter().flatten().all(|x| x.is_finite()), "L {level}");
        assert_eq!(bits(&auto), bits(&baseline), "AVX2 vs baseline, L {level}");
        assert_eq!(bits(&auto), bits(&one_thread), "threads vs one, L {level}");
    }
}

#[test]
fn host_shared_edges_are_bit_identical_so_a_closed_cage_has_v_plus_e_times_l_minus_1_edge_points() {
    // On a closed cage every edge sample is shared by the two patches of its edge and every corner by the
    // patches of its vertex: with identical bits the distinct boundary positions are exactly V + E·(L−1).
    for mesh in [builtin_cage(3, 2, 2), icosphere_quad_cage(1)] {
        let (points, rows, flags) = cage_points(&mesh);
        let hp = HostPatches {
            points: &points,
            residual_rows: (points.len() / 2) as u32,
            patch_points: &rows,
            patch_flags: &flags,
        };
        let (v, f) = (mesh.positions.len(), rows.len());
        let e = 2 * f; // all quads, closed: 4F/2
        for level in [1, 2, 5, 8] {
            let out = run(&hp, level as u32, true, HostSimd::Auto);
            let n = level + 1;
            let mut keys = std::collections::HashSet::new();
            for p in 0..f {
                for j in 0..n {
                    for i in 0..n {
                        if i == 0 || j == 0 || i == level || j == level {
                            keys.insert(key(&out[p * n * n + j * n + i][..3]));
                        }
                    }
                }
            }
            assert_eq!(keys.len(), v + e * (level - 1), "L {level}, {f} patches");
        }
    }
}

#[test]
fn host_evaluator_matches_the_vulkan_kernel_at_rest_and_under_deformation() {
    with_gpu(|ctx| {
        let mesh = icosphere_quad_cage(1);
        let (topo, cage, _) = cage_topology(&mesh, Tangents::OpenSubdiv).unwrap();
        for level in [1, 4, 9] {
            let mut host =
                GregorySurface::with_evaluator(ctx, &topo, &cage, level, Evaluator::Host).unwrap();
            let mut vulkan =
                GregorySurface::with_evaluator(ctx, &topo, &cage, level, Evaluator::Vulkan)
                    .unwrap();
            for mode in [Deformation::None, Deformation::Twist, Deformation::Wave] {
                let d = DeformParams {
                    mode,
                    t: 0.7,
                    amplitude: 0.5,
                    box_min: host.box_min(),
                    box_size: host.box_size(),
                };
                host.evaluate(ctx, Some(&d), None).unwrap();
                vulkan.evaluate(ctx, Some(&d), None).unwrap();
                let a = host.read_vertices(ctx).unwrap();
                let b = vulkan.read_vertices(ctx).unwrap();
                assert_eq!(a.len(), b.len());
                let (mut dp, mut dn, mut same) = (0.0f32, 0.0f32, 0usize);
                for (x, y) in a.iter().zip(&b) {
                    let (px, py) = (Vec3::from(x.xyz()), Vec3::from(y.xyz()));
                    dp = dp.max((px - py).length());
                    dn = dn.max(angle(
                        Vec3::from(x.normal_xyz()),
                        Vec3::from(y.normal_xyz()),
                    ));
                    same += (x.position_key() == y.position_key()) as usize;
                    assert_eq!((x.position[3], x.normal[3]), (1.0, 0.0));
                }
                eprintln!(
                    "L {level} {mode:?}: |ΔP| {dp:.2e}, normal {dn:.2e} rad, {same} of {} positions bit-equal",
                    a.len()
                );
                // The cage spans ~2 units: f32 rounding of the same formulas (the driver may fuse).
                assert!(dp < 2e-6, "L {level} {mode:?}: {dp}");
                assert!(dn < 1e-4, "L {level} {mode:?}: {dn}");
            }
        }
    });
}

#[test]
fn host_curvature_matches_the_curvature_pass_and_the_cpu_fundamental_forms_at_every_grid_vertex() {
    const LEVEL: u32 = 6;
    let mesh = builtin_cage(4, 2, 2);
    let (topo, cage, _) = cage_topology(&mesh, Tangents::OpenSubdiv).unwrap();
    let (host, vulkan, points) = with_gpu(|ctx| {
        let mut h =
            GregorySurface::with_evaluator(ctx, &topo, &cage, LEVEL, Evaluator::Host).unwrap();
        let mut v =
            GregorySurface::with_evaluator(ctx, &topo, &cage, LEVEL, Evaluator::Vulkan).unwrap();
        h.evaluate(ctx, None, None).unwrap();
        v.evaluate(ctx, None, None).unwrap();
        (
            h.curvature(ctx).unwrap(),
            v.curvature(ctx).unwrap(),
            h.read_points(ctx).unwrap(),
        )
    });
    let (worst, checked, singular) = common::assert_curvature_matches_cpu(
        "host kernel",
        &topo.patch_points,
        &points,
        LEVEL,
        &host,
    );
    common::assert_curvature_matches_cpu(
        "curvature pass",
        &topo.patch_points,
        &points,
        LEVEL,
        &vulkan,
    );
    // The same formulas in f32 on both sides (the driver may fuse): far tighter than the CPU bound.
    let rel = |x: f32, y: f32| (x as f64 - y as f64).abs() / (y as f64).abs().max(1.0);
    let worst_pass = host
        .iter()
        .zip(&vulkan)
        .map(|(a, b)| rel(a[0], b[0]).max(rel(a[1], b[1])))
        .fold(0.0f64, f64::max);
    eprintln!(
        "host curvature: {checked} vertices, {singular} singular, worst relative error {worst:.2e} vs \
         the CPU, {worst_pass:.2e} vs the pass"
    );
    assert!(
        worst_pass < 1e-4,
        "host vs curvature pass: {worst_pass:.2e}"
    );
}

#[test]
fn host_curvature_writes_the_same_bits_at_every_simd_width_and_thread_count_and_refuses_bad_layouts(
) {
    let (points, rows, flags) = cage_points(&icosphere_quad_cage(1));
    let hp = HostPatches {
        points: &points,
        residual_rows: (points.len() / 2) as u32,
        patch_points: &rows,
        patch_flags: &flags,
    };
    let bits = |v: &[[f32; 2]]| -> Vec<u32> { v.iter().flatten().map(|x| x.to_bits()).collect() };
    let run_hk = |simd: HostSimd, level: u32| {
        let mut out = vec![[0.0f32; 2]; rows.len() * ((level + 1) * (level + 1)) as usize];
        curvature(&hp, level, simd, &mut out).unwrap();
        out
    };
    for level in [1, 4, 9] {
        let auto = run_hk(HostSimd::Auto, level);
        let one_thread = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| run_hk(HostSimd::Auto, level));
        assert!(auto.iter().flatten().all(|x| x.is_finite()), "L {level}");
        assert!(
            auto.iter().any(|hk| hk[0] != 0.0),
            "L {level}: all singular?"
        );
        assert_eq!(
            bits(&auto),
            bits(&run_hk(HostSimd::Baseline, level)),
            "L {level}"
        );
        assert_eq!(bits(&auto), bits(&one_thread), "L {level}");
    }
    // A patch collapsed to a point is singular everywhere: (0, 0), never NaN.
    let (points, rows) = separate(&[PatchF64 {
        cv: [DVec3::new(1.0, 2.0, 3.0); 20],
    }]);
    let collapsed = HostPatches {
        points: &points,
        residual_rows: 0,
        patch_points: &rows,
        patch_flags: &[0],
    };
    let mut hk = vec![[1.0f32; 2]; 25];
    curvature(&collapsed, 4, HostSimd::Auto, &mut hk).unwrap();
    assert!(hk.iter().all(|v| *v == [0.0, 0.0]), "{hk:?}");
    // A wrong output length or level: a message, nothing written.
    let mut short = vec![[0.0f32; 2]; 3];
    let e = curvature(&hp, 4, HostSimd::Auto, &mut short)
        .unwrap_err()
        .to_string();
    assert!(e.contains("the output holds 3 vertices"), "{e}");
    assert!(curvature(&hp, 65, HostSimd::Auto, &mut short).is_err());
    assert!(short.iter().flatten().all(|&x| x == 0.0));
}

#[test]
fn degenerate_patches_get_the_fallback_normal_and_never_nan() {
    // Everything collapsed to one point (+Z), and a patch collapsed to a segment (the hull diagonals).
    let point = PatchF64 {
        cv: [DVec3::new(1.0, 2.0, 3.0); 20],
    };
    let segment = PatchF64 {
        cv: std::array::from_fn(|k| DVec3::new(k as f64, 0.0, 0.0)),
    };
    let patches = [point, segment];
    let (points, rows) = separate(&patches);
    let flags = [0b1010, 0];
    let hp = HostPatches {
        points: &points,
        residual_rows: 0,
        patch_points: &rows,
        patch_flags: &flags,
    };
    for level in [1, 4, 8] {
        let out = run(&hp, level, true, HostSimd::Auto);
        assert!(out.iter().flatten().all(|x| x.is_finite()), "L {level}");
        let n = ((level + 1) * (level + 1)) as usize;
        assert!(out[..n].iter().all(|v| v[4..7] == [0.0, 0.0, 1.0]));
        for v in &out {
            let len = Vec3::new(v[4], v[5], v[6]).length();
            assert!((len - 1.0).abs() < 1e-5, "{len}");
        }
    }
}

#[test]
fn a_degenerate_patch_among_regular_ones_takes_the_fallback_alone_with_the_same_bits_at_every_width(
) {
    // The kernel evaluates eight patches per lane group: a full group with collapsed patches in lanes 2
    // and 5 (and a partial group after it) writes those lanes' fallback normals, the regular lanes'
    // tested normals, and the same bits with AVX2 as with the baseline.
    let point = PatchF64 {
        cv: [DVec3::new(1.0, 2.0, 3.0); 20],
    };
    let mut patches: Vec<PatchF64> = (0..11).map(random_patch).collect();
    patches[2] = point;
    patches[5] = point;
    let (points, rows) = separate(&patches);
    let flags = vec![0; patches.len()];
    let hp = HostPatches {
        points: &points,
        residual_rows: 0,
        patch_points: &rows,
        patch_flags: &flags,
    };
    let alone = |k: usize| {
        let (points, rows) = separate(&patches[k..k + 1]);
        (points, rows)
    };
    for level in [1, 4, 7] {
        let auto = run(&hp, level, false, HostSimd::Auto);
        let baseline = run(&hp, level, false, HostSimd::Baseline);
        let bits =
            |v: &[HostVertex]| -> Vec<u32> { v.iter().flatten().map(|x| x.to_bits()).collect() };
        assert_eq!(bits(&auto), bits(&baseline), "L {level}");
        let n = ((level + 1) * (level + 1)) as usize;
        for k in [2, 5] {
            assert!(auto[k * n..(k + 1) * n]
                .iter()
                .all(|v| v[4..7] == [0.0, 0.0, 1.0]));
        }
        // Each patch evaluated alone (a batch of one) writes the bits it wrote among the others.
        for k in 0..patches.len() {
            let (points, rows) = alone(k);
            let one = HostPatches {
                points: &points,
                residual_rows: 0,
                patch_points: &rows,
                patch_flags: &[0],
            };
            let single = run(&one, level, false, HostSimd::Auto);
            assert_eq!(
                bits(&single),
                bits(&auto[k * n..(k + 1) * n]),
                "patch {k}, L {level}"
            );
        }
    }
}

#[test]
fn host_evaluator_refuses_bad_layouts_with_a_message() {
    let patches = [random_patch(1)];
    let (points, rows) = separate(&patches);
    let flags = [0u32];
    let ok = HostPatches {
        points: &points,
        residual_rows: 0,
        patch_points: &rows,
        patch_flags: &flags,
    };
    let mut out = vec![[0.0; 8]; 25];
    let err = |p: &HostPatches, level: u32, out: &mut [HostVertex]| {
        evaluate(p, level, true, HostSimd::Auto, out)
            .unwrap_err()
            .to_string()
    };
    assert!(err(&ok, 0, &mut out).contains("level 0"));
    assert!(err(&ok, 65, &mut out).contains("level 65"));
    assert!(err(&ok, 5, &mut out).contains("holds 25 vertices"));
    let mut bad = rows.clone();
    bad[0][7] = 20;
    let p = HostPatches {
        patch_points: &bad,
        ..ok
    };
    assert!(err(&p, 4, &mut out).contains("row 20"));
    // Residuals past the points: rows + residual_rows must stay inside.
    let p = HostPatches {
        residual_rows: 1,
        ..ok
    };
    assert!(err(&p, 4, &mut out).contains("residuals from row 1"));
    let p = HostPatches {
        patch_flags: &[],
        ..ok
    };
    assert!(err(&p, 4, &mut out).contains("0 patch flags"));
    // Nothing was written by the refused calls.
    assert!(out.iter().flatten().all(|&x| x == 0.0));
    evaluate(&ok, 4, true, HostSimd::Auto, &mut out).unwrap();
}

#[test]
fn operation_counts_are_the_kernels_per_sample_edge_and_patch_arithmetic() {
    use gregvox::surface::gregory_host::{operation_counts, OpCounts};
    // Per grid sample (the weights that depend on (u, v) alone are in the level table): four rational
    // points (6 adds, 15 multiplies each, none at the corner sample where its weights vanish: 4 per patch);
    // rows 1 and 2 of the net contracted in u, values and derivatives (6 multiplies, 9 adds each); the
    // v contractions of position and both derivatives (27 multiplies, 27 adds) and the origin (3 adds);
    // the four exact-derivative terms (6 multiplies, 6 adds each); the rescale (6), the cross product
    // (6 multiplies, 3 subtracts), three lengths (3 multiplies, 2 adds, 1 square root each), the test's
    // scale (1 add, 2 multiplies) and the unit normal (3 divides). Per column (L+1 of them): rows 0 and 3
    // contracted in u, values and derivatives (12 multiplies, 9 adds each), and columns 0 and 3 of rows 1
    // and 2 times their two weights (8 points, 3 multiplies each). Per edge sample (4L of them): one row
    // (12 + 9). Per patch: the 60 patch-local coordinates (3 adds each).
    for level in [1u32, 2, 4, 7, 16, 64] {
        let (s, e) = (((level + 1) * (level + 1)) as u64, 4 * level as u64);
        let n = level as u64 + 1;
        let c = operation_counts(level).unwrap();
        assert_eq!(
            c.ops,
            OpCounts {
                add: 124 * s - 4 * 6 + 36 * n + 9 * e + 180,
                mul: 167 * s - 4 * 15 + 72 * n + 12 * e,
                div: 3 * s,
                sqrt: 3 * s,
            },
            "level {level}"
        );
        assert_eq!(c.bytes, 40 * 16 + 84 + 32 * s, "level {level}");
    }
    assert!(operation_counts(0).is_err() && operation_counts(65).is_err());
}
