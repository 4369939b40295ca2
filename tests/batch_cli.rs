//! Specification of `gregvox batch`: a folder of mixed, partly broken models voxelized in one run; shards
//! run concurrently covering every model once; resume after SIGKILL giving byte-identical outputs and no
//! temporary left; manifests, globs and the job-runner environment.
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn gregvox(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_gregvox"));
    c.args(args).env("GREGVOX_VALIDATION", "1");
    for k in [
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_COUNT",
        "RANK",
        "WORLD_SIZE",
    ] {
        c.env_remove(k);
    }
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gregvox-batch-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Removes a test's dataset and everything named after it (outputs, reports) once the test passed.
fn cleanup(data: &Path) {
    let prefix = data.file_name().unwrap().to_string_lossy().into_owned();
    for e in std::fs::read_dir(data.parent().unwrap()).unwrap().flatten() {
        if e.file_name().to_string_lossy().starts_with(&prefix) {
            let p = e.path();
            let _ = if p.is_dir() {
                std::fs::remove_dir_all(&p)
            } else {
                std::fs::remove_file(&p)
            };
        }
    }
}

fn model(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("assets/models")
        .join(name)
}

/// A cube of side `s` at `o` as OBJ text.
fn cube_obj(o: f32, s: f32) -> String {
    let mut t = String::new();
    for i in 0..8 {
        let p = [i & 1, (i >> 1) & 1, (i >> 2) & 1].map(|b| o + s * b as f32);
        t += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for f in [
        [1, 3, 4, 2],
        [5, 6, 8, 7],
        [1, 2, 6, 5],
        [3, 7, 8, 4],
        [1, 5, 7, 3],
        [2, 4, 8, 6],
    ] {
        t += &format!("f {} {} {} {}\n", f[0], f[1], f[2], f[3]);
    }
    t
}

/// The test dataset: vendored models, generated cubes in OBJ, STL and PLY (sub-folders included), broken
/// files, and the `.mtl` and texture files datasets carry beside their meshes. Returns the folder and the
/// names of the broken models.
fn dataset(name: &str, cubes: usize) -> (PathBuf, Vec<String>) {
    let d = scratch(name);
    for m in ["spot.obj", "suzanne.obj", "teapot.obj"] {
        std::fs::copy(model(m), d.join(m)).unwrap();
    }
    std::fs::create_dir_all(d.join("gen/deeper")).unwrap();
    for i in 0..cubes {
        let obj = cube_obj(i as f32 * 0.1, 1.0 + i as f32 * 0.05);
        match i % 3 {
            0 => std::fs::write(d.join(format!("gen/cube{i:03}.obj")), &obj).unwrap(),
            1 => {
                // The same cube as an ASCII STL.
                let v: Vec<[f32; 3]> = obj
                    .lines()
                    .filter_map(|l| l.strip_prefix("v "))
                    .map(|l| {
                        let n: Vec<f32> = l.split(' ').map(|x| x.parse().unwrap()).collect();
                        [n[0], n[1], n[2]]
                    })
                    .collect();
                let mut stl = String::from("solid c\n");
                for f in obj.lines().filter_map(|l| l.strip_prefix("f ")) {
                    let q: Vec<usize> = f
                        .split(' ')
                        .map(|x| x.parse::<usize>().unwrap() - 1)
                        .collect();
                    for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
                        stl += "facet normal 0 0 0\nouter loop\n";
                        for k in t {
                            stl += &format!("vertex {} {} {}\n", v[k][0], v[k][1], v[k][2]);
                        }
                        stl += "endloop\nendfacet\n";
                    }
                }
                stl += "endsolid c\n";
                std::fs::write(d.join(format!("gen/deeper/cube{i:03}.STL")), stl).unwrap();
            }
            _ => {
                let v: Vec<&str> = obj.lines().filter_map(|l| l.strip_prefix("v ")).collect();
                let f: Vec<&str> = obj.lines().filter_map(|l| l.strip_prefix("f ")).collect();
                let mut ply = format!(
                    "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
                     property float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
                    v.len(),
                    f.len()
                );
                for l in &v {
                    ply += &format!("{l}\n");
                }
                for l in &f {
                    let q: Vec<usize> = l
                        .split(' ')
                        .map(|x| x.parse::<usize>().unwrap() - 1)
                        .collect();
                    ply += &format!("4 {} {} {} {}\n", q[0], q[1], q[2], q[3]);
                }
                std::fs::write(d.join(format!("gen/cube{i:03}.ply")), ply).unwrap();
            }
        }
    }
    std::fs::write(d.join("gen/cube000.mtl"), "newmtl a\nKd 1 0 0\n").unwrap();
    std::fs::write(d.join("gen/texture.png"), [0x89, b'P', b'N', b'G']).unwrap();
    let broken = [
        (
            "broken_index.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n".as_bytes(),
        ),
        ("empty.stl", b"".as_slice()),
        (
            "lying.ply",
            b"ply\nformat ascii 1.0\nelement vertex 1000000000\nproperty float x\nend_header\n0\n",
        ),
    ];
    for (n, b) in broken {
        std::fs::write(d.join(n), b).unwrap();
    }
    (d, broken.iter().map(|b| b.0.to_string()).collect())
}

fn report_lines(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap_or_default()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// Every file below `dir` (relative path → bytes).
fn tree(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().to_string_lossy().into_owned();
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

fn args<'a>(data: &'a str, out: &'a str, res: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["batch", data, "--res", res, "--out-dir", out];
    a.extend_from_slice(extra);
    a
}

#[test]
fn a_folder_with_broken_models_is_finished_and_each_failure_reported_in_one_line() {
    let (data, broken) = dataset("folder", 9);
    let out = data.with_extension("out");
    let report = data.with_extension("jsonl");
    let (d, o, r) = (
        data.to_str().unwrap(),
        out.to_str().unwrap(),
        report.to_str().unwrap(),
    );
    let run = gregvox(&args(d, o, "24", &["--report", r]), &[]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "a failed model fails the batch");
    assert!(err.contains("3 of 15 models failed"), "{err}");
    assert!(
        !err.contains("panicked") && !err.contains("validation"),
        "{err}"
    );
    let lines = report_lines(&report);
    assert_eq!(
        lines.len(),
        15,
        "one line a model (mtl and png are not models)"
    );
    for l in &lines {
        let input = l["input"].as_str().unwrap();
        let is_broken = broken.iter().any(|b| input.ends_with(b.as_str()));
        assert_eq!(
            l["status"],
            if is_broken { "failed" } else { "done" },
            "{l}"
        );
        if is_broken {
            let e = l["error"].as_str().unwrap();
            assert!(e.contains(input) && !e.contains('\n'), "{e}");
        } else {
            assert!(l["solid_voxels"].as_u64().unwrap() > 0, "{l}");
            assert!(Path::new(l["output"].as_str().unwrap()).is_file());
        }
    }
    // Relative folders are kept; extensions of any case are found.
    assert!(out.join("gen/deeper/cube001.binvox").is_file());
    assert!(out.join("spot.binvox").is_file());
    // A second run skips what is done and retries only the broken ones.
    let again = gregvox(&args(d, o, "24", &["--json"]), &[]);
    let j: serde_json::Value = serde_json::from_slice(&again.stdout).unwrap();
    assert_eq!(
        (j["skipped"].as_u64(), j["failed"].as_u64()),
        (Some(12), Some(3))
    );
    cleanup(&data);
}

#[test]
fn shards_run_at_once_cover_every_model_exactly_once() {
    let (data, _) = dataset("shards", 12);
    let d = data.to_str().unwrap();
    for n in [1usize, 3, 7] {
        let out = data.with_extension(format!("out{n}"));
        let report = data.with_extension(format!("r{n}.jsonl"));
        let (o, r) = (
            out.to_str().unwrap().to_string(),
            report.to_str().unwrap().to_string(),
        );
        let children: Vec<_> = (0..n)
            .map(|i| {
                let shard = format!("{i}/{n}");
                Command::new(env!("CARGO_BIN_EXE_gregvox"))
                    .args(["batch", d, "--res", "16", "--out-dir", &o, "--report", &r])
                    .args(["--shard", &shard])
                    .env("GREGVOX_VALIDATION", "1")
                    .stdout(std::process::Stdio::null())
                    .stderr(std::process::Stdio::null())
                    .spawn()
                    .unwrap()
            })
            .collect();
        for mut c in children {
            c.wait().unwrap();
        }
        let lines = report_lines(&report);
        let mut seen: BTreeMap<String, usize> = BTreeMap::new();
        for l in &lines {
            *seen
                .entry(l["input"].as_str().unwrap().to_string())
                .or_default() += 1;
        }
        assert_eq!(seen.len(), 18, "N = {n}: every model");
        assert!(seen.values().all(|&c| c == 1), "N = {n}: {seen:?}");
    }
    cleanup(&data);
}

#[test]
fn the_job_runner_environment_picks_the_shard() {
    let (data, _) = dataset("env", 6);
    let d = data.to_str().unwrap();
    let listed = |extra: &[&str], env: &[(&str, &str)]| -> Vec<String> {
        let report = data.with_extension(format!("{}.jsonl", extra.len() + env.len()));
        let _ = std::fs::remove_file(&report);
        let mut a = vec![
            "batch",
            d,
            "--res",
            "8",
            "--report",
            report.to_str().unwrap(),
        ];
        a.extend_from_slice(extra);
        gregvox(&a, env);
        report_lines(&report)
            .iter()
            .map(|l| l["input"].as_str().unwrap().to_string())
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect()
    };
    let by_flag = listed(&["--shard", "1/3"], &[]);
    assert_eq!(by_flag.len(), 4);
    let slurm = listed(
        &[],
        &[
            ("SLURM_ARRAY_TASK_ID", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
        ],
    );
    assert_eq!(slurm, by_flag);
    let torch = listed(&[], &[("RANK", "1"), ("WORLD_SIZE", "3")]);
    assert_eq!(torch, by_flag);
    let bad = gregvox(&["batch", d, "--res", "8", "--shard", "3/3"], &[]);
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--shard 3/3"));
    cleanup(&data);
}

#[test]
fn manifests_and_globs_name_the_models() {
    let (data, _) = dataset("manifest", 3);
    let csv = data.join("list.csv");
    std::fs::write(&csv, "id,path\n1,spot.obj\n2,gen/cube000.obj\n").unwrap();
    let jsonl = data.join("list.jsonl");
    std::fs::write(
        &jsonl,
        "{\"path\": \"suzanne.obj\"}\n\n{\"path\": \"gen/cube002.ply\"}\n",
    )
    .unwrap();
    let txt = data.join("list.txt");
    std::fs::write(&txt, "# models\nteapot.obj\n").unwrap();
    let pattern = format!("{}/gen/**/*.STL", data.display());
    let run = gregvox(
        &[
            "batch",
            csv.to_str().unwrap(),
            jsonl.to_str().unwrap(),
            txt.to_str().unwrap(),
            &pattern,
            "--res",
            "8",
            "--json",
        ],
        &[],
    );
    let j: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(j["models"], 6, "{}", String::from_utf8_lossy(&run.stderr));
    let missing = data.join("bad.txt");
    std::fs::write(&missing, "nope.obj\n").unwrap();
    let bad = gregvox(&["batch", missing.to_str().unwrap(), "--res", "8"], &[]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && err.contains("nope.obj"), "{err}");
    cleanup(&data);
}

#[test]
fn a_batch_killed_three_times_and_resumed_writes_every_output_once_byte_identical() {
    let (data, _) = dataset("kill", 30);
    let d = data.to_str().unwrap();
    let clean = data.with_extension("clean");
    let t0 = std::time::Instant::now();
    gregvox(&args(d, clean.to_str().unwrap(), "64", &[]), &[]);
    let clean_time = t0.elapsed();
    let expected = tree(&clean);
    assert_eq!(expected.len(), 33, "{:?}", expected.keys());
    let out = data.with_extension("killed");
    let o = out.to_str().unwrap();
    // Kill points by progress, not by clock (a loaded machine made clock-timed kills land after the batch
    // had finished): SIGKILL once the output folder holds 4, then 11, then 19 finished models (a kill can
    // land mid-write of the next one), each attempt resuming where the last one died.
    // Counted from names alone, every error ignored: the batch renames temporaries as this looks.
    fn outputs(dir: &Path) -> usize {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return 0;
        };
        entries
            .flatten()
            .map(|e| {
                let p = e.path();
                if p.is_dir() {
                    outputs(&p)
                } else {
                    usize::from(p.extension().is_some_and(|x| x == "binvox"))
                }
            })
            .sum()
    }
    let mut interrupted = 0;
    for target in [4, 11, 19] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_gregvox"))
            .args(args(d, o, "64", &[]))
            .env("GREGVOX_VALIDATION", "1")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let start = std::time::Instant::now();
        while outputs(&out) < target && child.try_wait().unwrap().is_none() {
            assert!(start.elapsed() < clean_time * 20 + std::time::Duration::from_secs(60));
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        if child.try_wait().unwrap().is_none() {
            interrupted += 1;
        }
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
    }
    assert_eq!(interrupted, 3, "every kill must hit a running batch");
    // What a kill mid-write leaves: a temporary of a process that is gone (past Linux's largest pid).
    std::fs::write(out.join(".spot.binvox.4194305.tmp"), b"partial").unwrap();
    let fin = gregvox(&args(d, o, "64", &["--json"]), &[]);
    let j: serde_json::Value = serde_json::from_slice(&fin.stdout).unwrap();
    assert_eq!(j["failed"], 3, "the broken models");
    let got = tree(&out);
    let temporaries: Vec<&String> = got
        .keys()
        .filter(|k| k.rsplit('/').next().is_some_and(|n| n.starts_with('.')) || k.ends_with(".tmp"))
        .collect();
    assert!(temporaries.is_empty(), "{temporaries:?}");
    assert_eq!(
        got.keys().collect::<Vec<_>>(),
        expected.keys().collect::<Vec<_>>()
    );
    for (k, v) in &expected {
        assert!(got[k] == *v, "{k} differs from the uninterrupted run");
    }
    cleanup(&data);
}

#[test]
fn resident_memory_stays_flat_over_a_long_batch() {
    let (data, _) = dataset("memory", 120);
    let out = data.with_extension("out");
    let report = data.with_extension("jsonl");
    let run = gregvox(
        &[
            "batch",
            data.to_str().unwrap(),
            "--res",
            "64",
            "--out-dir",
            out.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
            "--workers",
            "2",
        ],
        &[],
    );
    assert!(!run.status.success(), "3 broken models");
    let rss: Vec<f64> = report_lines(&report)
        .iter()
        .filter(|l| l["status"] == "done")
        .map(|l| l["rss_mib"].as_f64().unwrap())
        .collect();
    assert!(rss.len() >= 100, "{}", rss.len());
    let settled = rss[19];
    let worst = rss[20..].iter().cloned().fold(0.0f64, f64::max);
    eprintln!("resident memory after model 20: {settled:.1} MiB, at most {worst:.1} MiB after");
    assert!(worst <= settled * 1.10, "{settled:.1} MiB → {worst:.1} MiB");
    cleanup(&data);
}

#[test]
fn a_model_past_the_time_limit_fails_and_the_batch_goes_on() {
    let data = scratch("timeout");
    // A UV sphere of 300,000 triangles (13 MB of OBJ): loading it alone takes far longer than 0.1 s;
    // the cube, a millisecond.
    let (n, rings) = (500usize, 300usize);
    let mut obj = String::from("v 0 0 1\n");
    for i in 1..rings {
        let t = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..n {
            let p = 2.0 * std::f64::consts::PI * j as f64 / n as f64;
            obj += &format!(
                "v {:.6} {:.6} {:.6}\n",
                t.sin() * p.cos(),
                t.sin() * p.sin(),
                t.cos()
            );
        }
    }
    obj += "v 0 0 -1\n";
    let at = |i: usize, j: usize| 2 + (i - 1) * n + j % n;
    let south = 2 + (rings - 1) * n;
    for j in 0..n {
        obj += &format!("f 1 {} {}\n", at(1, j), at(1, j + 1));
        obj += &format!("f {south} {} {}\n", at(rings - 1, j + 1), at(rings - 1, j));
    }
    for i in 1..rings - 1 {
        for j in 0..n {
            obj += &format!(
                "f {} {} {} {}\n",
                at(i, j),
                at(i + 1, j),
                at(i + 1, j + 1),
                at(i, j + 1)
            );
        }
    }
    std::fs::write(data.join("big_sphere.obj"), obj).unwrap();
    std::fs::write(data.join("cube.obj"), cube_obj(0.0, 1.0)).unwrap();
    let report = data.with_extension("jsonl");
    let run = gregvox(
        &[
            "batch",
            data.to_str().unwrap(),
            "--res",
            "16",
            // The CPU scanline: a GPU under the validation layer can take 0.1 s for the cube's buffers alone.
            "--method",
            "cpu",
            "--timeout-per-model",
            "0.1",
            "--report",
            report.to_str().unwrap(),
        ],
        &[],
    );
    assert!(!run.status.success());
    let lines = report_lines(&report);
    let by_name = |n: &str| {
        lines
            .iter()
            .find(|l| l["input"].as_str().unwrap().ends_with(n))
            .unwrap()
            .clone()
    };
    let big = by_name("big_sphere.obj");
    assert_eq!(big["status"], "failed");
    let e = big["error"].as_str().unwrap();
    assert!(
        e.contains("big_sphere.obj") && e.contains("past the time limit of 0.1 s"),
        "{e}"
    );
    assert_eq!(by_name("cube.obj")["status"], "done");
    let bad = gregvox(
        &[
            "batch",
            data.to_str().unwrap(),
            "--res",
            "8",
            "--timeout-per-model",
            "0",
        ],
        &[],
    );
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--timeout-per-model 0"));
    cleanup(&data);
}

#[test]
fn ctrl_c_stops_after_the_models_in_flight_and_a_rerun_finishes() {
    let (data, _) = dataset("sigint", 60);
    let d = data.to_str().unwrap();
    let out = data.with_extension("out");
    let o = out.to_str().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .args(args(d, o, "64", &[]))
        .env("GREGVOX_VALIDATION", "1")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(300));
    let running = child.try_wait().unwrap().is_none();
    Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    let stopped = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&stopped.stderr);
    assert!(
        !err.contains("panicked") && !err.contains("validation"),
        "{err}"
    );
    // Stopped with models left: a failure that says so. A fast device may finish the last models in flight
    // and leave none: then the run succeeds (the rerun below finds all 63 complete).
    if running && !stopped.status.success() {
        assert!(
            err.contains("interrupted") || err.contains("failed"),
            "{err}"
        );
    }
    let fin = gregvox(&args(d, o, "64", &["--json"]), &[]);
    let j: serde_json::Value = serde_json::from_slice(&fin.stdout).unwrap();
    assert_eq!(
        j["done"].as_u64().unwrap() + j["skipped"].as_u64().unwrap(),
        63,
        "{j}"
    );
    cleanup(&data);
}

