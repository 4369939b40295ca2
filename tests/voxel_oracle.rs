//! Specification against the generalized-winding-number oracle (tests/oracle/gen_voxel.py, libigl
//! `fast_winding_number` at voxel centres, thresholded at ½; the band mask marks centres within √3/2·pitch of
//! the mesh, where a sampled surface may legitimately fall on either side).
//!
//! The meshes are loaded exactly as `gregvox voxelize` loads them (`load_obj` → `triangles_of` → `clean`),
//! and the fixture's origin and side must equal our grid frame bit for bit, so both sides sample the same
//! centres. Tolerances:
//! - closed and overlapping meshes (spot, cow, teapot): 0 wrong voxels outside the band, IoU ≥ 0.9999, for
//!   the CPU scanline, the GPU peel and the GPU A-buffer (winding rule, one axis: z);
//! - GPU vs CPU, same rule: ≤ max(4, 1e-5·solid) voxels (sub-pixel snapping ties, §3);
//! - parity on the teapot (overlapping shells, 1,182 centres with w = 2 at 128³) must fail;
//! - open meshes (stanford-bunny, suzanne) with the 3-axis 2-of-3 vote: IoU ≥ 0.995.
mod common;

use common::{model, with_gpu};
use gregvox::engine::voxelize::{AbufferVoxelizer, GpuTriangles, PeelVoxelizer};
use gregvox::gpu::Context;
use gregvox::voxel::cpu::{voxelize_cpu, FillRule};
use gregvox::voxel::grid::{Axis, GridFrame, VoxelGrid};
use gregvox::voxel::mesh::TriMesh;
use std::path::PathBuf;

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/voxel")
}

/// Decodes the fixtures' (value, run) byte pairs.
/// One fixture case: the oracle grids and the mesh as the CLI sees it.
struct Case {
    name: String,
    res: u32,
    mesh: TriMesh,
    frame: GridFrame,
    inside: VoxelGrid,
    band: VoxelGrid,
    fractional: u64,
}

fn case(name: &str, res: u32) -> Case {
    let c = &common::oracle_case(&fixtures(), name, res);
    let mesh = gregvox::mesh::load_obj(model(&format!("{name}.obj"))).unwrap();
    let (mesh, _) = gregvox::voxel::mesh::TriMesh::fan(&mesh).clean();
    let frame = GridFrame::from_points(&mesh.positions, res).unwrap();
    let (inside, band) = common::oracle_masks(c, &fixtures(), frame, res);

    Case {
        name: name.into(),
        res,
        mesh,
        frame,
        inside,
        band,
        fractional: c["fractional"].as_u64().unwrap(),
    }
}

/// Comparison of a grid with the oracle.
#[derive(Debug)]
struct Score {
    wrong_outside_band: u64,
    wrong_in_band: u64,
    iou: f64,
}

fn score(grid: &VoxelGrid, c: &Case) -> Score {
    let g = grid.to_axis(Axis::Z);
    let (mut out, mut inb) = (0, 0);
    for ((a, b), m) in g.words.iter().zip(&c.inside.words).zip(&c.band.words) {
        out += ((a ^ b) & !m).count_ones() as u64;
        inb += ((a ^ b) & m).count_ones() as u64;
    }
    Score {
        wrong_outside_band: out,
        wrong_in_band: inb,
        iou: g.iou(&c.inside),
    }
}

/// Runs `f` with a peel and an A-buffer voxelizer and the uploaded mesh.
fn gpu_run<T>(
    ctx: &Context,
    mesh: &TriMesh,
    f: impl FnOnce(&PeelVoxelizer, &AbufferVoxelizer, &GpuTriangles) -> T,
) -> T {
    let peel = PeelVoxelizer::new(ctx, 12).unwrap();
    let abuf = AbufferVoxelizer::new(ctx, 12).unwrap();
    let tris = GpuTriangles::upload(ctx, mesh).unwrap();
    f(&peel, &abuf, &tris)
}

#[test]
fn the_fixtures_classify_the_models() {
    // Closed simple meshes have integer w everywhere; open ones show fractional w (stanford-bunny: 362 at
    // 64³, the figure of the notes §10).
    for (name, res, fractional) in [
        ("spot", 128, 0),
        ("cow", 128, 0),
        ("stanford-bunny", 64, 362),
    ] {
        let c = case(name, res);
        eprintln!(
            "{name} {res}³: {} centres with |w − round(w)| > 0.25",
            c.fractional
        );
        assert_eq!(c.fractional, fractional, "{name}");
    }
}

