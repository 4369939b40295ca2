//! Specification of the thesis's flag experiment: patches built on the GPU from the animated curve network equal
//! the f64 reference; with the Chiyokura–Kimura correction every shared edge is G1, without it they are not.
mod common;

use common::{flag_max_jump as max_jump, with_gpu};
use gregvox::engine::flag::{flag_patches, FlagParams, FlagSurface};
use gregvox::passes::gregory_eval::SurfaceVertex;

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

fn angle(a: [f32; 4], b: [f32; 4]) -> f32 {
    let d = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0);
    d.acos()
}

/// Seeded corner offsets for a `columns × rows` flag: every corner moved by up to ±0.2 in x and y and
/// ±0.3 in z.
fn moved_corners(columns: usize, rows: usize, seed: u64) -> Vec<glam::DVec3> {
    let mut s = seed;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    (0..(columns + 1) * (rows + 1))
        .map(|_| glam::DVec3::new(0.2 * next(), 0.2 * next(), 0.3 * next()))
        .collect()
}

#[test]
fn moved_corners_keep_every_shared_edge_g1_and_the_gpu_builds_the_reference() {
    use gregvox::engine::flag::{flag_corners, flag_patches_with};
    let (columns, rows) = (3usize, 2usize);
    let offsets = moved_corners(columns, rows, 7);
    let t = 0.7f32;
    let params = |correct| FlagParams {
        t: t as f64,
        correct,
        ..Default::default()
    };
    // The corners moved by their offsets; each patch's corner control points are those corners.
    let rest = flag_corners(&params(true), &[]);
    let moved = flag_corners(&params(true), &offsets);
    let cpu = flag_patches_with(&params(true), &offsets).unwrap();
    for (i, (a, b)) in rest.iter().zip(&moved).enumerate() {
        assert!((*b - *a).length() > 1e-3, "corner {i} did not move");
    }
    assert_eq!(cpu[0].cv[0], moved[0]);
    // Offsets back from the moved corners (what a drag computes) are the offsets.
    let back = gregvox::engine::flag::corner_offsets(&params(true), &moved);
    for (a, b) in back.iter().zip(&offsets) {
        assert!((*a - *b).length() < 1e-12, "{a} against {b}");
    }
    assert_eq!(cpu[columns * rows - 1].cv[10], moved[moved.len() - 1]);
    // G1 with the correction, broken without it, on the moved network.
    let j_on = max_jump(&cpu, columns, rows);
    let j_off = max_jump(
        &flag_patches_with(&params(false), &offsets).unwrap(),
        columns,
        rows,
    );
    assert!(j_on <= 1e-9, "{j_on}");
    assert!(j_off > 1e-2, "negative control: {j_off}");
    // No offsets and zero offsets are the thesis's flag, bit for bit.
    let zeros = vec![glam::DVec3::ZERO; offsets.len()];
    assert_eq!(
        flag_patches_with(&params(true), &zeros).unwrap(),
        flag_patches(&params(true)).unwrap()
    );
    // The GPU with the offsets recorded into its command buffer builds the same points.
    let gpu = with_gpu(|ctx| {
        let flag = FlagSurface::new(ctx, columns as u32, rows as u32, 4).unwrap();
        assert!(ctx
            .one_shot(|cmd| flag.record_offsets(ctx, cmd, &offsets[1..]))
            .is_err());
        ctx.one_shot(|cmd| {
            flag.record_offsets(ctx, cmd, &offsets)?;
            flag.record(ctx, cmd, t, 0.35, true, None)
        })
        .unwrap();
        flag.read_points(ctx).unwrap()
    });
    let worst = cpu
        .iter()
        .flat_map(|p| p.cv.iter())
        .zip(gpu.iter())
        .map(|(c, g)| (*c - glam::DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64)).length())
        .fold(0.0, f64::max);
    assert!(worst < 2e-5, "GPU against f64: {worst}");
}