#[test]
fn batch_writes_every_voxelize_format_openvdb_and_boundary_meshes_included() {
    let data = scratch("formats");
    std::fs::write(data.join("a.obj"), cube_obj(0.0, 1.0)).unwrap();
    std::fs::write(data.join("b.obj"), cube_obj(2.0, 0.5)).unwrap();
    let d = data.to_str().unwrap();
    for format in ["vdb", "obj", "npz"] {
        let out = data.with_extension(format!("out-{format}"));
        let o = out.to_str().unwrap();
        let run = gregvox(&args(d, o, "8", &["--format", format]), &[]);
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        for stem in ["a", "b"] {
            let path = out.join(format!("{stem}.{format}"));
            let bytes = std::fs::read(&path).unwrap();
            match format {
                "vdb" => assert_eq!(&bytes[..8], &0x5644_4220i64.to_le_bytes()),
                // A cube filling its 8³ grid: one closed box of 6·64 voxel faces.
                "obj" => assert_eq!(
                    String::from_utf8_lossy(&bytes)
                        .lines()
                        .filter(|l| l.starts_with("f "))
                        .count(),
                    6 * 64
                ),
                _ => assert_eq!(&bytes[..2], b"PK"),
            }
        }
    }
    cleanup(&data);
}

/// FNV-1a of `bytes` (the per-model seed of a query batch: seed ⊕ FNV-1a of the relative path).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

