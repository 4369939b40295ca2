//! Specification of the GPU Gregory surface end to end (cage → W·cage → evaluation): control points against
//! OpenSubdiv, the surface against the f64 CPU reference, G1 and corners, and G1 kept through 100 random cage
//! deformations applied on the GPU. Validation on (tests/common).
mod common;
#[path = "surface_common.rs"]
mod surface_common;

use common::with_gpu;
use glam::DVec3;
use gregvox::engine::cage::{cage_topology, max_jump_coincident};
use gregvox::engine::gregory::GregorySurface;
use gregvox::mesh::{load_obj, Mesh};
use gregvox::passes::gregory_eval::{ControlPoints, GregoryEvalPass, SurfaceVertex};
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
            s.read_points(ctx).unwrap()
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
    // Negative control: one patch with its normals flipped must fail (the measure once folded the angle
    // to min(θ, π − θ), which this passed).
    let mut flipped = gpu.clone();
    let per = ((level + 1) * (level + 1)) as usize;
    for v in &mut flipped[7 * per..8 * per] {
        v.normal = [-v.normal[0], -v.normal[1], -v.normal[2], v.normal[3]];
    }
    let flipped_jump = max_jump_coincident(&flipped, level);
    assert!(
        flipped_jump > 3.0,
        "a flipped patch must show as a jump near π, got {flipped_jump}"
    );
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
/// vertex index.
fn edge_samples(e: usize, l: u32) -> Vec<usize> {
    let n = (l + 1) as usize;
    (0..n)
        .map(|k| match e {
            0 => k,
            1 => k * n + n - 1,
            2 => (n - 1) * n + k,
            _ => k * n,
        })
        .collect()
}

/// Largest normal jump (rad) and sample count over every shared edge matched topologically: the two patches'
/// rows of the same edge, samples paired by their bit-identical canonical positions.
fn gpu_g1(
    edges: &gregvox::passes::adaptive_levels::EdgeTopology,
    gpu: &[SurfaceVertex],
    level: u32,
) -> (f64, usize) {
    let per = ((level + 1) * (level + 1)) as usize;
    let (mut worst, mut samples) = (0.0f64, 0usize);
    for (eid, w) in edges.edge_offsets.windows(2).enumerate() {
        let share = &edges.edge_patches[w[0] as usize..w[1] as usize];
        if share.len() != 2 {
            continue;
        }
        let side = |p: usize| {
            let e = (0..4)
                .find(|&e| edges.edge_ids[4 * p + e] as usize == eid)
                .unwrap();
            edge_samples(e, level)
                .into_iter()
                .map(|local| {
                    let g = &gpu[p * per + local];
                    (g.position.map(f32::to_bits), dv(&g.normal))
                })
                .collect::<HashMap<_, _>>()
        };
        let (sa, sb) = (side(share[0] as usize), side(share[1] as usize));
        for (key, na) in &sa {
            let nb = sb
                .get(key)
                .expect("canonical edges: bit-identical positions");
            worst = worst.max(na.angle_between(*nb));
            samples += 1;
        }
    }
    (worst, samples)
}

