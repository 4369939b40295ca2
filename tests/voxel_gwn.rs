//! Specification of `--rule gwn`, the exact generalized winding number (src/voxel/gwn.rs), against libigl's
//! exact `winding_number` at the voxel centres (tests/oracle/gen_gwn.py; fixtures in tests/fixtures/gwn/):
//! an open tube, a hemisphere shell, the bunny (five holes), a sphere with a quarter of its triangles
//! removed at random, a cup as an unwelded soup, two overlapping open shells and a closed sphere.
//!
//! Done means, on every case at 64³ and 128³: no voxel differs from the exact winding number (on the surface
//! or off it); both device methods give the CPU's grid; closed meshes give the winding rule's grid bit for
//! bit, and `gwn-positive` the positive rule's (an inverted closed part empty, the device's facing included);
//! a mesh whose fractional term needs more than the memory budget is refused with a clear error, and a time
//! limit stops the stages inside their loops. The negative control: the 3-axis vote, the former answer for
//! open meshes, fails the same bar on the tube.
mod common;

use common::{model, validated_gpu};
use gregvox::api::{
    load_mesh, voxelize_on_cpu, Axes, Axis, FillRule, Mesh, Method, VoxelGrid, VoxelizeOptions,
};
use std::path::PathBuf;

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/gwn")
}

struct Case {
    name: String,
    res: u32,
    mesh: Mesh,
    inside: VoxelGrid,
    band: VoxelGrid,
}

const CASES: [&str; 7] = [
    "tube",
    "hemisphere",
    "stanford-bunny",
    "sphere_quarter_removed",
    "cup_soup",
    "two_shells",
    "closed_sphere",
];

fn case(name: &str, res: u32) -> Case {
    let c = &common::oracle_case(&fixtures(), name, res);
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(c["obj"].as_str().unwrap());
    let mesh = load_mesh(&path).unwrap();
    let frame = gregvox::api::grid_frame(&mesh, &VoxelizeOptions::default().res(res)).unwrap();
    let (inside, band) = common::oracle_masks(c, &fixtures(), frame, res);

    Case {
        name: name.into(),
        res,
        mesh,
        inside,
        band,
    }
}

/// (wrong voxels farther than one voxel from the surface, wrong voxels within it, IoU).
fn score(grid: &VoxelGrid, c: &Case) -> (u64, u64, f64) {
    let g = grid.to_axis(Axis::Z);
    let (mut out, mut inb) = (0, 0);
    for ((a, b), m) in g.words.iter().zip(&c.inside.words).zip(&c.band.words) {
        out += ((a ^ b) & !m).count_ones() as u64;
        inb += ((a ^ b) & m).count_ones() as u64;
    }
    (out, inb, g.iou(&c.inside))
}

fn gwn(res: u32) -> VoxelizeOptions {
    VoxelizeOptions::default().res(res).rule(FillRule::Gwn)
}

#[test]
fn gwn_is_the_exact_winding_number_on_every_case() {
    for name in CASES {
        for res in [64, 128] {
            let c = case(name, res);
            let v = voxelize_on_cpu(&c.mesh, &gwn(res)).unwrap();
            let (out, inb, iou) = score(&v.grid, &c);
            let s = v.report.gwn;
            eprintln!(
                "{} {}³: {out} wrong off the band, {inb} in it, IoU {iou:.6}; {s:?}",
                c.name, c.res
            );
            assert_eq!(
                (out, inb),
                (0, 0),
                "{} {}³: wrong voxels (off the surface, near it)",
                c.name,
                c.res
            );
            assert!(iou >= 0.999, "{} {}³: IoU {iou}", c.name, c.res);
            assert_eq!(v.report.rule, FillRule::Gwn);
            if name == "closed_sphere" {
                assert!(s.is_none(), "a closed mesh needs no cap: {s:?}");
            } else {
                let s = s.expect("an open mesh is capped");
                assert!(
                    s.loops_capped >= 1 && s.boxes_evaluated > 0,
                    "{name}: {s:?}"
                );
            }
        }
    }
}