#[test]
fn a_query_batch_writes_each_models_npz_as_gregvox_query_does_with_the_models_own_seed() {
    let (data, broken) = dataset("query", 3);
    let d = data.to_str().unwrap();
    let out = data.with_extension("qout");
    let report = data.with_extension("q.jsonl");
    let (o, r) = (out.to_str().unwrap(), report.to_str().unwrap());
    let spec = "uniform:1500,near:0.02:1500";
    // The batch of this test: the samplers, three arrays, seed 7.
    let batch = |out: &str, extra: &[&str]| {
        let mut a = vec![
            "batch",
            d,
            "--query",
            spec,
            "--what",
            "winding,occupancy,sdf",
        ];
        a.extend_from_slice(&["--seed", "7", "--out-dir", out]);
        a.extend_from_slice(extra);
        gregvox(&a, &[])
    };
    let run = batch(o, &["--report", r]);
    assert!(!run.status.success(), "the broken models fail the batch");
    let lines = report_lines(&report);
    assert_eq!(lines.len(), 9, "{lines:?}");
    for l in &lines {
        let input = l["input"].as_str().unwrap();
        if broken.iter().any(|b| input.ends_with(b.as_str())) {
            assert_eq!(l["status"], "failed", "{l}");
            assert!(l["error"].as_str().unwrap().contains(input), "{l}");
            continue;
        }
        assert_eq!(l["status"], "done", "{l}");
        assert_eq!(l["points"], 3000, "{l}");
        let relative = Path::new(input).strip_prefix(&data).unwrap();
        let seed = 7 ^ fnv1a(relative.to_string_lossy().as_bytes());
        assert_eq!(l["seed"].as_u64(), Some(seed), "{l}");
        let npz = PathBuf::from(l["output"].as_str().unwrap());
        assert_eq!(npz, out.join(relative).with_extension("npz"));
        let bytes = std::fs::read(&npz).unwrap();
        for name in ["points.npy", "winding.npy", "occupancy.npy", "sdf.npy"] {
            assert!(
                bytes.windows(name.len()).any(|w| w == name.as_bytes()),
                "{name} in {npz:?}"
            );
        }
        // The same model alone, with its seed: the same file, byte for byte.
        if input.ends_with("spot.obj") || input.ends_with("cube001.STL") {
            let single = data.with_extension("single.npz");
            let seed = seed.to_string();
            let alone = gregvox(
                &[
                    "query",
                    input,
                    "--sample",
                    spec,
                    "--what",
                    "winding,occupancy,sdf",
                    "--seed",
                    &seed,
                    "--out",
                    single.to_str().unwrap(),
                ],
                &[],
            );
            assert!(alone.status.success(), "{alone:?}");
            assert!(std::fs::read(&single).unwrap() == bytes, "{input}");
        }
    }
    // Two shards make the same files; a second run skips every model that was done.
    let sharded = data.with_extension("qshards");
    for shard in ["0/2", "1/2"] {
        batch(sharded.to_str().unwrap(), &["--shard", shard]);
    }
    let mut whole = tree(&out);
    whole.retain(|k, _| k.ends_with(".npz"));
    assert_eq!(whole.len(), 6);
    assert_eq!(tree(&sharded), whole);
    let again = data.with_extension("q2.jsonl");
    batch(o, &["--report", again.to_str().unwrap()]);
    let lines = report_lines(&again);
    assert_eq!(
        lines.iter().filter(|l| l["status"] == "skipped").count(),
        6,
        "{lines:?}"
    );
    cleanup(&data);
}

