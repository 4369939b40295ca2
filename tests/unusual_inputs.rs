//! Valid but unusual input gives the right answer (not a silently wrong one), and out-of-range numbers are
//! refused with one clear line instead of reaching the GPU as infinities.
mod common;
use common::model;
use std::io::Read;
use std::process::Command;

fn gregvox() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gregvox"))
}

/// A fresh empty folder under the target directory.
fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("unusual-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn a_utf8_byte_order_mark_before_the_first_vertex_is_skipped() {
    let text = std::fs::read_to_string(model("opensubdiv/catmark_cube.obj")).unwrap();
    let plain = gregvox::mesh::parse_obj(&text, "cube.obj").unwrap();
    let marked = gregvox::mesh::parse_obj(&format!("\u{feff}{text}"), "cube.obj").unwrap();
    assert_eq!(
        marked.positions, plain.positions,
        "the first v line was lost"
    );
    assert_eq!(marked.indices, plain.indices);
    // Through a file and the CLI: the same topology report as without the mark.
    let dir = scratch("bom");
    let with_bom = dir.join("bom.obj");
    std::fs::write(&with_bom, format!("\u{feff}{text}")).unwrap();
    let report = |p: &std::path::Path| {
        let o = gregvox().arg("mesh").arg(p).arg("--json").output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8(o.stdout).unwrap()
    };
    assert_eq!(
        report(&with_bom),
        report(&model("opensubdiv/catmark_cube.obj"))
    );
}

#[test]
fn a_beziex_file_with_a_byte_order_mark_loads_the_same_patches() {
    let mut json = String::new();
    flate2::read::GzDecoder::new(std::fs::File::open(model("beziex/19_Sphere1.gzjson")).unwrap())
        .read_to_string(&mut json)
        .unwrap();
    let path = std::path::Path::new("sphere.json");
    let plain = gregvox::surface::beziex::parse_beziex(&json, path).unwrap();
    let marked = gregvox::surface::beziex::parse_beziex(&format!("\u{feff}{json}"), path).unwrap();
    assert_eq!(marked.len(), plain.len());
    assert_eq!(marked[0].to_gpu(), plain[0].to_gpu());
}

#[test]
fn a_beziex_coordinate_past_the_f32_range_is_refused_by_name() {
    let mut json = String::new();
    flate2::read::GzDecoder::new(std::fs::File::open(model("beziex/19_Sphere1.gzjson")).unwrap())
        .read_to_string(&mut json)
        .unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["surface"][3]["vertex"][1] = serde_json::json!(1e39);
    let dir = scratch("beziex-range");
    let input = dir.join("huge.json");
    std::fs::write(&input, v.to_string()).unwrap();
    let out = dir.join("out.obj");
    let o = gregvox()
        .args(["tessellate", "--level", "2", "--out"])
        .arg(&out)
        .arg(&input)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("huge.json") && err.contains("patch 3") && err.contains("f32 range"),
        "{err}"
    );
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(
        left,
        [std::ffi::OsString::from("huge.json")],
        "something was written"
    );
}

#[test]
fn the_voxelize_summary_is_short_unless_a_profile_is_asked_for() {
    let dir = scratch("summary");
    let run = |extra: &[&str]| {
        let o = gregvox()
            .arg("voxelize")
            .arg(model("opensubdiv/catmark_cube.obj"))
            .args(["--res", "8", "--method", "peel"])
            .args(extra)
            .current_dir(&dir)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        (
            String::from_utf8(o.stdout).unwrap(),
            String::from_utf8(o.stderr).unwrap(),
        )
    };
    let (plain, plain_err) = run(&[]);
    assert!(!plain_err.contains("peel"), "{plain_err}");
    // Input and grid, method, layers per axis, solid voxels, total time.
    assert_eq!(plain.lines().count(), 5, "{plain}");
    assert!(!plain.contains("peel layer"), "{plain}");
    // --profile adds the per-pass table (on stderr, as for every command).
    let (_, profiled) = run(&["--profile"]);
    assert!(profiled.contains("peel"), "{profiled}");
}