/// Issue 5's G1 test on the GPU path: every shared edge of spot at 33 samples, before and after 100 random cage
/// deformations of ±1 % of the diagonal, every sample ≤ 1e-3 rad.
///
/// What makes it hold at folds (a ±1 % move folds some faces, so S_u and S_v are nearly parallel there): the
/// control points come from gregory_points.comp as hi + lo, summed relative to a cage vertex of their row,
/// and the evaluation works in patch-local coordinates, so no f32 rounding proportional to the distance from
/// the world origin reaches the derivatives. The control case evaluates the same points without their
/// residuals (f32 world-space points, as before the split): that error is 2⁻²⁴·|P| per point. Measured on
/// these deformations: 2.4e-4 rad with residuals, 6.1e-3 rad without, so the control shows the test can fail.
#[test]
fn gpu_g1_over_100_random_deformations_of_one_percent() {
    let mesh = load_obj(model("spot_quadrangulated.obj")).unwrap();
    let level = 32; // 33 samples per edge, as the issue asks
    let (topo, cage, _) = cage_topology(&mesh, Tangents::OpenSubdiv).unwrap();
    let edges = gregvox::passes::adaptive_levels::EdgeTopology::new(&topo.patch_points);
    let d = diag(&cage);
    let runs: usize = std::env::var("GREGVOX_G1_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100);
    with_gpu(|ctx| {
        let s = GregorySurface::new(ctx, &topo, &cage, level).unwrap();
        let control = GregoryEvalPass::new(ctx).unwrap();
        let plain_out = ctx
            .create_buffer(
                "plain-points vertices",
                s.vertices().size(),
                ash::vk::BufferUsageFlags::STORAGE_BUFFER | ash::vk::BufferUsageFlags::TRANSFER_SRC,
                gregvox::gpu::MemoryLocation::GpuOnly,
            )
            .unwrap();
        let mut rng = Rng(0x51f1_5eed_0000_0001);
        let (mut worst, mut worst_plain, mut samples) = (0.0f64, 0.0f64, 0usize);
        for run in 0..=runs {
            let moved: Vec<DVec3> = if run == 0 {
                cage.clone()
            } else {
                cage.iter().map(|p| *p + rng.ball(0.01 * d)).collect()
            };
            ctx.one_shot(|cmd| {
                s.record_cage_update(ctx, cmd, &moved)?;
                s.record(ctx, cmd, None, None)?;
                control.record(
                    ctx,
                    cmd,
                    ControlPoints::plain(s.points()),
                    s.patch_points(),
                    s.patch_flags(),
                    topo.patch_points.len() as u32,
                    level,
                    true,
                    &plain_out,
                )
            })
            .unwrap();
            let (jump, n) = gpu_g1(&edges, &s.read_vertices(ctx).unwrap(), level);
            let plain: Vec<SurfaceVertex> = ctx.read_pod(&plain_out).unwrap();
            let (jump_plain, _) = gpu_g1(&edges, &plain, level);
            if run == 0 {
                eprintln!("spot L={level}, rest cage: jump {jump:.2e} rad over {n} samples");
            }
            worst = worst.max(jump);
            worst_plain = worst_plain.max(jump_plain);
            samples += n;
        }
        eprintln!(
            "spot L={level}, rest + {runs} deformations ±1 % diag, {samples} samples: max jump {worst:.2e} rad; \
             control without residuals {worst_plain:.2e} rad"
        );
        assert!(worst <= 1e-3, "G1: {worst} rad");
        if runs >= 100 {
            assert!(
                worst_plain > 1e-3,
                "the control (no residuals) should exceed 1e-3 rad on these deformations: {worst_plain}"
            );
        }
    });
}

/// Level 64 on spot is 12.4 M vertices (396 MB), three times what one storage binding holds on lavapipe
/// (128 MiB): the evaluation binds batches of patches at aligned offsets. Every even sample of the level-64
/// grid has the same (u, v) bits as a level-32 sample ((2k)/64 = k/32 exactly), so the two evaluations must
/// agree bit for bit; and the GPU bounds pass, chunked the same way, must equal the CPU bounds.
#[test]
fn level_64_past_one_storage_binding_equals_level_32_at_shared_samples() {
    let mesh = load_obj(model("spot_quadrangulated.obj")).unwrap();
    let (topo, cage, _) = cage_topology(&mesh, Tangents::OpenSubdiv).unwrap();
    let patches = topo.patch_points.len();
    with_gpu(|ctx| {
        let eval = |level: u32| {
            let s = GregorySurface::new(ctx, &topo, &cage, level).unwrap();
            ctx.one_shot(|cmd| s.record(ctx, cmd, None, None)).unwrap();
            (s.read_vertices(ctx).unwrap(), s)
        };
        let (fine, s64) = eval(64);
        let bytes = fine.len() as u64 * 32;
        assert!(
            bytes > 2 * ctx.info.max_storage_buffer_range as u64
                || ctx.info.max_storage_buffer_range > 1 << 30,
            "the case must span several storage bindings on this device"
        );
        // Bounds on the GPU over the whole buffer (chunked binding) vs the CPU.
        let bounds = gregvox::passes::bounds::BoundsPass::new(ctx).unwrap();
        let out = ctx
            .create_buffer(
                "bounds",
                24,
                ash::vk::BufferUsageFlags::STORAGE_BUFFER
                    | ash::vk::BufferUsageFlags::TRANSFER_DST
                    | ash::vk::BufferUsageFlags::TRANSFER_SRC,
                gregvox::gpu::MemoryLocation::GpuOnly,
            )
            .unwrap();
        ctx.one_shot(|cmd| bounds.record(ctx, cmd, s64.vertices(), fine.len() as u32, 32, &out))
            .unwrap();
        let gpu_bounds: Vec<u32> = ctx.read_pod(&out).unwrap();
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for v in &fine {
            assert!(v.position.iter().chain(&v.normal).all(|c| c.is_finite()));
            for a in 0..3 {
                lo[a] = lo[a].min(v.position[a]);
                hi[a] = hi[a].max(v.position[a]);
            }
        }
        for a in 0..3 {
            assert_eq!(gregvox::passes::bounds::decode(gpu_bounds[a]), lo[a]);
            assert_eq!(gregvox::passes::bounds::decode(gpu_bounds[3 + a]), hi[a]);
        }
        // The level-64 buffers go before level 32 is built (peak memory); the level-32 surface right after
        // its vertices are read.
        drop(out);
        drop(bounds);
        drop(s64);
        let (coarse, _) = eval(32);
        let mut differing = 0usize;
        for p in 0..patches {
            for j in 0..33 {
                for i in 0..33 {
                    let a = fine[p * 65 * 65 + 2 * j * 65 + 2 * i];
                    let b = coarse[p * 33 * 33 + j * 33 + i];
                    differing += (a != b) as usize;
                }
            }
        }
        eprintln!(
            "spot L=64: {} vertices ({} MiB) in batches; {differing} of {} shared samples differ from L=32",
            fine.len(),
            bytes >> 20,
            patches * 33 * 33
        );
        assert_eq!(differing, 0);
    });
}