#[test]
fn the_three_axis_vote_fails_the_tube_where_gwn_passes() {
    // The negative control: the bar above can fail, and fails the former answer for open meshes.
    let c = case("tube", 64);
    let vote = voxelize_on_cpu(
        &c.mesh,
        &VoxelizeOptions::default()
            .res(64)
            .rule(FillRule::Winding)
            .axes(Axes::Three),
    )
    .unwrap();
    let (out, _, iou) = score(&vote.grid, &c);
    assert!(out > 1000 && iou < 0.99, "vote: {out} wrong, IoU {iou}");
    // And gwn under --axes 3 is that vote, said in a note.
    let v = voxelize_on_cpu(&c.mesh, &gwn(64).axes(Axes::Three)).unwrap();
    assert_eq!(v.grid.count_differences(&vote.grid), 0);
    assert_eq!(v.report.rule, FillRule::Winding);
    assert!(v.report.notes.iter().any(|n| n.contains("2-of-3 vote")));
}

#[test]
fn both_device_methods_give_the_cpus_grid() {
    let gpu = validated_gpu();
    for name in CASES {
        let res = 64;
        let c = case(name, res);
        let cpu = voxelize_on_cpu(&c.mesh, &gwn(res).axes(Axes::One(Axis::Z))).unwrap();
        for method in [Method::Peel, Method::Abuffer] {
            let g = gpu
                .voxelize(&c.mesh, &gwn(res).method(method).axes(Axes::One(Axis::Z)))
                .unwrap();
            // Identical on lavapipe; on other devices a closed mesh keeps the rasterizer's snapping ties
            // (open ones are decided exactly near the surface, so their grids are identical everywhere).
            common::assert_same_up_to_snapping(
                &g.grid,
                &cpu.grid,
                &gregvox::voxel::mesh::TriMesh::fan(&c.mesh),
                &format!("{name} {res}³ {method:?}"),
            );
        }
    }
    gpu.finish().unwrap();
}

#[test]
fn closed_meshes_give_the_winding_rule_bit_for_bit() {
    let closed: Vec<Mesh> = vec![
        load_mesh(fixtures().join("closed_sphere.obj")).unwrap(),
        load_mesh(model("spot.obj")).unwrap(),
        load_mesh(model("cow.obj")).unwrap(),
    ];
    let gpu = validated_gpu();
    for m in &closed {
        for res in [64, 128] {
            let w = voxelize_on_cpu(m, &gwn(res).rule(FillRule::Winding)).unwrap();
            let g = voxelize_on_cpu(m, &gwn(res)).unwrap();
            assert_eq!(g.grid.count_differences(&w.grid), 0);
            assert!(g.report.gwn.is_none());
            // On the GPU: gwn and winding by the same method are the same grid (GPU and CPU may break
            // sub-pixel ties differently, tests/voxel_oracle.rs).
            let peel = |rule| {
                gpu.voxelize(
                    m,
                    &gwn(res)
                        .rule(rule)
                        .method(Method::Peel)
                        .axes(Axes::One(Axis::Z)),
                )
                .unwrap()
            };
            let (gg, gw) = (peel(FillRule::Gwn), peel(FillRule::Winding));
            assert_eq!(gg.grid.count_differences(&gw.grid), 0);
            assert!(gg.report.gwn.is_none());
        }
    }
    gpu.finish().unwrap();
}

#[test]
fn soups_are_welded_before_capping_and_holes_are_counted() {
    let loops = |name: &str| {
        let c = case(name, 64);
        voxelize_on_cpu(&c.mesh, &gwn(64))
            .unwrap()
            .report
            .gwn
            .unwrap()
    };
    // The cup is a soup (every triangle its own vertices): welded, its only boundary is the rim.
    let cup = loops("cup_soup");
    assert_eq!((cup.loops_capped, cup.boundary_edges), (1, 48), "{cup:?}");
    let tube = loops("tube");
    assert_eq!(
        (tube.loops_capped, tube.boundary_edges),
        (2, 128),
        "{tube:?}"
    );
    let bunny = loops("stanford-bunny");
    assert_eq!(bunny.loops_capped, 5, "{bunny:?}");
    assert!(loops("sphere_quarter_removed").loops_capped > 50);
}

