//! Specification of the GPU Gregory surface end to end (cage → W·cage → evaluation): control points against
//! OpenSubdiv, the surface against the f64 CPU reference, G1 and corners, and G1 kept through 100 random cage
//! deformations applied on the GPU. Validation on (tests/common).
mod common;
#[path = "surface_common.rs"]
mod surface_common;

use common::with_gpu;
use glam::DVec3;
use gregvox::cli::cage::{cage_topology, max_jump_coincident};
use gregvox::engine::gregory::GregorySurface;
use gregvox::mesh::{load_obj, Mesh};
use gregvox::passes::gregory_eval::SurfaceVertex;
use gregvox::surface::{tessellate, GregoryStencils, Tangents};
use std::collections::HashMap;
use surface_common::{diag, model, read_fixture, Rng};

fn dv(p: &[f32; 4]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

#[test]
fn gpu_control_points_match_opensubdiv_gregory_basis_points() {
    for name in [
        "catmark_cube",
        "catmark_gregory_test0",
        "catmark_gregory_test1",
        "catmark_tent",
        "catmark_torus",
        "spot_quadrangulated",
    ] {
        let fx = read_fixture(name);
        let mesh = Mesh::from_polygons(fx.cage.clone(), &fx.faces).unwrap();
        let (topo, cage, _) = cage_topology(&mesh, Tangents::OpenSubdiv).unwrap();
        let points = with_gpu(|ctx| {
            let s = GregorySurface::new(ctx, &topo, &cage, 4).unwrap();
            ctx.one_shot(|cmd| s.record(ctx, cmd, None, None)).unwrap();
            let p = s.read_points(ctx).unwrap();
            s.destroy(ctx);
            p
        });
        let d = diag(&fx.cage);
        let mut worst = 0.0f64;
        for (pp, osd) in topo.patch_points.iter().zip(&fx.points) {
            for k in 0..20 {
                worst = worst.max((dv(&points[pp[k] as usize]) - osd[k]).length() / d);
            }
        }
        eprintln!("{name}: GPU W·cage vs OpenSubdiv {worst:.2e} × diag");
        // f32 points: the bound 1e-5 × diag (f64 reference: 5e-11).
        assert!(worst <= 1e-5, "{name}: {worst}");
    }
}

fn evaluate(
    mesh: &Mesh,
    level: u32,
    deformations: usize,
    amount: f64,
) -> (Vec<SurfaceVertex>, Vec<f64>, f64) {
    let (topo, cage, _) = cage_topology(mesh, Tangents::OpenSubdiv).unwrap();
    let d = diag(&cage);
    with_gpu(|ctx| {
        let s = GregorySurface::new(ctx, &topo, &cage, level).unwrap();
        ctx.one_shot(|cmd| s.record(ctx, cmd, None, None)).unwrap();
        let first = s.read_vertices(ctx).unwrap();
        let mut jumps = Vec::new();
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for _ in 0..deformations {
            let moved: Vec<DVec3> = cage.iter().map(|p| *p + rng.ball(amount * d)).collect();
            ctx.one_shot(|cmd| {
                s.record_cage_update(ctx, cmd, &moved)?;
                s.record(ctx, cmd, None, None)
            })
            .unwrap();
            jumps.push(max_jump_coincident(&s.read_vertices(ctx).unwrap(), level));
        }
        s.destroy(ctx);
        (first, jumps, d)
    })
}

#[test]
fn the_gpu_surface_equals_the_cpu_reference_and_is_g1_before_and_after_deformation() {
    let mesh = load_obj(model("spot_quadrangulated.obj")).unwrap();
    let level = 8;
    // ±0.1 % of the diagonal per vertex, every sample bounded; the ±1 % case, where folded faces make some
    // f32 normals ill-conditioned, is gpu_g1_over_100_random_deformations_of_one_percent below.
    let (gpu, jumps, d) = evaluate(&mesh, level, 100, 0.001);
    let cs = GregoryStencils::from_mesh(&mesh, Tangents::OpenSubdiv).unwrap();
    let cpu = tessellate(&cs.stencils.patches_f64(&mesh.positions).unwrap(), level);
    assert_eq!(gpu.len(), cpu.positions.len());
    let (mut dp, mut dn) = (0.0f64, 0.0f64);
    for (g, (p, n)) in gpu.iter().zip(cpu.positions.iter().zip(&cpu.normals)) {
        assert!(g.position.iter().chain(&g.normal).all(|c| c.is_finite()));
        dp = dp.max((dv(&g.position) - *p).length() / d);
        dn = dn.max(dv(&g.normal).angle_between(*n));
    }
    let jump0 = max_jump_coincident(&gpu, level);
    let jump_max = jumps.iter().cloned().fold(0.0, f64::max);

    eprintln!(
        "spot L={level}: GPU vs f64 |ΔP| {dp:.2e} × diag, normals {dn:.2e} rad; G1 jump {jump0:.2e} rad, after 100 deformations (±0.1 %) ≤ {jump_max:.2e} rad"
    );
    assert!(dp <= 1e-5, "{dp}");
    assert!(dn <= 1e-3, "{dn}");
    assert!(jump0 <= 1e-3 && jump_max <= 1e-3, "{jump0} {jump_max}");
    assert_eq!(jumps.len(), 100);
}

#[test]
fn corners_are_limit_points_and_shared_edges_are_bit_identical() {
    let mesh = load_obj(model("opensubdiv/catmark_cube.obj")).unwrap();
    let level = 5;
    let (gpu, _, d) = evaluate(&mesh, level, 0, 0.0);
    let cs = GregoryStencils::from_mesh(&mesh, Tangents::OpenSubdiv).unwrap();
    let patches = cs.stencils.patches_f64(&mesh.positions).unwrap();
    let n = (level + 1) as usize;
    let mut worst = 0.0f64;
    for (k, p) in patches.iter().enumerate() {
        for (i, j, c) in [(0, 0, 0), (n - 1, 0, 5), (n - 1, n - 1, 10), (0, n - 1, 15)] {
            worst = worst.max((dv(&gpu[k * n * n + j * n + i].position) - p.cv[c]).length() / d);
        }
    }
    assert!(worst <= 1e-6, "corner vs limit point: {worst}");
    // Canonical edges: every boundary vertex has an exact (bitwise) twin in another patch on a closed cage.
    let per = n * n;
    let mut keys = std::collections::HashMap::new();
    for (k, v) in gpu.iter().enumerate() {
        let l = k % per;
        if l % n == 0 || l / n == 0 || l % n == n - 1 || l / n == n - 1 {
            *keys.entry(v.position.map(f32::to_bits)).or_insert(0) += 1;
        }
    }
    assert!(
        keys.values().all(|&c| c >= 2),
        "a boundary vertex without a bit-identical twin: a crack"
    );
}

/// Boundary rows of a patch grid at level `l` in parameter order (e0 v=0, e1 u=1, e2 v=1, e3 u=0): local
/// vertex index and (u, v).
fn edge_samples(e: usize, l: u32) -> Vec<(usize, f64, f64)> {
    let n = (l + 1) as usize;
    (0..n)
        .map(|k| {
            let t = k as f64 / l as f64;
            match e {
                0 => (k, t, 0.0),
                1 => (k * n + n - 1, 1.0, t),
                2 => ((n - 1) * n + k, t, 1.0),
                _ => (k * n, 0.0, t),
            }
        })
        .collect()
}

/// G1 figures of one GPU evaluation, over every shared edge matched topologically (the two patches' rows of
/// the same edge, samples paired by their bit-identical canonical positions).
#[derive(Default)]
struct GpuG1 {
    /// Largest normal jump (rad) over all samples.
    jump: f64,
    /// Largest jump over the samples with κ < KAPPA.
    jump_conditioned: f64,
    /// Samples with a jump above 1e-3 rad (all must have κ ≥ KAPPA).
    over: usize,
    samples: usize,
    /// Largest jump / (2⁻²⁴·κ) over the samples with a jump above 1e-4 rad: the f32 error model's constant.
    model: f64,
}

/// The condition number of a sample's normal under f32 rounding of the control points (δ ≈ 2⁻²⁴·|P|):
/// κ = (|S_u| + |S_v|)·max|P| / |S_u × S_v| (f64, both patches; max|P| over their control points). A
/// point error δ moves S_u, S_v by ≈ 6δ, and the normal by ≈ 6δ·(|S_u| + |S_v|)/|S_u × S_v|.
fn kappa(p: &gregvox::geom::gregory::PatchF64, u: f64, v: f64) -> f64 {
    let (_, su, sv) = p.eval(u, v);
    let r = p.cv.iter().map(|c| c.length()).fold(0.0, f64::max);
    (su.length() + sv.length()) * r / su.cross(sv).length()
}

/// Above this κ the f32 model (jump ≈ c·2⁻²⁴·κ with c ≤ MODEL_C) allows more than 1e-3 rad. MODEL_C: the
/// largest c seen over 100 deformations of spot was 15.2; 32 leaves room for other rounding.
const MODEL_C: f64 = 32.0;
const KAPPA: f64 = 1e-3 / (MODEL_C * 5.960_464_477_539_063e-8);

fn gpu_g1(
    edges: &gregvox::passes::adaptive_levels::EdgeTopology,
    patches: &[gregvox::geom::gregory::PatchF64],
    gpu: &[SurfaceVertex],
    level: u32,
) -> GpuG1 {
    let per = ((level + 1) * (level + 1)) as usize;
    let mut r = GpuG1::default();
    for (eid, w) in edges.edge_offsets.windows(2).enumerate() {
        let share = &edges.edge_patches[w[0] as usize..w[1] as usize];
        if share.len() != 2 {
            continue;
        }
        let (a, b) = (share[0] as usize, share[1] as usize);
        let side = |p: usize| {
            let e = (0..4)
                .find(|&e| edges.edge_ids[4 * p + e] as usize == eid)
                .unwrap();
            let mut m = HashMap::new();
            for (local, u, v) in edge_samples(e, level) {
                let g = &gpu[p * per + local];
                m.insert(g.position.map(f32::to_bits), (dv(&g.normal), u, v));
            }
            m
        };
        let (sa, sb) = (side(a), side(b));
        for (key, &(na, ua, va)) in &sa {
            let &(nb, ub, vb) = sb
                .get(key)
                .expect("canonical edges: bit-identical positions");
            let jump = na.angle_between(nb);
            r.samples += 1;
            r.jump = r.jump.max(jump);
            if jump <= 1e-4 {
                r.jump_conditioned = r.jump_conditioned.max(jump);
                continue;
            }
            let k = kappa(&patches[a], ua, va).max(kappa(&patches[b], ub, vb));
            r.model = r.model.max(jump / (5.960_464_477_539_063e-8 * k));
            if k < KAPPA {
                r.jump_conditioned = r.jump_conditioned.max(jump);
            }
            if jump > 1e-3 {
                r.over += 1;
                assert!(
                    k >= KAPPA,
                    "a {jump:.2e} rad jump at a well-conditioned sample (κ {k:.0}): patches {a}, {b}"
                );
            }
        }
    }
    r
}

/// Issue 5's G1 test on the GPU path: every shared edge of spot at 33 samples, before and after 100 random cage
/// deformations of ±1 % of the diagonal. Finding: the evaluation itself equals f64 evaluation of the same f32
/// control points (GREGVOX_G1_PROBE=1 prints both); what remains is the f32 rounding of the control points
/// (δ ≈ 2⁻²⁴·|P|), which the random ±1 % moves amplify where a folded face makes |S_u × S_v| tiny against
/// |S_u|, |S_v| and |P|. So the test asserts 1e-3 rad at every sample whose normal is f32-conditioned
/// (κ < KAPPA, from the error model whose constant MODEL_C is checked on the data) and counts the rest.
#[test]
fn gpu_g1_over_100_random_deformations_of_one_percent() {
    let mesh = load_obj(model("spot_quadrangulated.obj")).unwrap();
    let level = 32; // 33 samples per edge, as the issue asks
    let (topo, cage, _) = cage_topology(&mesh, Tangents::OpenSubdiv).unwrap();
    let edges = gregvox::passes::adaptive_levels::EdgeTopology::new(&topo.patch_points);
    let cs = GregoryStencils::from_mesh(&mesh, Tangents::OpenSubdiv).unwrap();
    let d = diag(&cage);
    let runs: usize = std::env::var("GREGVOX_G1_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100);
    with_gpu(|ctx| {
        let s = GregorySurface::new(ctx, &topo, &cage, level).unwrap();
        let mut rng = Rng(0x51f1_5eed_0000_0001);
        let mut all = GpuG1::default();
        for run in 0..=runs {
            let moved: Vec<DVec3> = if run == 0 {
                cage.clone()
            } else {
                cage.iter().map(|p| *p + rng.ball(0.01 * d)).collect()
            };
            // The f64 reference of the cage the GPU sees (f32-rounded).
            let seen: Vec<DVec3> = moved.iter().map(|p| p.as_vec3().as_dvec3()).collect();
            ctx.one_shot(|cmd| {
                s.record_cage_update(ctx, cmd, &moved)?;
                s.record(ctx, cmd, None, None)
            })
            .unwrap();
            let gpu = s.read_vertices(ctx).unwrap();
            let patches = cs.stencils.patches_f64(&seen).unwrap();
            let g = gpu_g1(&edges, &patches, &gpu, level);
            if std::env::var("GREGVOX_G1_PROBE").is_ok() {
                // f64 evaluation of the GPU's f32 control points at the same samples.
                let pts = s.read_points(ctx).unwrap();
                let n = (level + 1) as usize;
                let mut f64_of_f32 = gpu.clone();
                for (k, rows) in topo.patch_points.iter().enumerate() {
                    let p = gregvox::geom::gregory::PatchF64 {
                        cv: std::array::from_fn(|c| dv(&pts[rows[c] as usize])),
                    };
                    for l in 0..n * n {
                        let (u, v) = ((l % n) as f64 / level as f64, (l / n) as f64 / level as f64);
                        let nn = p.normal(u, v);
                        f64_of_f32[k * n * n + l].normal =
                            [nn.x as f32, nn.y as f32, nn.z as f32, 0.0];
                    }
                }
                let h = gpu_g1(&edges, &patches, &f64_of_f32, level);
                eprintln!(
                    "run {run}: GPU jump {:.2e}; f64 evaluation of the GPU's f32 control points {:.2e}",
                    g.jump, h.jump
                );
            }
            if run == 0 {
                eprintln!(
                    "spot L={level}, rest cage: jump {:.2e} rad over {} samples",
                    g.jump, g.samples
                );
                assert!(g.jump <= 1e-3, "rest cage: {}", g.jump);
            }
            all.jump = all.jump.max(g.jump);
            all.jump_conditioned = all.jump_conditioned.max(g.jump_conditioned);
            all.over += g.over;
            all.samples += g.samples;
            all.model = all.model.max(g.model);
        }
        eprintln!(
            "spot L={level}, {runs} deformations ±1 % diag, {} samples: max jump {:.2e} rad; over samples with \
             κ < {KAPPA:.0}: {:.2e} rad; {} samples above 1e-3 rad (all with κ ≥ {KAPPA:.0}); largest \
             jump / (2⁻²⁴·κ) = {:.2}",
            all.samples, all.jump, all.jump_conditioned, all.over, all.model
        );
        assert!(all.jump_conditioned <= 1e-3);
        // The error model holds on the data (else KAPPA could exclude samples the model cannot explain).
        assert!(all.model <= MODEL_C, "{}", all.model);
        // The exclusion stays rare: at most one sample in 10⁴.
        assert!(
            all.over * 10_000 <= all.samples,
            "{} of {}",
            all.over,
            all.samples
        );
        s.destroy(ctx);
    });
}
