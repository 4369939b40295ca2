//! Specification of the thesis's flag experiment: patches built on the GPU from the animated curve network equal
//! the f64 reference; with the Chiyokura–Kimura correction every shared edge is G1, without it they are not.
mod common;

use common::with_gpu;
use gregvox::engine::flag::{flag_patches, FlagParams, FlagSurface};
use gregvox::geom::compat::Edge;
use gregvox::geom::gregory::PatchF64;
use gregvox::passes::gregory_eval::SurfaceVertex;

/// Largest normal jump (rad) across the shared edges of a `columns × rows` flag, 33 samples per edge.
fn max_jump(p: &[PatchF64], columns: usize, rows: usize) -> f64 {
    let mut worst = 0.0f64;
    for r in 0..rows {
        for c in 0..columns {
            let a = &p[r * columns + c];
            for k in 0..=32 {
                let t = k as f64 / 32.0;
                if c + 1 < columns {
                    let b = &p[r * columns + c + 1];
                    let (ua, va) = Edge::U1.uv(t);
                    let (ub, vb) = Edge::U0.uv(t);
                    assert!((a.eval(ua, va).0 - b.eval(ub, vb).0).length() < 1e-12);
                    worst = worst.max(angle64(a.normal(ua, va), b.normal(ub, vb)));
                }
                if r + 1 < rows {
                    let b = &p[(r + 1) * columns + c];
                    let (ua, va) = Edge::V1.uv(t);
                    let (ub, vb) = Edge::V0.uv(t);
                    worst = worst.max(angle64(a.normal(ua, va), b.normal(ub, vb)));
                }
            }
        }
    }
    worst
}

#[test]
fn the_correction_makes_every_shared_edge_g1_and_without_it_they_break() {
    for t in [0.0, 0.7, 2.3] {
        let on = flag_patches(&FlagParams {
            t,
            ..Default::default()
        })
        .unwrap();
        let off = flag_patches(&FlagParams {
            t,
            correct: false,
            ..Default::default()
        })
        .unwrap();
        let (j_on, j_off) = (max_jump(&on, 3, 2), max_jump(&off, 3, 2));
        eprintln!(
            "flag 3×2 at t = {t}: normal jump with CK {j_on:.2e} rad, without {j_off:.2e} rad"
        );
        assert!(j_on <= 1e-9, "{j_on}");
        assert!(j_off > 1e-2, "negative control: {j_off}");
    }
}

#[test]
fn gpu_patches_equal_the_reference_and_stay_g1_when_evaluated() {
    let t = 0.7f32;
    let level = 16u32;
    let (points_on, points_off, verts) = with_gpu(|ctx| {
        let flag = FlagSurface::new(ctx, 3, 2, level).unwrap();
        ctx.one_shot(|cmd| flag.record(ctx, cmd, t, 0.35, false, None))
            .unwrap();
        let off = flag.read_points(ctx).unwrap();
        ctx.one_shot(|cmd| flag.record(ctx, cmd, t, 0.35, true, None))
            .unwrap();
        let on = flag.read_points(ctx).unwrap();
        let verts: Vec<SurfaceVertex> = ctx.read_pod(flag.vertices()).unwrap();
        (on, off, verts)
    });
    for (gpu, correct) in [(&points_on, true), (&points_off, false)] {
        let cpu = flag_patches(&FlagParams {
            t: t as f64,
            correct,
            ..Default::default()
        })
        .unwrap();
        let worst = cpu
            .iter()
            .flat_map(|p| p.cv.iter())
            .zip(gpu.iter())
            .map(|(c, g)| {
                ((c.x - g[0] as f64).powi(2)
                    + (c.y - g[1] as f64).powi(2)
                    + (c.z - g[2] as f64).powi(2))
                .sqrt()
            })
            .fold(0.0, f64::max);
        eprintln!("flag points GPU vs f64 (CK {correct}): {worst:.2e}");
        // The flag is 3 units wide: f32 trigonometry and the CK solve keep points within 2e-6 of f64.
        assert!(worst < 2e-5, "{worst}");
    }
    // Normals of coincident vertices on the shared edges of the evaluated surface (f32 G1).
    let n = (level + 1) as usize;
    let vert = |patch: usize, i: usize, j: usize| verts[patch * n * n + j * n + i];
    let mut worst = 0.0f32;
    for r in 0..2 {
        for c in 0..3 {
            let p = r * 3 + c;
            for k in 0..n {
                if c + 1 < 3 {
                    let (a, b) = (vert(p, n - 1, k), vert(p + 1, 0, k));
                    worst = worst.max(angle(a.normal, b.normal));
                }
                if r + 1 < 2 {
                    let (a, b) = (vert(p, k, n - 1), vert(p + 3, k, 0));
                    worst = worst.max(angle(a.normal, b.normal));
                }
            }
        }
    }
    eprintln!("evaluated flag: max normal jump across shared edges {worst:.2e} rad");
    assert!(worst < 1e-3, "{worst}");
}

/// Angle between unit vectors by atan2 (acos loses half the digits near 0: its floor is ~1.5e-8 rad in f64).
fn angle64(a: glam::DVec3, b: glam::DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

fn angle(a: [f32; 4], b: [f32; 4]) -> f32 {
    let d = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0);
    d.acos()
}
