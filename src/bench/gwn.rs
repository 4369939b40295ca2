//! Suite `gwn`: the exact generalized winding number (`--rule gwn`, the default) as a whole `gregvox
//! voxelize` process on the stress suite (`voxel::stress`: holes by the thousand, an unwelded noisy soup,
//! open shells, a broken chair, the teapot) beside the bunny, against libigl's fast winding number at the
//! same voxel centres, measured in the same run; the soup against the same mesh welded; and closed meshes,
//! where the rule must be the winding rule bit for bit and cost nothing more.
//!
//! Invariants: every gregvox time is the wall time of the whole process (load, weld, cap, solid pass,
//! fractional term, nothing written), the median of alternating runs; libigl is `fast_winding_number` at
//! every voxel centre ≥ ½ with its own threading (`bench/peers/voxel_peers.py`, centres not timed). The
//! stress meshes are written afresh into a temporary folder and removed afterwards.
use super::peers::{self, Peer};
use super::{median, num, speedup, BenchConfig, Report, Table};
use crate::mesh::load_mesh_file;
use crate::voxel::grid::GridFrame;
use crate::voxel::mesh::TriMesh;
use crate::voxel::stress::{obj_text, suite};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One whole `gregvox voxelize FILE --res R …` process: (wall ms, its --json).
fn voxelize_process(file: &Path, res: u32, extra: &[&str]) -> anyhow::Result<(f64, Value)> {
    let exe = std::env::current_exe()?;
    let start = Instant::now();
    let out = std::process::Command::new(exe)
        .arg("voxelize")
        .arg(file)
        .args(["--res", &res.to_string(), "--json"])
        .args(extra)
        .env("GREGVOX_VALIDATION", "0")
        .output()?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    if !out.status.success() {
        anyhow::bail!(
            "gregvox voxelize {} {extra:?} failed: {}",
            file.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok((ms, serde_json::from_slice(&out.stdout)?))
}

/// libigl's fast winding number at the centres of gregvox's --res `res` grid over `file`.
fn libigl(cfg: &BenchConfig, file: &Path, res: u32) -> anyhow::Result<Peer> {
    libigl_within(cfg, file, res, None)
}

/// As [`libigl`], killed after `limit`.
fn libigl_within(
    cfg: &BenchConfig,
    file: &Path,
    res: u32,
    limit: Option<std::time::Duration>,
) -> anyhow::Result<Peer> {
    let tri = TriMesh::fan(&load_mesh_file(file)?);
    let used: Vec<[f32; 3]> = tri
        .triangles
        .iter()
        .flat_map(|t| t.map(|v| tri.positions[v as usize]))
        .collect();
    let frame = GridFrame::from_points(&used, res)?;
    let mut args = vec![file.display().to_string(), res.to_string()];
    args.extend(frame.origin.iter().map(|o| format!("{o:.17e}")));
    args.push(format!("{:.17e}", frame.voxel_size[0]));
    args.push("1".into());
    args.push("--no-trimesh".into());
    Ok(peers::python_within(
        &cfg.repo.join("bench/peers/voxel_peers.py"),
        &args,
        limit,
    ))
}

fn peer_number(peer: &Peer, key: &str) -> Option<f64> {
    match peer {
        Peer::Ran(v) => v.first().and_then(|o| o[key].as_f64()),
        _ => None,
    }
}

/// Runs suite `gwn`.
pub fn run(cfg: &BenchConfig, report: &mut Report) -> anyhow::Result<()> {
    let dir = std::env::temp_dir().join(format!("gregvox-bench-gwn-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let result = tables(cfg, report, &dir);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn tables(cfg: &BenchConfig, report: &mut Report, dir: &Path) -> anyhow::Result<()> {
    let bunny_file = cfg.model("stanford-bunny.obj")?;
    let bunny = TriMesh::fan(&load_mesh_file(&bunny_file)?);
    let teapot = TriMesh::fan(&load_mesh_file(&cfg.model("teapot.obj")?)?);
    let mut cases: Vec<(String, PathBuf, String)> = vec![(
        "stanford-bunny".into(),
        bunny_file.clone(),
        "the bunny as shipped: 5 holes".into(),
    )];
    for case in suite(&bunny, &teapot) {
        let file = dir.join(format!("{}.obj", case.name));
        std::fs::write(&file, obj_text(&case.mesh))?;
        cases.push((case.name.into(), file, case.what.into()));
    }
    let resolutions: &[u32] = if cfg.quick { &[64] } else { &[128, 256] };
    let repeats = if cfg.quick { 1 } else { 3 };
    let mut t = Table::new(
        "gwn_stress",
        "Exact generalized winding number on broken meshes: whole process vs libigl fast winding number",
        &format!(
            "gregvox ms = wall time of the whole `gregvox voxelize MESH --res R --json` process (default \
             options: --rule gwn, method auto), median of {repeats} runs. libigl = fast_winding_number ≥ 0.5 \
             at the same voxel centres (an approximation with no error bound; all cores; the centres are not \
             timed; bench/peers/voxel_peers.py). speed-up = libigl / gregvox. Stress meshes: \
             src/voxel/stress.rs (seeded). The counts come from the run's --json (`gwn`): boxes = boxes and \
             cells bounded, one by one = voxels of cells evaluated one at a time, direct = voxels near the \
             surface or left undecided (exact crossing count + the tree at the point), plain = voxels only \
             the plain sum over the mesh decided."
        ),
        &[
            "mesh",
            "triangles",
            "loops",
            "res",
            "gregvox ms",
            "libigl fwn ms",
            "speed-up",
            "gregvox solid",
            "libigl solid",
            "boxes",
            "one by one",
            "direct",
            "plain",
        ],
    );
    let mut times: std::collections::BTreeMap<(String, u32), f64> = Default::default();
    for (name, file, _) in &cases {
        for &res in resolutions {
            eprintln!("gregvox bench: gwn {name} {res}³");
            let mut ms = Vec::new();
            let mut json = Value::Null;
            for _ in 0..repeats {
                let (m, j) = voxelize_process(file, res, &[])?;
                ms.push(m);
                json = j;
            }
            let g = median(&ms);
            times.insert((name.clone(), res), g);
            eprintln!("gregvox bench: gwn libigl {name} {res}³");
            let peer = libigl(cfg, file, res)?;
            let igl_ms = peer_number(&peer, "igl_s").map(|s| s * 1e3);
            let stage = |k: &str| json["gwn"][k].clone();
            t.push(vec![
                name.clone().into(),
                json["triangles"].clone(),
                stage("loops_capped"),
                res.into(),
                num(g),
                igl_ms.map(num).unwrap_or_else(|| peer.status().into()),
                speedup(igl_ms, g),
                json["solid_voxels"].clone(),
                peer_number(&peer, "igl_solid")
                    .map(|x| (x as u64).into())
                    .unwrap_or(Value::Null),
                stage("boxes_evaluated"),
                stage("voxels_evaluated"),
                stage("direct_voxels"),
                stage("plain_sums"),
            ]);
        }
    }
    report.tables.push(t);
    let mut soup = Table::new(
        "gwn_soup_vs_welded",
        "The unwelded noisy soup against the same mesh welded",
        "bunny_soup: every triangle of the bunny its own three vertices, ±1e-7 noise on each coordinate; \
         welded: the bunny as shipped. Whole processes, the times of the table above. The weld (within a \
         512th of a voxel) closes the seams and thin ribbons carry the noise, so the soup costs what the \
         bunny costs plus the ribbons.",
        &["res", "soup ms", "welded ms", "soup / welded"],
    );
    for &res in resolutions {
        let (s, w) = (
            times[&("bunny_soup".to_string(), res)],
            times[&("stanford-bunny".to_string(), res)],
        );
        soup.push(vec![res.into(), num(s), num(w), num(s / w)]);
    }
    report.tables.push(soup);
    worst_table(cfg, report, dir, &cases)?;
    closed_table(cfg, report, dir, repeats)
}

/// Table `gwn_worst`: the inputs that attack the cost model, one whole process each: two loops of half a
/// million edges (huge caps, and w = ½ on both end discs: every voxel near them decided one by one), and
/// thousands of holes at 1024³ (the per-voxel work grows with the surface's voxels).
fn worst_table(
    cfg: &BenchConfig,
    report: &mut Report,
    dir: &Path,
    cases: &[(String, PathBuf, String)],
) -> anyhow::Result<()> {
    let mut t = Table::new(
        "gwn_worst",
        "The generalized winding number's worst cases",
        "One whole `gregvox voxelize MESH --res R --json` process each (default options). open_tube: a \
         cylinder open at both ends, two boundary loops of half the triangle count each (each cap one \
         polygon of that many sides; w is ½ on both end discs); open_tube_soup: a smaller tube as an unwelded \
         soup (±1e-7 noise), beside open_tube_welded, the same tube as it is: every ribbon is as long as the \
         tube, so no expansion of theirs converges and their bounds add up near the end discs (an open worst \
         case: at 20,000 segments and 128³ the soup took 263 s against 0.64 s welded, the same grid, on \
         2026-12-08); bunny_holes_5pct at a high resolution: the voxels evaluated one by one grow with the \
         surface's voxel count. libigl = fast_winding_number ≥ 0.5 \
         at the same centres where it runs in reasonable time (not at 1024³: 10⁹ centres), killed after \
         120 s (5 s with --quick): `> ms (killed)`, and the speed-up is then a lower bound.",
        &[
            "mesh",
            "triangles",
            "loops",
            "res",
            "gregvox ms",
            "libigl fwn ms",
            "speed-up",
            "boxes",
            "one by one",
            "direct",
        ],
    );
    let (segments, tube_res, holes_res) = if cfg.quick {
        (20_000, 32, 128)
    } else {
        (500_000, 128, 1024)
    };
    let tube = dir.join("open_tube.obj");
    std::fs::write(&tube, obj_text(&crate::voxel::stress::open_tube(segments)))?;
    let small_segments = if cfg.quick { 500 } else { 2000 };
    let small_tube = crate::voxel::stress::open_tube(small_segments);
    let (welded, soup) = (
        dir.join("open_tube_welded.obj"),
        dir.join("open_tube_soup.obj"),
    );
    std::fs::write(&welded, obj_text(&small_tube))?;
    std::fs::write(
        &soup,
        obj_text(&crate::voxel::stress::soup(&small_tube, 1e-7, 5)),
    )?;
    let holes = cases
        .iter()
        .find(|c| c.0 == "bunny_holes_5pct")
        .map(|c| c.1.clone())
        .ok_or_else(|| anyhow::anyhow!("the stress suite has no bunny_holes_5pct"))?;
    for (name, file, res, peer) in [
        ("open_tube", tube, tube_res, true),
        ("open_tube_welded", welded, tube_res, true),
        ("open_tube_soup", soup, tube_res, true),
        ("bunny_holes_5pct", holes, holes_res, false),
    ] {
        eprintln!("gregvox bench: gwn worst case {name} {res}³");
        let (ms, json) = voxelize_process(&file, res, &[])?;
        // libigl's tree struggles too on the tube (minutes at 128³): it gets a time limit, and the row
        // says what it reached.
        let limit = std::time::Duration::from_secs(if cfg.quick { 5 } else { 120 });
        let (igl_ms, igl_cell) = if peer {
            eprintln!("gregvox bench: gwn worst case libigl {name} {res}³");
            let p = libigl_within(cfg, &file, res, Some(limit))?;
            let ms = peer_number(&p, "igl_s").map(|s| s * 1e3);
            let cell: Value = match (&p, ms) {
                (_, Some(ms)) => num(ms),
                (Peer::Failed(e), None) if e.contains("did not finish") => {
                    format!("> {} (killed)", limit.as_millis()).into()
                }
                (p, None) => p.status().into(),
            };
            (ms, cell)
        } else {
            let why = if res >= 1024 { " (10⁹ centres)" } else { "" };
            (None, format!("not run{why}").into())
        };
        let stage = |k: &str| json["gwn"][k].clone();
        t.push(vec![
            name.into(),
            json["triangles"].clone(),
            stage("loops_capped"),
            res.into(),
            num(ms),
            igl_cell.clone(),
            match (&igl_cell, igl_ms) {
                (Value::String(s), None) if s.contains("killed") => {
                    format!("> {:.3}", limit.as_secs_f64() * 1e3 / ms).into()
                }
                _ => speedup(igl_ms, ms),
            },
            stage("boxes_evaluated"),
            stage("voxels_evaluated"),
            stage("direct_voxels"),
        ]);
    }
    report.tables.push(t);
    Ok(())
}

/// Closed meshes: `--rule gwn` against `--rule winding` (one axis), whole processes, outputs compared byte
/// for byte.
fn closed_table(
    cfg: &BenchConfig,
    report: &mut Report,
    dir: &Path,
    repeats: usize,
) -> anyhow::Result<()> {
    let res: u32 = if cfg.quick { 64 } else { 256 };
    let mut t = Table::new(
        "gwn_closed",
        "Closed meshes: the generalized winding number is the winding rule, at its cost",
        &format!(
            "Whole `gregvox voxelize MESH --res {res} --out X.npy` processes, median of {repeats} runs, \
             alternating: --rule gwn (default) and --rule winding --axes 1. same = the two .npy files are \
             byte for byte equal."
        ),
        &["mesh", "res", "gwn ms", "winding ms", "gwn / winding", "same"],
    );
    for m in ["spot.obj", "cow.obj"] {
        let file = cfg.model(m)?;
        let (a, b) = (dir.join("gwn.npy"), dir.join("winding.npy"));
        let (mut g, mut w) = (Vec::new(), Vec::new());
        for _ in 0..repeats {
            let out = a.display().to_string();
            g.push(voxelize_process(&file, res, &["--out", &out])?.0);
            let out = b.display().to_string();
            w.push(
                voxelize_process(
                    &file,
                    res,
                    &["--rule", "winding", "--axes", "1", "--out", &out],
                )?
                .0,
            );
        }
        let same = std::fs::read(&a)? == std::fs::read(&b)?;
        let (g, w) = (median(&g), median(&w));
        t.push(vec![
            m.trim_end_matches(".obj").into(),
            res.into(),
            num(g),
            num(w),
            num(g / w),
            same.into(),
        ]);
    }
    report.tables.push(t);
    Ok(())
}
