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
    // ±0.1 % of the diagonal per vertex: at ±1 % (the notes' figure) spot's small faces fold, and f32 normals
    // at the resulting near-singular points (S_u ∥ S_v) differ by up to 0.4 rad between patches although the
    // f64 surface stays G1 to 3e-12 rad (surface_g1.rs checks the ±1 % case in f64).
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
