//! Distance queries with the nearest triangles searched on the device (`MeshQuery::unsigned_distance_on`,
//! `signed_distance_on`, `gregvox query --device`): the same rows as the CPU's, bit for bit, on closed,
//! holed, unwelded and sliver meshes; on lavapipe (IEEE f64) the device's own answers need no correction.
mod common;

use common::{dataset_points, model};
use gregvox::api::query::{DeviceCheck, Distances, MeshQuery, QueryOptions};
use gregvox::api::Mesh;
use gregvox::mesh::load_mesh_file;
use gregvox::voxel::mesh::TriMesh;
use gregvox::voxel::stress::{obj_text, polygon_prism, soup, with_holes};

fn mesh_of(t: &TriMesh) -> Mesh {
    gregvox::mesh::parse_obj(&obj_text(t), "case.obj").unwrap()
}

/// `n` points uniform in the padded box and `n` near the surface (`common::dataset_points`), then the
/// corners of the first triangles exactly (ties between neighbours).
fn points(t: &TriMesh, n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut out = dataset_points(t, n, seed);
    for tri in t.triangles.iter().take(n / 10) {
        out.push(t.positions[tri[0] as usize].map(f64::from));
    }
    out
}

fn same_rows(name: &str, cpu: &Distances, dev: &Distances) {
    assert_eq!(cpu.distance.len(), dev.distance.len(), "{name}");
    for i in 0..cpu.distance.len() {
        assert_eq!(
            (
                cpu.distance[i].to_bits(),
                cpu.face[i],
                cpu.closest[i],
                cpu.barycentric[i]
            ),
            (
                dev.distance[i].to_bits(),
                dev.face[i],
                dev.closest[i],
                dev.barycentric[i]
            ),
            "{name} point {i}"
        );
    }
}

fn check_case(gpu: &gregvox::api::Gpu, name: &str, t: &TriMesh, n: usize) {
    let q = MeshQuery::new(&mesh_of(t), &QueryOptions::default()).unwrap();
    let pts = points(t, n, 11);
    for signed in [false, true] {
        let cpu = if signed {
            q.signed_distance(&pts).unwrap()
        } else {
            q.unsigned_distance(&pts).unwrap()
        };
        for verify in [false, true] {
            let (dev, check) = q.distances_on(gpu, &pts, signed, verify).unwrap();
            same_rows(name, &cpu, &dev);
            // Every search completes within its node limit (the fan included), and the device's pieces
            // are the CPU's: the host's check of every one corrects none.
            assert_eq!(
                check,
                DeviceCheck {
                    incomplete: 0,
                    checked: if verify { pts.len() } else { 0 },
                    corrected: 0
                },
                "{name} signed {signed} verify {verify}"
            );
        }
    }
}

fn bunny() -> TriMesh {
    TriMesh::fan(&load_mesh_file(model("stanford-bunny.obj")).unwrap())
}

#[test]
fn device_distances_are_the_cpus_on_closed_holed_and_unwelded_meshes() {
    let gpu = common::validated_gpu();
    let b = bunny();
    check_case(&gpu, "bunny", &b, 2000);
    check_case(
        &gpu,
        "bunny_holes_third",
        &with_holes(&b, 1.0 / 3.0, 3),
        2000,
    );
    check_case(&gpu, "bunny_soup", &soup(&b, 1e-7, 5), 2000);
    gpu.finish().unwrap();
}

/// Slivers: the fan of one 100,000-gon (every triangle meets at one vertex, 6·10⁻⁵ rad wide), and a prism
/// of two 4,000-gons with one side panel open (the pieces of a long sliver tie along their cuts).
#[test]
fn device_distances_are_the_cpus_on_the_slivers_of_huge_polygons() {
    let gpu = common::validated_gpu();
    let fan = TriMesh::fan(&gregvox::bench::simplify::disc(100_000));
    check_case(&gpu, "fan", &fan, 300);
    check_case(&gpu, "prism", &polygon_prism(4000), 1000);
    gpu.finish().unwrap();
}

