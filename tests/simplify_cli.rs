//! `gregvox simplify` run as the real binary: every output format read back by the loader, levels of
//! detail as files and as one GLB, the JSON report, and bad input (one error line, nothing written).
mod common;
use common::{assert_one_error_line, entries_under, model};
use gregvox::api::{load_mesh, topology};
use std::process::Command;

fn gregvox(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .args(args)
        .output()
        .expect("gregvox runs")
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!(
        "gregvox-simplify-cli-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn every_output_format_reads_back_with_the_reported_triangles() {
    let dir = tmp("formats");
    let spot = model("spot.obj");
    for ext in ["obj", "ply", "stl", "glb"] {
        let out = dir.join(format!("spot.{ext}"));
        let o = gregvox(&[
            "simplify",
            spot.to_str().unwrap(),
            "--ratio",
            "0.25",
            "--out",
            out.to_str().unwrap(),
            "--json",
        ]);
        assert!(
            o.status.success(),
            "{ext}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let level = &j["levels"][0];
        for key in [
            "input_faces",
            "faces",
            "vertices",
            "error",
            "relative_error",
            "collapses",
            "passes",
            "out",
        ] {
            assert!(!level[key].is_null(), "{ext}: {key}");
        }
        let faces = level["faces"].as_u64().unwrap() as usize;
        assert!(faces <= 5856 / 4);
        let back = load_mesh(&out).unwrap();
        assert_eq!(back.n_faces(), faces, "{ext}");
        // STL and glTF are welded on load; OBJ and PLY keep ids: closed either way.
        assert!(topology(&back).closed, "{ext}");
    }
}

#[test]
fn levels_of_detail_as_files_and_as_one_glb() {
    let dir = tmp("lod");
    let bunny = model("stanford-bunny.obj");
    let out = dir.join("b.obj");
    let o = gregvox(&[
        "simplify",
        bunny.to_str().unwrap(),
        "--ratio",
        "0.5",
        "--lod",
        "3",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        text.lines().filter(|l| l.contains("level ")).count(),
        3,
        "{text}"
    );
    let faces: Vec<usize> = (0..3)
        .map(|k| {
            load_mesh(dir.join(format!("b_lod{k}.obj")))
                .unwrap()
                .n_faces()
        })
        .collect();
    assert_eq!(faces[0], 69451);
    // Each level at most half the previous one (a collapse removes two triangles: one may be missing).
    assert!(
        faces[1] <= 69451 / 2 && faces[1] + 2 >= 69451 / 2,
        "{faces:?}"
    );
    assert!(
        faces[2] <= faces[1] / 2 && faces[2] + 2 >= faces[1] / 2,
        "{faces:?}"
    );
    let glb = dir.join("b.glb");
    let o = gregvox(&[
        "simplify",
        bunny.to_str().unwrap(),
        "--ratio",
        "0.5",
        "--lod",
        "3",
        "--out",
        glb.to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["levels"].as_array().unwrap().len(), 3);
    // The loader reads the scene: level 0; the others hang off it through MSFT_lod.
    assert_eq!(load_mesh(&glb).unwrap().n_faces(), 69451);
    let bytes = std::fs::read(&glb).unwrap();
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    assert_eq!(
        doc["nodes"][0]["extensions"]["MSFT_lod"]["ids"],
        serde_json::json!([1, 2])
    );
    assert_eq!(doc["meshes"].as_array().unwrap().len(), 3);
    assert_eq!(doc["nodes"][2]["extras"]["faces"], j["levels"][2]["faces"]);
}

#[test]
fn weld_lets_an_unwelded_mesh_reduce() {
    let dir = tmp("weld");
    let teapot = model("teapot.obj");
    let out = dir.join("t.obj");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "simplify",
            teapot.to_str().unwrap(),
            "--ratio",
            "0.05",
            "--out",
            out.to_str().unwrap(),
            "--json",
        ];
        args.extend_from_slice(extra);
        let o = gregvox(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        j["levels"][0]["faces"].as_u64().unwrap()
    };
    // The teapot's patches repeat their border vertices: seams, which reduce two sides at a time, but
    // where three or more patches meet the copies are locked and hold the reduction above the target,
    // unless welded.
    let (plain, welded) = (run(&[]), run(&["--weld", "1e-6"]));
    assert!(plain > 6320 / 20 && welded <= 6320 / 20, "{plain} {welded}");
}

#[test]
fn bad_input_is_one_error_line_and_nothing_written() {
    let dir = tmp("bad");
    let spot = model("spot.obj");
    let spot = spot.to_str().unwrap();
    let out = dir.join("o.obj");
    let out = out.to_str().unwrap();
    let fbx = dir.join("o.fbx");
    let fbx = fbx.to_str().unwrap();
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec![
                "simplify",
                "/nonexistent/m.obj",
                "--ratio",
                "0.5",
                "--out",
                out,
            ],
            vec!["/nonexistent/m.obj"],
        ),
        (
            vec!["simplify", spot, "--ratio", "2", "--out", out],
            vec!["ratio"],
        ),
        (
            vec!["simplify", spot, "--error=-1", "--out", out],
            vec!["error"],
        ),
        (
            vec![
                "simplify",
                spot,
                "--ratio",
                "0.5",
                "--weld=-1",
                "--out",
                out,
            ],
            vec!["--weld"],
        ),
        (
            vec![
                "simplify", spot, "--ratio", "0.5", "--lod", "0", "--out", out,
            ],
            vec!["--lod"],
        ),
        (
            vec!["simplify", spot, "--ratio", "0.5", "--out", fbx],
            vec!["o.fbx", "extension"],
        ),
    ];
    for (args, needles) in cases {
        let o = gregvox(&args);
        assert_one_error_line(&args.join(" "), &o, &needles);
    }
    // No target at all: the argument parser refuses.
    let o = gregvox(&["simplify", spot, "--out", out]);
    assert!(!o.status.success());
    assert!(entries_under(&dir).is_empty(), "{:?}", entries_under(&dir));
}
