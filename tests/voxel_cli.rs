//! Specification of `gregvox voxelize`: outputs that parse back, open-mesh handling, and one clear error for
//! every bad input (validation layer forced on).
use std::process::{Command, Output};

fn gregvox(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .args(args)
        .env("GREGVOX_VALIDATION", "1")
        .output()
        .unwrap()
}

/// Names in `dir` that an interrupted or failed atomic write would leave (`.NAME.PID.tmp`, see src/io.rs):
/// any hidden file or any `.tmp` file.
fn temporaries(dir: &std::path::Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with('.') || n.ends_with(".tmp"))
        .collect()
}

fn model(name: &str) -> String {
    format!("{}/assets/models/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("gregvox-voxel-cli-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

fn one_line_error(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "expected failure");
    // Informational notes may precede it; the error itself is one line.
    let errors: Vec<&str> = err
        .lines()
        .filter(|l| !l.starts_with("gregvox voxelize: "))
        .collect();
    assert_eq!(errors.len(), 1, "one error line expected:\n{err}");
    assert!(
        errors[0].starts_with("gregvox: error: ") && errors[0].contains(needle),
        "'{needle}' not in: {err}"
    );
    assert!(!err.contains("panicked") && !err.contains("vulkan validation"));
}

#[test]
fn peel_and_cpu_agree_on_spot_and_the_binvox_parses_back() {
    let out_peel = tmp("spot_peel.binvox");
    let out_cpu = tmp("spot_cpu.binvox");
    let a = gregvox(&[
        "voxelize",
        &model("spot.obj"),
        "--res",
        "64",
        "--axis",
        "z",
        "--method",
        "peel",
        "--out",
        out_peel.to_str().unwrap(),
        "--json",
    ]);
    assert!(a.status.success(), "{}", String::from_utf8_lossy(&a.stderr));
    let b = gregvox(&[
        "voxelize",
        &model("spot.obj"),
        "--res",
        "64",
        "--axis",
        "z",
        "--method",
        "cpu",
        "--out",
        out_cpu.to_str().unwrap(),
        "--json",
    ]);
    assert!(b.status.success());
    let ja: serde_json::Value = serde_json::from_slice(&a.stdout).unwrap();
    let jb: serde_json::Value = serde_json::from_slice(&b.stdout).unwrap();
    assert_eq!(
        ja["layers"]["z"].as_u64().unwrap() % 2,
        0,
        "a closed mesh has an even layer count"
    );
    let ga = gregvox::voxel::export::parse_binvox(&std::fs::read(&out_peel).unwrap()).unwrap();
    let gb = gregvox::voxel::export::parse_binvox(&std::fs::read(&out_cpu).unwrap()).unwrap();
    let solid = jb["solid_voxels"].as_u64().unwrap();
    assert_eq!(gb.count(), solid);
    assert_eq!(ga.count(), ja["solid_voxels"].as_u64().unwrap());
    let diff = ga.count_differences(&gb);
    eprintln!(
        "spot 64³: peel {} vs cpu {solid} solid, {diff} differ",
        ga.count()
    );
    assert!(diff <= 4.max(solid / 100_000), "{diff}");
    assert_eq!(
        temporaries(out_peel.parent().unwrap()),
        Vec::<String>::new()
    );
}

#[test]
fn open_meshes_are_capped_for_the_generalized_winding_number_and_voted_with_axes_3() {
    let run = |extra: &[&str]| {
        let mut args = vec![
            "voxelize".to_string(),
            model("suzanne.obj"),
            "--res".into(),
            "32".into(),
            "--method".into(),
            "peel".into(),
            "--json".into(),
        ];
        args.extend(extra.iter().map(|s| s.to_string()));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = gregvox(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(err.contains("open mesh"), "{err}");
        let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(
            j["removed"]["cancelled"], 2,
            "suzanne's duplicate face pair"
        );
        (j, err)
    };
    // Default: the generalized winding number over one axis, its cap and flips reported.
    let (j, _) = run(&[]);
    assert_eq!(j["rule"], "gwn");
    assert_eq!(j["layers"].as_object().unwrap().len(), 1);
    let gwn = &j["gwn"];
    assert!(gwn["loops_capped"].as_u64().unwrap() >= 1, "{gwn}");
    assert_eq!(gwn["boundary_edges"], 42, "{gwn}");
    assert!(
        gwn["near_voxels"].as_u64().unwrap() >= gwn["flipped"].as_u64().unwrap(),
        "{gwn}"
    );
    // --axes 3 keeps the old 2-of-3 vote of the winding rule, and says so.
    let (j, err) = run(&["--axes", "3"]);
    assert!(err.contains("open mesh (42 boundary"), "{err}");
    assert_eq!(j["layers"].as_object().unwrap().len(), 3);
    assert!(j["gwn"].is_null(), "{}", j["gwn"]);
    assert!(err.contains("2-of-3 vote"), "{err}");
}

#[test]
fn bad_inputs_end_with_one_clear_line() {
    one_line_error(
        &gregvox(&["voxelize", "/nonexistent/x.obj", "--res", "8"]),
        "/nonexistent/x.obj",
    );
    one_line_error(
        &gregvox(&["voxelize", &model("spot.obj"), "--res", "0"]),
        "--res 0",
    );
    one_line_error(
        &gregvox(&["voxelize", &model("spot.obj"), "--res", "5000"]),
        "between 1 and 2048",
    );
    one_line_error(
        &gregvox(&[
            "voxelize",
            &model("spot.obj"),
            "--res",
            "8",
            "--out",
            "x.fbx",
        ]),
        "unknown voxel format",
    );
    let empty = tmp("empty.obj");
    std::fs::write(&empty, "# nothing\n").unwrap();
    one_line_error(
        &gregvox(&["voxelize", empty.to_str().unwrap(), "--res", "8"]),
        "empty.obj",
    );
    let flat = tmp("flat.obj");
    std::fs::write(&flat, "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").unwrap();
    one_line_error(
        &gregvox(&["voxelize", flat.to_str().unwrap(), "--res", "8"]),
        "no triangle with a non-zero area",
    );
    one_line_error(
        &gregvox(&[
            "voxelize",
            &model("spot.obj"),
            "--res",
            "8",
            "--out",
            "/proc/gregvox/x.binvox",
        ]),
        "/proc/gregvox/x.binvox",
    );
    one_line_error(
        &gregvox(&[
            "voxelize",
            &model("stanford-bunny.obj"),
            "--res",
            "16",
            "--axis",
            "x",
            "--method",
            "peel",
            "--max-layers",
            "4",
        ]),
        "depth layers along x",
    );
}

#[test]
fn abuffer_method_equals_peel_on_teapot_and_writes_vox() {
    // The teapot's overlapping shells (w = 2) and open rims: both GPU methods use the same sampling and the
    // same fill, so their binvox files are byte-identical; the .vox of the same grid holds the same count.
    let run = |method: &str, out: &std::path::Path| {
        let o = gregvox(&[
            "voxelize",
            &model("teapot.obj"),
            "--res",
            "48",
            "--axes",
            "1",
            "--axis",
            "z",
            "--method",
            method,
            "--out",
            out.to_str().unwrap(),
            "--json",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(j["method"], method);
        j["solid_voxels"].as_u64().unwrap()
    };
    let (p, a, v) = (
        tmp("tp_peel.binvox"),
        tmp("tp_abuf.binvox"),
        tmp("tp_abuf.vox"),
    );
    let np = run("peel", &p);
    let na = run("abuffer", &a);
    let nv = run("abuffer", &v);
    assert!(np > 0 && np == na && na == nv, "{np} {na} {nv}");
    assert_eq!(std::fs::read(&p).unwrap(), std::fs::read(&a).unwrap());
    let vox = dot_vox::load_bytes(&std::fs::read(&v).unwrap()).unwrap();
    let n: usize = vox.models.iter().map(|m| m.voxels.len()).sum();
    assert_eq!(n as u64, nv);
    // No progress bar on a pipe: stderr holds only the informational notes.
    let o = gregvox(&[
        "voxelize",
        &model("teapot.obj"),
        "--res",
        "512",
        "--method",
        "cpu",
        "--axes",
        "1",
        "--rule",
        "winding",
    ]);
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.lines().all(|l| l.starts_with("gregvox voxelize: ")),
        "{err}"
    );
}