#[test]
fn the_query_command_searches_on_the_device_with_the_cpus_arrays() {
    let dir = std::env::temp_dir().join(format!("gregvox-query-device-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mesh = model("spot.obj");
    let run = |device: bool, out: &std::path::Path| {
        let mut args = vec![
            "query".to_string(),
            mesh.display().to_string(),
            "--sample".into(),
            "uniform:3000,near:0.01:3000".into(),
            "--what".into(),
            "sdf,udf".into(),
            "--closest".into(),
            "--json".into(),
            "--out".into(),
            out.display().to_string(),
        ];
        if device {
            args.push("--device-check".into());
        }
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_gregvox"))
            .args(&args)
            .env("GREGVOX_VALIDATION", "1")
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    };
    let (cpu, dev) = (dir.join("cpu.npz"), dir.join("dev.npz"));
    run(false, &cpu);
    let summary = run(true, &dev);
    let j: serde_json::Value = serde_json::from_str(summary.trim()).unwrap();
    assert_eq!(
        j["device_check"],
        serde_json::json!({"incomplete": 0, "checked": 6000, "corrected": 0}),
        "{summary}"
    );
    assert_eq!(std::fs::read(&cpu).unwrap(), std::fs::read(&dev).unwrap());
    // --device without a distance: one error line, nothing written.
    let nothing = dir.join("nothing.npz");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .args([
            "query",
            &mesh.display().to_string(),
            "--sample",
            "uniform:10",
        ])
        .args(["--what", "occupancy", "--device", "--out"])
        .arg(&nothing)
        .output()
        .unwrap();
    common::assert_one_error_line(
        "--device --what occupancy",
        &out,
        &["--device", "sdf or udf"],
    );
    assert!(!nothing.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The device's search itself, slot by slot against the CPU's (the same piece, not only the same
/// triangle), also where the driver's f64 quotients are a few ulps off, and cut short at a few nodes: then
/// it says so, and its best piece so far is one the host can start from.
#[test]
fn the_device_search_finds_the_cpus_pieces_and_says_when_it_stopped_short() {
    use gregvox::mesh::distance::{DistanceTree, Stack};
    use gregvox::passes::closest_point::{nearest_slots, Search, INCOMPLETE, VISITS};
    let gpu = common::validated_gpu();
    for (name, t) in [
        ("prism", polygon_prism(4000)),
        (
            "fan",
            TriMesh::fan(&gregvox::bench::simplify::disc(100_000)),
        ),
    ] {
        let tris: Vec<[[f64; 3]; 3]> = t
            .triangles
            .iter()
            .map(|x| x.map(|v| t.positions[v as usize].map(f64::from)))
            .collect();
        let tree = DistanceTree::new_split(&tris, 2.0 / 128.0, 1 << 18);
        let layout = tree.device_layout();
        let pts = points(&t, 300, 7);
        let cpu: Vec<usize> = pts
            .iter()
            .map(|&p| {
                let mut hint = None;
                tree.closest_within_from(p, f64::INFINITY, &mut hint, &mut Stack::default())
                    .unwrap();
                hint.unwrap()
            })
            .collect();
        // The shader that corrects the driver's quotients (every driver's but lavapipe's), on exact ones and
        // on ones off by a few ulps (Vulkan allows it in f64): IEEE's quotients, hence the CPU's pieces.
        for perturb in [0, 1, -1, 3, -3] {
            let search = Search {
                visits: VISITS,
                perturb,
                force_correction: true,
            };
            let full = nearest_slots(gpu.context(), &layout, &pts, search).unwrap();
            let dev: Vec<usize> = full.iter().map(|&s| s as usize).collect();
            assert_eq!(
                dev, cpu,
                "{name}, quotients {perturb} ulps off: the CPU's pieces"
            );
        }
        let search = Search {
            visits: 4,
            ..Search::default()
        };
        let short = nearest_slots(gpu.context(), &layout, &pts, search).unwrap();
        let stopped = short.iter().filter(|&&s| s & INCOMPLETE != 0).count();
        assert!(
            stopped * 2 > pts.len(),
            "{name}: {stopped} searches stopped at 4 nodes"
        );
        for (i, &s) in short.iter().enumerate() {
            let slot = (s & !INCOMPLETE) as usize;
            assert!(slot < layout.index.len(), "{name} point {i}");
            if s & INCOMPLETE == 0 {
                assert_eq!(slot, cpu[i], "{name} point {i}: a complete search");
            }
        }
    }
    gpu.finish().unwrap();
}