#[test]
fn voxel_centres_on_a_cap_plane_are_evaluated_directly() {
    // The hemisphere's cap is its equator disk (z = 0); 65 voxels over z ∈ [−1, 1] put centre plane 32 on
    // it (within rounding), where the rasterized cap and the analytic cap term could disagree.
    let m = load_mesh(fixtures().join("hemisphere.obj")).unwrap();
    let opts = VoxelizeOptions::default()
        .dims([33, 33, 65])
        .bbox([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])
        .rule(FillRule::Gwn);
    let v = voxelize_on_cpu(&m, &opts).unwrap();
    let s = v.report.gwn.unwrap();
    assert!(s.direct_voxels >= 33 * 33 / 2, "{s:?}");
    // Against the plain f64 sum at every centre whose winding number is clearly decided (|w − ½| > 0.02:
    // off the surface; on the cap plane inside the rim w is ½ ± the rim's pull, decided by the sum).
    let tri = gregvox::voxel::mesh::TriMesh::fan(&m);
    let f = v.grid.frame;
    let (mut checked, mut on_plane) = (0, 0);
    for k in 0..65 {
        for j in 0..33 {
            for i in 0..33 {
                let w = gregvox::voxel::gwn::winding_number(&tri, f.centre(i, j, k));
                if (w.abs() - 0.5).abs() > 0.02 {
                    checked += 1;
                    on_plane += (k == 32) as u32;
                    assert_eq!(v.grid.get(i, j, k), w.abs() >= 0.5, "({i},{j},{k}) w = {w}");
                }
            }
        }
    }
    assert!(checked > 60_000 && on_plane > 100, "{checked} {on_plane}");
    let gpu = validated_gpu();
    let g = gpu
        .voxelize(&m, &opts.clone().method(Method::Peel))
        .unwrap();
    assert_eq!(g.grid.count_differences(&v.grid), 0);
    assert_eq!(g.report.gwn, v.report.gwn);
    gpu.finish().unwrap();
}

/// A stress generator's triangles as an API mesh.
fn mesh_of(t: &gregvox::voxel::mesh::TriMesh) -> Mesh {
    let positions = t
        .positions
        .iter()
        .map(|p| p.map(f64::from).into())
        .collect();
    let faces: Vec<Vec<u32>> = t.triangles.iter().map(|f| f.to_vec()).collect();
    Mesh::from_polygons(positions, &faces).unwrap()
}

#[test]
fn a_tube_open_on_two_loops_of_a_hundred_thousand_edges_is_the_exact_winding_number() {
    // The cost model's attack on the caps: each end is one polygon of 10⁵ sides (capped hierarchically), and
    // w is ½ on both end discs, so the voxels near them are decided one by one. Checked against the plain
    // f64 sum at every voxel of the planes next to the ends and along the axis, and on a grid of others.
    const SEGMENTS: usize = 100_000;
    let tube = gregvox::voxel::stress::open_tube(SEGMENTS);
    let m = mesh_of(&tube);
    let opts = VoxelizeOptions::default().res(24).rule(FillRule::Gwn);
    let v = voxelize_on_cpu(&m, &opts).unwrap();
    let s = v.report.gwn.unwrap();
    // Rim vertices 3e-5 apart lie within the weld's reach (a 512th of a voxel, 8e-5 here): a few are
    // joined, their ribbons keep w exact, and the two loops stay two loops of nearly all their edges.
    assert!(
        s.loops_capped == 2 && s.boundary_edges > 2 * SEGMENTS - 100,
        "{s:?}"
    );
    let f = v.grid.frame;
    let d = f.dims;
    let mut checked = 0;
    for k in 0..d[2] {
        for j in 0..d[1] {
            for i in 0..d[0] {
                let near_end = k < 2 || k + 2 >= d[2];
                let axis = i == d[0] / 2 && j == d[1] / 2;
                if !(near_end || axis || (i % 5 == 0 && j % 5 == 0 && k % 5 == 0)) {
                    continue;
                }
                let w = gregvox::voxel::gwn::winding_number(&tube, f.centre(i, j, k));
                assert_eq!(v.grid.get(i, j, k), w.abs() >= 0.5, "({i},{j},{k}) w = {w}");
                checked += 1;
            }
        }
    }
    assert!(checked > 4 * d[0] * d[1], "{checked}");
    // Inside the tube's middle, solid; outside, empty: the decision is not vacuous.
    assert!(v.grid.get(d[0] / 2, d[1] / 2, d[2] / 2));
    assert!(!v.grid.get(0, 0, d[2] / 2));
}

