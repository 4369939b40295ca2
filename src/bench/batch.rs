//! Suite `batch`: `gregvox batch` over a folder of mixed models against one `gregvox voxelize` process per
//! model (what a dataset script looping over a voxelizer does), with `--method peel` and with the default
//! method, whole processes, measured in one run.
//!
//! Invariants:
//! - The folder is generated afresh in the output folder: the vendored models, UV spheres and boxes of
//!   several sizes as OBJ, ASCII STL and ASCII PLY in nested folders, four broken files, and the `.mtl` and
//!   texture files datasets carry; at least 200 models in full mode.
//! - Both ways write the same outputs (.binvox) into fresh folders; the batch runs with `--no-resume`.
//!   The per-model loop skips nothing and counts the models it could not voxelize, as the batch does.
//! - Table `batch_broken_fifth` runs `gregvox batch` over one folder of closed spheres and over the same
//!   folder with every fifth model broken (alternately a quarter of its triangles removed, and an unwelded
//!   soup with ±1e-7 noise on every vertex): the generalized winding number's cost on broken models must not
//!   dominate a dataset's throughput (the goal: within 1.5× of the closed folder).
use super::{num, BenchConfig, Report, Table};
use crate::voxel::mesh::TriMesh;
use crate::voxel::stress;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A UV sphere (`n` segments, `n / 2` rings) of radius `r` at `c` as positions and triangles.
fn sphere(n: usize, r: f32, c: [f32; 3]) -> (Vec<[f32; 3]>, Vec<[usize; 3]>) {
    let rings = (n / 2).max(2);
    let mut v = vec![[c[0], c[1], c[2] + r]];
    for i in 1..rings {
        let t = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..n {
            let p = 2.0 * std::f32::consts::PI * j as f32 / n as f32;
            v.push([
                c[0] + r * t.sin() * p.cos(),
                c[1] + r * t.sin() * p.sin(),
                c[2] + r * t.cos(),
            ]);
        }
    }
    v.push([c[0], c[1], c[2] - r]);
    let south = v.len() - 1;
    let at = |i: usize, j: usize| 1 + (i - 1) * n + j % n;
    let mut f = Vec::new();
    for j in 0..n {
        f.push([0, at(1, j), at(1, j + 1)]);
        f.push([south, at(rings - 1, j + 1), at(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..n {
            f.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            f.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    (v, f)
}

fn write_obj(path: &Path, v: &[[f32; 3]], f: &[[usize; 3]]) -> std::io::Result<()> {
    let mut s = String::from("mtllib m.mtl\n");
    for p in v {
        let _ = writeln!(s, "v {} {} {}", p[0], p[1], p[2]);
    }
    for t in f {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(path, s)
}

fn write_stl(path: &Path, v: &[[f32; 3]], f: &[[usize; 3]]) -> std::io::Result<()> {
    let mut s = String::from("solid s\n");
    for t in f {
        s.push_str("facet normal 0 0 0\nouter loop\n");
        for &k in t {
            let _ = writeln!(s, "vertex {} {} {}", v[k][0], v[k][1], v[k][2]);
        }
        s.push_str("endloop\nendfacet\n");
    }
    s.push_str("endsolid s\n");
    std::fs::write(path, s)
}

fn write_ply(path: &Path, v: &[[f32; 3]], f: &[[usize; 3]]) -> std::io::Result<()> {
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        v.len(),
        f.len()
    );
    for p in v {
        let _ = writeln!(s, "{} {} {}", p[0], p[1], p[2]);
    }
    for t in f {
        let _ = writeln!(s, "3 {} {} {}", t[0], t[1], t[2]);
    }
    std::fs::write(path, s)
}

/// Writes the benchmark's model folder into `dir`; returns the number of models (broken ones included).
pub fn dataset(cfg: &BenchConfig, dir: &Path, generated: usize) -> anyhow::Result<usize> {
    let _ = std::fs::remove_dir_all(dir);
    let mut count = 0;
    for m in [
        "spot.obj",
        "cow.obj",
        "teapot.obj",
        "suzanne.obj",
        "stanford-bunny.obj",
    ] {
        std::fs::create_dir_all(dir.join("vendored"))?;
        std::fs::copy(cfg.model(m)?, dir.join("vendored").join(m))?;
        count += 1;
    }
    for i in 0..generated {
        let sub = dir.join(format!("gen/{:02}", i / 50));
        std::fs::create_dir_all(&sub)?;
        let n = [8, 16, 32, 64, 96][i % 5];
        let (v, f) = sphere(n, 0.5 + 0.01 * i as f32, [0.1 * i as f32, 0.0, 0.0]);
        match i % 3 {
            0 => write_obj(&sub.join(format!("m{i:04}.obj")), &v, &f)?,
            1 => write_stl(&sub.join(format!("m{i:04}.stl")), &v, &f)?,
            _ => write_ply(&sub.join(format!("m{i:04}.ply")), &v, &f)?,
        }
        count += 1;
        if i % 50 == 0 {
            std::fs::write(
                sub.join("m.mtl"),
                "newmtl a\nKd 0.8 0.8 0.8\nmap_Kd t.png\n",
            )?;
            std::fs::write(sub.join("t.png"), [0x89u8, b'P', b'N', b'G', 0, 0])?;
        }
    }
    let broken = dir.join("broken");
    std::fs::create_dir_all(&broken)?;
    std::fs::write(
        broken.join("index.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
    )?;
    std::fs::write(broken.join("empty.stl"), b"")?;
    std::fs::write(
        broken.join("truncated.ply"),
        "ply\nformat ascii 1.0\nelement vertex 9\n",
    )?;
    std::fs::write(
        broken.join("nan.off"),
        "OFF\n3 1 0\nnan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    )?;
    Ok(count + 4)
}

fn mesh_files(dir: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = walk(dir)
        .into_iter()
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| ["obj", "stl", "ply", "off"].contains(&e))
        })
        .collect();
    out.sort();
    out
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        if let Ok(rd) = std::fs::read_dir(&d) {
            for e in rd.flatten() {
                let p = e.path();
                if p.is_dir() {
                    stack.push(p);
                } else {
                    out.push(p);
                }
            }
        }
    }
    out
}

/// Runs suite `batch`.
pub fn run(cfg: &BenchConfig, report: &mut Report) -> anyhow::Result<()> {
    let exe = std::env::current_exe()?;
    let out = std::env::temp_dir().join(format!("gregvox-bench-batch-{}", std::process::id()));
    let dir = out.join("batch-models");
    let models = dataset(cfg, &dir, if cfg.quick { 20 } else { 200 })?;
    let files = mesh_files(&dir);
    let res = if cfg.quick { "32" } else { "64" };
    let mut t = Table::new(
        "batch_vs_per_model",
        "gregvox batch vs one gregvox voxelize process per model",
        &format!(
            "{models} models ({} vendored, the rest generated UV spheres of 8–96 segments as OBJ, STL and PLY \
             in nested folders, 4 broken; .mtl and .png files beside them), --res {res}, .binvox outputs. \
             batch = the whole `gregvox batch DIR --out-dir … --no-resume` process; per model = a loop of \
             `gregvox voxelize FILE --out …` processes (a dataset script's loop). Validation off. \
             speed-up = per model / batch.",
            5
        ),
        &[
            "method",
            "models",
            "batch s",
            "batch models/s",
            "per-model s",
            "per-model models/s",
            "speed-up",
            "failed",
        ],
    );
    for method in ["peel", "auto"] {
        eprintln!("gregvox bench: batch --method {method}");
        let target = out.join(format!("batch-out-{method}"));
        let _ = std::fs::remove_dir_all(&target);
        let start = Instant::now();
        let o = std::process::Command::new(&exe)
            .arg("batch")
            .arg(&dir)
            .args(["--res", res, "--method", method, "--no-resume", "--json"])
            .arg("--out-dir")
            .arg(&target)
            .env("GREGVOX_VALIDATION", "0")
            .output()?;
        let batch_s = start.elapsed().as_secs_f64();
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap_or_default();
        let loop_dir = out.join(format!("batch-loop-{method}"));
        let _ = std::fs::remove_dir_all(&loop_dir);
        std::fs::create_dir_all(&loop_dir)?;
        eprintln!("gregvox bench: per-model voxelize --method {method}");
        let start = Instant::now();
        let mut loop_failed = 0;
        for (i, f) in files.iter().enumerate() {
            let s = std::process::Command::new(&exe)
                .arg("voxelize")
                .arg(f)
                .args(["--res", res, "--method", method, "--out"])
                .arg(loop_dir.join(format!("{i}.binvox")))
                .env("GREGVOX_VALIDATION", "0")
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .status()?;
            if !s.success() {
                loop_failed += 1;
            }
        }
        let loop_s = start.elapsed().as_secs_f64();
        let _ = std::fs::remove_dir_all(&loop_dir);
        let _ = std::fs::remove_dir_all(&target);
        t.push(vec![
            method.into(),
            files.len().into(),
            num(batch_s),
            num(files.len() as f64 / batch_s),
            num(loop_s),
            num(files.len() as f64 / loop_s),
            num(loop_s / batch_s),
            format!("{} / {loop_failed}", j["failed"]).into(),
        ]);
    }
    report.tables.push(t);
    report.tables.push(broken_fifth(cfg, &exe, &out)?);
    let _ = std::fs::remove_dir_all(&out);
    Ok(())
}

/// Writes `count` closed UV spheres (32 to 128 segments) as OBJ into `dir`; with `broken`, every fifth is
/// broken (alternately a quarter of its triangles removed and an unwelded soup). Returns the broken count.
pub fn sphere_folder(dir: &Path, count: usize, broken: bool) -> anyhow::Result<usize> {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir)?;
    let mut broken_count = 0;
    for i in 0..count {
        let n = [32, 48, 64, 96, 128][(i / 5) % 5];
        let (v, f) = sphere(n, 0.5, [0.0; 3]);
        let (v, f) = if broken && i % 5 == 0 {
            broken_count += 1;
            let mesh = TriMesh {
                positions: v,
                triangles: f.iter().map(|t| t.map(|k| k as u32)).collect(),
            };
            let bad = if (i / 5) % 2 == 0 {
                stress::with_holes(&mesh, 0.25, 0x5eed + i as u64)
            } else {
                stress::soup(&mesh, 1e-7, 0x5eed + i as u64)
            };
            let f = bad
                .triangles
                .iter()
                .map(|t| t.map(|k| k as usize))
                .collect();
            (bad.positions, f)
        } else {
            (v, f)
        };
        write_obj(&dir.join(format!("m{i:04}.obj")), &v, &f)?;
    }
    Ok(broken_count)
}

/// Table `batch_broken_fifth`: whole `gregvox batch` processes over a closed folder and the same folder with
/// a fifth of its models broken.
fn broken_fifth(cfg: &BenchConfig, exe: &Path, out: &Path) -> anyhow::Result<Table> {
    let count = if cfg.quick { 10 } else { 100 };
    let res = if cfg.quick { "32" } else { "64" };
    let mut t = Table::new(
        "batch_broken_fifth",
        "gregvox batch: a fifth of the models broken vs all closed",
        &format!(
            "{count} UV spheres (32–128 segments, OBJ); `broken`: every fifth model has a quarter of its \
             triangles removed or is an unwelded soup (±1e-7 noise), alternately. Whole `gregvox batch DIR \
             --res {res} --out-dir … --no-resume --report R` processes with the default rule (gwn) and \
             method; slowest model from the report's per-model `seconds` (its own work). ratio = broken \
             folder / closed folder (goal ≤ 1.5)."
        ),
        &[
            "folder",
            "models",
            "broken",
            "batch s",
            "models/s",
            "slowest model s",
            "ratio",
        ],
    );
    let mut closed_s = f64::NAN;
    for broken in [false, true] {
        let name = if broken { "broken" } else { "closed" };
        let dir = out.join(format!("fifth-{name}"));
        let broken_count = sphere_folder(&dir, count, broken)?;
        let target = out.join(format!("fifth-out-{name}"));
        let report_path = out.join(format!("fifth-{name}.jsonl"));
        let _ = std::fs::remove_dir_all(&target);
        let _ = std::fs::remove_file(&report_path);
        eprintln!("gregvox bench: batch over the {name} folder");
        let start = Instant::now();
        let o = std::process::Command::new(exe)
            .arg("batch")
            .arg(&dir)
            .args(["--res", res, "--no-resume", "--json"])
            .arg("--out-dir")
            .arg(&target)
            .arg("--report")
            .arg(&report_path)
            .env("GREGVOX_VALIDATION", "0")
            .output()?;
        let seconds = start.elapsed().as_secs_f64();
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap_or_default();
        anyhow::ensure!(
            o.status.success() && j["failed"] == 0,
            "batch over {} failed: {}",
            dir.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        let slowest = std::fs::read_to_string(&report_path)
            .unwrap_or_default()
            .lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .filter_map(|r| r["seconds"].as_f64())
            .fold(0.0, f64::max);
        if !broken {
            closed_s = seconds;
        }
        t.push(vec![
            name.into(),
            count.into(),
            broken_count.into(),
            num(seconds),
            num(count as f64 / seconds),
            num(slowest),
            num(seconds / closed_s),
        ]);
        let _ = std::fs::remove_dir_all(&target);
        let _ = std::fs::remove_dir_all(&dir);
    }
    Ok(t)
}
