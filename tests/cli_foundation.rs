//! Specification of the foundation's command line: `gregvox info` and `gregvox demo` (offscreen), their
//! error paths, and the profile outputs. Runs the real binary with the validation layer forced on.
use std::process::{Command, Output};

fn gregvox(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .args(args)
        .env("GREGVOX_VALIDATION", "1")
        .output()
        .expect("run gregvox")
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

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn assert_clean_stderr(out: &Output) {
    let err = text(&out.stderr);
    assert!(
        !err.contains("vulkan validation"),
        "validation messages:\n{err}"
    );
    assert!(!err.contains("panicked"), "panic:\n{err}");
}

#[test]
fn info_reports_the_device_limits_and_the_validation_layer() {
    let out = gregvox(&["info", "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_clean_stderr(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in [
        "name",
        "driver_name",
        "api_version",
        "max_storage_buffer_range",
        "max_compute_work_group_count",
        "max_image_dimension_2d",
        "max_push_constants_size",
        "timestamps_supported",
        "validation_layer_present",
    ] {
        assert!(v.get(key).is_some(), "missing key {key} in {v}");
    }
    assert_eq!(v["validation_layer_present"], true);
    assert!(v["max_storage_buffer_range"].as_u64().unwrap() >= 1 << 27);
    if std::env::var("VK_DRIVER_FILES").is_ok_and(|f| f.contains("lvp")) {
        assert!(v["name"].as_str().unwrap().contains("llvmpipe"), "{v}");
        assert_eq!(v["max_compute_work_group_count"][0], 65535);
    }
    let human = gregvox(&["info"]);
    assert!(human.status.success());
    let s = text(&human.stdout);
    assert!(
        s.contains("max storage buffer range")
            && s.contains("timestamps")
            && s.contains("validation layer")
    );
}

#[test]
fn info_without_a_vulkan_driver_fails_with_one_clear_line() {
    let out = Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .arg("info")
        .env("VK_DRIVER_FILES", "/nonexistent/gregvox_no_driver.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/gregvox_no_driver.json")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert_eq!(
        err.trim().lines().count(),
        1,
        "expected one line, got:\n{err}"
    );
    assert!(err.contains("no Vulkan driver"), "{err}");
    assert!(!err.contains("panicked"));
}

#[test]
fn offscreen_demo_writes_the_asked_frames_and_the_profiles() {
    let dir = std::env::temp_dir().join(format!("gregvox-demo-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let prof = dir.join("profile.json");
    let trace = dir.join("trace.json");
    let out = gregvox(&[
        "demo",
        "--scene",
        "spinner",
        "--offscreen",
        "--frames",
        "7",
        "--every",
        "3",
        "--size",
        "64x48",
        "--out",
        dir.to_str().unwrap(),
        "--profile-json",
        prof.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_clean_stderr(&out);
    let mut pngs: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".png"))
        .collect();
    pngs.sort();
    // Every third frame (0, 3, 6) and always the last (6).
    assert_eq!(
        pngs,
        ["frame_00000.png", "frame_00003.png", "frame_00006.png"]
    );
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(dir.join(&pngs[2])).unwrap(),
    ));
    let reader = decoder.read_info().unwrap();
    assert_eq!((reader.info().width, reader.info().height), (64, 48));

    let p: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&prof).unwrap()).unwrap();
    assert!(p["device"].is_string());
    let passes = p["passes"].as_array().unwrap();
    assert_eq!(passes.len(), 2, "{p}");
    for pass in passes {
        assert_eq!(pass["calls"], 7);
        let ms = &pass["gpu_ms"];
        assert!(ms["min"].as_f64().unwrap() > 0.0);
        assert!(
            ms["min"].as_f64() <= ms["median"].as_f64()
                && ms["median"].as_f64() <= ms["max"].as_f64()
        );
    }
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).unwrap();
    assert_eq!(t["traceEvents"].as_array().unwrap().len(), 14);
    assert_eq!(temporaries(&dir), Vec::<String>::new());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn windowed_demo_without_a_display_suggests_offscreen() {
    let out = Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .args(["demo", "--frames", "1"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("--offscreen"), "{err}");
}

#[test]
fn demo_rejects_bad_sizes_and_unwritable_outputs_clearly() {
    let out = gregvox(&["demo", "--offscreen", "--size", "0x10"]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("size '0x10'"),
        "{}",
        text(&out.stderr)
    );
    let out = gregvox(&[
        "demo",
        "--offscreen",
        "--frames",
        "1",
        "--out",
        "/proc/gregvox-cannot-write-here",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(
        err.contains("/proc/gregvox-cannot-write-here") && !err.contains("panicked"),
        "{err}"
    );
}

#[test]
fn every_demo_scene_renders_offscreen_under_validation() {
    use clap::ValueEnum;
    let scenes: Vec<String> = gregvox::demo::SceneKind::all()
        .iter()
        .map(|k| k.to_possible_value().unwrap().get_name().to_string())
        .collect();
    assert_eq!(scenes.len(), 6, "{scenes:?}");
    for scene in &scenes {
        let dir =
            std::env::temp_dir().join(format!("gregvox-scene-{scene}-{}", std::process::id()));
        let out = gregvox(&[
            "demo",
            "--offscreen",
            "--scene",
            scene,
            "--frames",
            "3",
            "--size",
            "96x64",
            "--out",
            dir.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{scene}: {}", text(&out.stderr));
        assert_clean_stderr(&out);
        let png = dir.join("frame_00002.png");
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut px = vec![0; reader.output_buffer_size()];
        reader.next_frame(&mut px).unwrap();
        // Something was drawn: at least 1 % of the pixels differ by more than 8/255 from the frame's most
        // common colour (the background). One stray pixel is not a scene.
        let mut counts = std::collections::HashMap::new();
        for p in px.chunks_exact(4) {
            *counts.entry(p).or_insert(0usize) += 1;
        }
        let (bg, _) = counts.into_iter().max_by_key(|&(_, c)| c).unwrap();
        let bg = bg.to_vec();
        let shown = px
            .chunks_exact(4)
            .filter(|p| p.iter().zip(&bg).any(|(a, b)| a.abs_diff(*b) > 8))
            .count() as f64
            / (px.len() / 4) as f64;
        assert!(
            shown >= 0.01,
            "{scene}: only {:.2} % of the pixels show anything",
            100.0 * shown
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