#[test]
fn an_open_tube_of_long_slivers_as_a_noisy_soup_is_the_exact_winding_number_near_its_end_discs() {
    // A CAD export's soup: every sliver its own three vertices, moved by ±1e-7. The weld joins them and
    // every ribbon is as long as the tube, so near the end discs (w = ½) the ribbons' bounds add up to
    // more than the voxels' margins and the voxels are decided by opening them (the worst case the
    // `voxel::gwn` cost model names). Checked against the plain f64 sum of the soup itself.
    let tube = gregvox::voxel::stress::open_tube(1000);
    let soup = gregvox::voxel::stress::soup(&tube, 1e-7, 5);
    let m = mesh_of(&soup);
    let v = voxelize_on_cpu(&m, &VoxelizeOptions::default().res(32).rule(FillRule::Gwn)).unwrap();
    let s = v.report.gwn.unwrap();
    assert!(
        s.welded_vertices > 1000 && s.ribbon_triangles > 1000 && s.loops_capped == 2,
        "{s:?}"
    );
    let f = v.grid.frame;
    let d = f.dims;
    let (mut checked, mut solid) = (0, 0);
    for k in 0..d[2] {
        for j in 0..d[1] {
            for i in 0..d[0] {
                let near_end = k < 3 || k + 3 >= d[2];
                if !(near_end || (i % 4 == 0 && j % 4 == 0 && k % 4 == 0)) {
                    continue;
                }
                let w = gregvox::voxel::gwn::winding_number(&soup, f.centre(i, j, k));
                assert_eq!(v.grid.get(i, j, k), w.abs() >= 0.5, "({i},{j},{k}) w = {w}");
                checked += 1;
                solid += usize::from(w.abs() >= 0.5);
            }
        }
    }
    assert!(
        checked > 6 * d[0] * d[1] && solid > 500,
        "{checked} checked, {solid} solid"
    );
}

#[test]
fn caps_past_the_memory_budget_are_refused_with_a_clear_error() {
    let c = case("tube", 64);
    let small = gwn(64).gwn_budget(4096);
    let e = voxelize_on_cpu(&c.mesh, &small).unwrap_err();
    assert!(matches!(e, gregvox::Error::Budget { .. }), "{e}");
    assert!(
        e.to_string().contains("budget") && e.to_string().contains("tree"),
        "{e}"
    );
    // Budgets from 4 KiB up: the trees and index first, then the voxels near the surface or those resolved
    // one by one run out; every refusal names the budget, and a big enough one succeeds. The smallest budget
    // that holds the trees (found by bisection) is refused for its voxel lists.
    let run = |budget: u64| {
        voxelize_on_cpu(&c.mesh, &gwn(64).gwn_budget(budget)).map_err(|e| e.to_string())
    };
    assert!(run(1 << 30).is_ok(), "1 GiB was not enough");
    let (mut lo, mut hi) = (4096u64, 1u64 << 30);
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        match run(mid) {
            Err(e) if e.contains("tree") => lo = mid,
            Err(e) => {
                assert!(e.contains("budget"), "{mid}: {e}");
                hi = mid
            }
            Ok(_) => hi = mid,
        }
    }
    let e = run(hi).expect_err("the trees fit exactly, the voxel lists cannot");
    assert!(e.contains("budget") && e.contains("voxels"), "{hi}: {e}");
    let gpu = validated_gpu();
    let e = gpu
        .voxelize(&c.mesh, &small.clone().method(Method::Peel))
        .unwrap_err()
        .to_string();
    assert!(e.contains("budget"), "{e}");
    gpu.finish().unwrap();
}