#[test]
fn a_query_batch_takes_given_points_and_refuses_what_it_cannot_do_before_reading_a_model() {
    let (data, _) = dataset("qpoints", 1);
    let d = data.to_str().unwrap();
    // Given points: an (N, 3) float64 .npy of 4 points, the same for every model.
    let points = data.with_extension("p.npy");
    let mut npy = b"\x93NUMPY\x01\x00".to_vec();
    let mut header = "{'descr': '<f8', 'fortran_order': False, 'shape': (4, 3), }".to_string();
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    npy.extend_from_slice(&(header.len() as u16).to_le_bytes());
    npy.extend_from_slice(header.as_bytes());
    for x in [
        0.5f64, 0.5, 0.5, 9.0, 9.0, 9.0, 0.1, 0.2, 0.3, -4.0, 0.0, 0.0,
    ] {
        npy.extend_from_slice(&x.to_le_bytes());
    }
    std::fs::write(&points, npy).unwrap();
    let out = data.with_extension("pout");
    let run = gregvox(
        &[
            "batch",
            &format!("{d}/gen"),
            "--query-points",
            points.to_str().unwrap(),
            "--out-dir",
            out.to_str().unwrap(),
        ],
        &[],
    );
    assert!(run.status.success(), "{run:?}");
    let files = tree(&out);
    assert_eq!(files.len(), 1, "{:?}", files.keys());
    let (name, bytes) = files.iter().next().unwrap();
    assert_eq!(name, "cube000.npz");
    // winding and occupancy (the default with given points), no drawn points.
    for (member, present) in [
        ("winding.npy", true),
        ("occupancy.npy", true),
        ("points.npy", false),
    ] {
        assert_eq!(
            bytes.windows(member.len()).any(|w| w == member.as_bytes()),
            present,
            "{member}"
        );
    }
    let o = out.to_str().unwrap();
    for (extra, says) in [
        (
            vec!["--query", "uniform:10", "--what", "colour"],
            "--what colour",
        ),
        (
            vec!["--query", "uniform:10", "--closest"],
            "--closest needs sdf or udf",
        ),
        (vec!["--query", "sideways:10"], "--sample sideways:10"),
        (vec!["--what", "sdf", "--res", "8"], "need --query"),
        (
            vec!["--query", "uniform:10", "--name", "{stem}_{res}.npz"],
            "no grid",
        ),
        (vec![], "give the grid size"),
    ] {
        let mut a = vec!["batch", d, "--out-dir", o];
        a.extend_from_slice(&extra);
        let run = gregvox(&a, &[]);
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(
            !run.status.success() && err.contains(says),
            "{extra:?}: {err}"
        );
    }
    assert_eq!(tree(&out).len(), 1, "nothing more written");
    cleanup(&data);
}
