//! `gregvox mesh` and `gregvox subdivide` run as the real binary.
mod mesh_common;
use mesh_common::model;
use std::process::Command;

fn gregvox(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .args(args)
        .output()
        .expect("gregvox runs")
}

const REQUIRED: [&str; 10] = [
    "vertices",
    "faces",
    "edges",
    "boundary_edges",
    "non_manifold_edges",
    "inconsistent_edges",
    "closed",
    "components",
    "euler_characteristic",
    "valence_histogram",
];

fn json_of(name: &str) -> serde_json::Value {
    let path = model(name);
    let out = gregvox(&["mesh", path.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("stdout is one JSON document")
}

#[test]
fn mesh_json_of_the_bunny() {
    let j = json_of("stanford-bunny.obj");
    for k in REQUIRED {
        assert!(j.get(k).is_some(), "key {k}");
    }
    assert_eq!(j["vertices"], 35947);
    assert_eq!(j["faces"], 69451);
    assert_eq!(j["edges"], 104288);
    assert_eq!(j["boundary_edges"], 223);
    assert_eq!(j["non_manifold_edges"], 0);
    assert_eq!(j["inconsistent_edges"], 0);
    assert_eq!(j["closed"], false);
    assert_eq!(j["components"], 1);
    assert_eq!(j["euler_characteristic"], -3);
    assert_eq!(j["unreferenced_vertices"], 1113);
    assert_eq!(
        j["boundary_loop_sizes"],
        serde_json::json!([22, 39, 40, 42, 80])
    );
    // keys are strings, counts sum to the referenced vertices
    let hist = j["valence_histogram"].as_object().unwrap();
    assert_eq!(hist["6"], 26169);
    assert_eq!(
        hist.values().map(|v| v.as_u64().unwrap()).sum::<u64>(),
        34834
    );
}

#[test]
fn mesh_json_of_cow_teapot_suzanne() {
    let cow = json_of("cow.obj");
    assert_eq!(
        (
            cow["closed"].as_bool(),
            cow["euler_characteristic"].as_i64()
        ),
        (Some(true), Some(1))
    );
    assert_eq!(cow["non_manifold_vertices"], 1);
    let teapot = json_of("teapot.obj");
    assert_eq!(
        (
            teapot["components"].as_u64(),
            teapot["face_components"].as_u64()
        ),
        (Some(4), Some(19))
    );
    let suzanne = json_of("suzanne.obj");
    assert_eq!(suzanne["components"], 3);
}

#[test]
fn mesh_human_report_names_the_figures() {
    let path = model("spot.obj");
    let out = gregvox(&["mesh", path.to_str().unwrap()]);
    assert!(out.status.success());
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(
        s.contains("spot.obj") && s.contains("5856") && s.contains("closed           yes"),
        "{s}"
    );
}

#[test]
fn mesh_weld_flag_joins_the_teapot() {
    let path = model("teapot.obj");
    let out = gregvox(&["mesh", path.to_str().unwrap(), "--json", "--weld", "1e-7"]);
    assert!(out.status.success());
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["vertices"], 3241);
}

#[test]
fn bad_input_is_one_line_and_a_non_zero_exit() {
    let dir = std::env::temp_dir().join(format!("gregvox-mesh-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("nan-cli.obj");
    std::fs::write(&bad, "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    for args in [
        vec!["mesh".to_string(), bad.display().to_string()],
        vec![
            "mesh".to_string(),
            dir.join("absent.obj").display().to_string(),
            "--json".into(),
        ],
        vec![
            "subdivide".to_string(),
            bad.display().to_string(),
            "--out".into(),
            dir.join("o.obj").display().to_string(),
        ],
    ] {
        let out = gregvox(&args.iter().map(|s| s.as_str()).collect::<Vec<_>>());
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(
            err.contains("gregvox: error:")
                && (err.contains("nan-cli.obj") || err.contains("absent.obj")),
            "{err}"
        );
        assert!(!err.contains("panicked"));
        assert!(out.stdout.is_empty());
    }
}

#[test]
fn subdivide_writes_catmull_clark_obj() {
    let dir = std::env::temp_dir().join(format!("gregvox-mesh-cli-sub-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out_path = dir.join("spot-cc2.obj");
    let input = model("spot_control_mesh.obj");
    let out = gregvox(&[
        "subdivide",
        input.to_str().unwrap(),
        "--levels",
        "2",
        "--out",
        out_path.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let m = gregvox::mesh::load_obj(&out_path).unwrap();
    assert_eq!((m.positions.len(), m.n_faces()), (2930, 2928));
    // the library result, written and read back exactly
    let lib = gregvox::mesh::catmull_clark(&gregvox::mesh::load_obj(&input).unwrap(), 2);
    assert_eq!(m, lib);
    // Loop on polygons is refused with a message naming the file
    let out = gregvox(&[
        "subdivide",
        input.to_str().unwrap(),
        "--scheme",
        "loop",
        "--out",
        out_path.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("spot_control_mesh.obj"));
}

#[test]
fn mesh_triangulate_flag_fan_splits_polygons() {
    let path = model("suzanne.obj");
    let out = gregvox(&["mesh", path.to_str().unwrap(), "--json", "--triangulate"]);
    assert!(out.status.success());
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let polys = json_of("suzanne.obj");
    // 32 triangles + 468 quads × 2
    assert_eq!(j["faces"], 32 + 2 * 468);
    assert_eq!(j["components"], polys["components"]);
    assert_eq!(j["boundary_edges"], polys["boundary_edges"]);
    // Each diagonal is a new edge except one that coincides with an existing edge: the naive fan makes
    // that edge non-manifold and raises χ by one (the "test polygon paths on polygon data" trap).
    assert_eq!(
        j["edges"].as_u64().unwrap(),
        polys["edges"].as_u64().unwrap() + 468 - 1
    );
    assert_eq!(
        (
            j["non_manifold_edges"].as_u64(),
            polys["non_manifold_edges"].as_u64()
        ),
        (Some(1), Some(0))
    );
    assert_eq!(
        j["euler_characteristic"].as_i64().unwrap(),
        polys["euler_characteristic"].as_i64().unwrap() + 1
    );
}