/// An inward-facing cube (every triangle reversed) inside an outward one, as one mesh.
fn nested_cubes() -> Mesh {
    use glam::DVec3;
    let corners = |lo: f64, s: f64| -> Vec<DVec3> {
        (0..8)
            .map(|i| {
                DVec3::new(
                    lo + s * (i & 1) as f64,
                    lo + s * (i >> 1 & 1) as f64,
                    lo + s * (i >> 2) as f64,
                )
            })
            .collect()
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let mut positions = corners(0.0, 1.0);
    positions.extend(corners(0.3, 0.4));
    let mut faces: Vec<Vec<u32>> = quads.iter().map(|q| q.to_vec()).collect();
    faces.extend(
        quads
            .iter()
            .map(|q| q.iter().rev().map(|&v| v + 8).collect()),
    );
    // A second, separate inverted cube: w = −1 inside it.
    positions.extend(corners(1.5, 0.5));
    faces.extend(
        quads
            .iter()
            .map(|q| q.iter().rev().map(|&v| v + 16).collect()),
    );
    Mesh::from_polygons(positions, &faces).unwrap()
}

#[test]
fn gwn_positive_empties_inverted_parts_where_gwn_fills_them_on_every_method() {
    // Closed: w = 1 in the shell between the nested cubes, 0 in their hollow, −1 in the separate inverted
    // cube. The magnitude rule is the winding rule (the inverted cube solid), the positive rule keeps w ≥ 1.
    let m = nested_cubes();
    let opts = |rule| VoxelizeOptions::default().res(40).rule(rule);
    let mag = voxelize_on_cpu(&m, &opts(FillRule::Gwn)).unwrap();
    let pos = voxelize_on_cpu(&m, &opts(FillRule::GwnPositive)).unwrap();
    let winding = voxelize_on_cpu(&m, &opts(FillRule::Winding)).unwrap();
    let positive = voxelize_on_cpu(&m, &opts(FillRule::Positive)).unwrap();
    assert_eq!(mag.grid.count_differences(&winding.grid), 0);
    assert_eq!(pos.grid.count_differences(&positive.grid), 0);
    assert!(mag.report.gwn.is_none() && pos.report.gwn.is_none());
    let f = mag.grid.frame;
    let at = |g: &VoxelGrid, p: [f64; 3]| {
        let ijk: [u32; 3] =
            std::array::from_fn(|a| ((p[a] - f.origin[a]) / f.voxel_size[a]) as u32);
        g.get(ijk[0], ijk[1], ijk[2])
    };
    // The shell between the nested cubes, their hollow, and the separate inverted cube.
    for (p, m_want, p_want) in [
        ([0.1, 0.1, 0.1], true, true),
        ([0.5, 0.5, 0.5], false, false),
        ([1.75, 1.75, 1.75], true, false),
    ] {
        assert_eq!(
            (at(&mag.grid, p), at(&pos.grid, p)),
            (m_want, p_want),
            "{p:?}"
        );
    }
    // The device methods' facing agrees (the positive rule sees the sign of the winding).
    let gpu = validated_gpu();
    for method in [Method::Peel, Method::Abuffer] {
        for (rule, want) in [(FillRule::Gwn, &mag), (FillRule::GwnPositive, &pos)] {
            let g = gpu
                .voxelize(&m, &opts(rule).method(method).axes(Axes::One(Axis::Z)))
                .unwrap();
            assert_eq!(
                g.grid
                    .to_axis(Axis::Z)
                    .count_differences(&want.grid.to_axis(Axis::Z)),
                0,
                "{method:?} {rule:?}"
            );
        }
    }
    gpu.finish().unwrap();
    // Open: on the tube the two rules agree (w ≥ 0 everywhere there).
    let c = case("tube", 64);
    let a = voxelize_on_cpu(&c.mesh, &gwn(64)).unwrap();
    let b = voxelize_on_cpu(&c.mesh, &gwn(64).rule(FillRule::GwnPositive)).unwrap();
    assert_eq!(a.grid.count_differences(&b.grid), 0);
}

#[test]
fn a_time_limit_stops_the_fractional_term_inside_its_stages() {
    use gregvox::voxel::gwn::{resolve, GwnParams, Inside, Proxy};
    use gregvox::voxel::mesh::TriMesh;
    let c = case("sphere_quarter_removed", 64);
    let tri = TriMesh::fan(&c.mesh).clean().0;
    let frame = gregvox::api::grid_frame(&c.mesh, &gwn(64)).unwrap();
    let proxy = Proxy::new(&tri, 0.0).unwrap();
    let closed = proxy.closed(&tri);
    let mut grid = gregvox::voxel::cpu::voxelize_cpu(&closed, &frame, Axis::Z, FillRule::Winding);
    let params = GwnParams {
        inside: Inside::Magnitude,
        near: gregvox::voxel::gwn::near_distance(&frame, 8),
        budget: 1 << 30,
        deadline: Some((std::time::Instant::now(), 0.25)),
    };
    let e = resolve(&mut grid, &tri, &closed, &proxy, &params).unwrap_err();
    let msg = e.to_string();
    assert!(
        matches!(e, gregvox::Error::Timeout { .. })
            && msg.contains("0.25 s")
            && msg.contains("surface"),
        "{msg}"
    );
    // And through the API: past the limit, a timeout and nothing else.
    let e = voxelize_on_cpu(&c.mesh, &gwn(64).time_limit(0.0)).unwrap_err();
    assert!(matches!(e, gregvox::Error::Timeout { .. }), "{e}");
}