#[test]
fn closed_and_overlapping_models_match_the_winding_oracle() {
    with_gpu(|ctx| {
        for name in ["spot", "cow", "teapot"] {
            for res in [64, 128] {
                let c = case(name, res);
                let cpu = voxelize_cpu(&c.mesh, &c.frame, Axis::Z, FillRule::Winding);
                let (peel, abuf) = gpu_run(ctx, &c.mesh, |p, a, t| {
                    let g = t.geometry();
                    let peel = p
                        .voxelize(ctx, &g, &c.frame, &[Axis::Z], FillRule::Winding, None)
                        .unwrap()
                        .0;
                    let abuf = a
                        .voxelize(ctx, &g, &c.frame, &[Axis::Z], FillRule::Winding, None)
                        .unwrap()
                        .0;
                    (peel, abuf)
                });
                let solid = cpu.count();
                for (method, g) in [("cpu", &cpu), ("peel", &peel), ("abuffer", &abuf)] {
                    let s = score(g, &c);
                    eprintln!(
                        "{} {}³ {method}: outside band {}, in band {}, IoU {:.6} (oracle {} solid)",
                        c.name,
                        c.res,
                        s.wrong_outside_band,
                        s.wrong_in_band,
                        s.iou,
                        c.inside.count()
                    );
                    assert_eq!(s.wrong_outside_band, 0, "{name} {res} {method}");
                    assert!(s.iou >= 0.9999, "{name} {res} {method}: IoU {}", s.iou);
                }
                let (dp, da) = (peel.count_differences(&cpu), abuf.count_differences(&cpu));
                eprintln!("{name} {res}³: GPU vs CPU: peel {dp}, abuffer {da} of {solid}");
                common::assert_same_up_to_snapping(
                    &peel,
                    &cpu,
                    &c.mesh,
                    &format!("{name} {res}³ peel"),
                );
                common::assert_same_up_to_snapping(
                    &abuf,
                    &cpu,
                    &c.mesh,
                    &format!("{name} {res}³ abuffer"),
                );
            }
        }
    });
}

#[test]
fn parity_measurably_fails_on_the_teapot_overlapping_shells() {
    // Negative control: the oracle has 1,182 centres with w = 2 at 128³ (index.json histogram); parity
    // empties them, winding keeps them. The peel must fail the same way (same rule, same layers).
    let c = case("teapot", 128);
    let cpu = score(
        &voxelize_cpu(&c.mesh, &c.frame, Axis::Z, FillRule::Parity),
        &c,
    );
    let gpu = with_gpu(|ctx| {
        gpu_run(ctx, &c.mesh, |p, _, t| {
            p.voxelize(
                ctx,
                &t.geometry(),
                &c.frame,
                &[Axis::Z],
                FillRule::Parity,
                None,
            )
            .unwrap()
            .0
        })
    });
    let gpu = score(&gpu, &c);
    eprintln!("teapot 128³ parity: CPU {cpu:?}; GPU peel {gpu:?}");
    let wrong = cpu.wrong_outside_band + cpu.wrong_in_band;
    // Parity is wrong on exactly the 1,182 w = 2 centres (measured: 757 outside the band, 425 in it); ±5 %
    // leaves room for tie columns, not for a rule that fails differently.
    assert!((1_120..=1_245).contains(&wrong), "parity wrong {wrong}");
    assert!(
        cpu.wrong_outside_band > 700,
        "the failure is not a band effect"
    );
    assert!(cpu.iou < 0.995);
    assert_eq!(gpu.wrong_outside_band, cpu.wrong_outside_band);
}

#[test]
fn open_models_reach_iou_0_995_with_the_three_axis_vote() {
    with_gpu(|ctx| {
        for name in ["stanford-bunny", "suzanne"] {
            for res in [64, 128] {
                let c = case(name, res);
                let cpu = VoxelGrid::majority(
                    Axis::ALL
                        .map(|a| voxelize_cpu(&c.mesh, &c.frame, a, FillRule::Winding))
                        .each_ref(),
                );
                let (peel, abuf) = gpu_run(ctx, &c.mesh, |p, a, t| {
                    let g = t.geometry();
                    (
                        p.voxelize(ctx, &g, &c.frame, &Axis::ALL, FillRule::Winding, None)
                            .unwrap()
                            .0,
                        a.voxelize(ctx, &g, &c.frame, &Axis::ALL, FillRule::Winding, None)
                            .unwrap()
                            .0,
                    )
                });
                let single = score(
                    &voxelize_cpu(&c.mesh, &c.frame, Axis::Z, FillRule::Winding),
                    &c,
                );
                for (method, g) in [("cpu", &cpu), ("peel", &peel), ("abuffer", &abuf)] {
                    let s = score(g, &c);
                    eprintln!(
                        "{name} {res}³ {method} 3-axis vote: outside band {}, in band {}, IoU {:.5} (z alone: IoU {:.5})",
                        s.wrong_outside_band, s.wrong_in_band, s.iou, single.iou
                    );
                    assert!(s.iou >= 0.995, "{name} {res} {method}: IoU {}", s.iou);
                    // The vote must beat the best-behaved single axis, or it is not doing its job.
                    assert!(
                        s.iou > single.iou,
                        "{name} {res} {method}: {} ≤ z alone",
                        s.iou
                    );
                }
            }
        }
    });
}
