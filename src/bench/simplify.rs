//! Suite `simplify`: mesh reduction against meshoptimizer (`meshopt_simplify` through the meshopt crate,
//! `examples/meshopt_peer.rs`), fast-simplification and pyfqmr, at 50 %, 10 % and 1 % of the triangles,
//! speed and quality in one run.
//!
//! Invariants: every reducer gets the same OBJ; gregvox's time is one whole `api::simplify` call (the
//! triangulation, the locks, the quadrics and the passes) on all rayon threads, the peers' their reducing
//! call (meshoptimizer on one thread: it has no threaded simplifier); quality is measured by an
//! independent script (`tests/oracle/simplify_quality.py`: trimesh area-weighted samples plus vertices,
//! libigl point–triangle distances, both directions) as the symmetric Hausdorff and the mean distance in
//! percent of the input's diagonal. The meshes: the bunny; (full run) the bunny after two Loop levels
//! (1.1 M triangles); a CAD-like block (flat faces finely tessellated, a cylinder boss: large flat
//! regions and sharp creases); a gregvox voxel surface (the bunny voxelized at 96³ by the CPU scanline,
//! every exposed voxel face two triangles: staircases, and non-manifold edges where voxels touch along
//! an edge only, which gregvox locks); the Utah teapot (unwelded along its patches' boundaries: 662
//! vertices share a position, seams that both reducers collapse along, both sides together); and the
//! attacks: one 100,000-gon (a fan vertex of valence
//! 100,000; 20,000 with `--quick`) and the bunny as an unwelded noisy soup (every triangle its own
//! piece: nothing may collapse, and finding that out must be cheap).
use super::peers::{self, Peer};
use super::{median, num, BenchConfig, Report, Table};
use crate::api::{simplify, Mesh, SimplifyOptions};
use crate::mesh::{load_mesh_file, loop_subdivide, write_obj, LoopBeta};
use crate::voxel::cpu::{voxelize_cpu, FillRule};
use crate::voxel::grid::{Axis, GridFrame};
use crate::voxel::mesh::TriMesh;
use glam::DVec3;
use serde_json::Value;
use std::collections::HashMap;
use std::time::Instant;

/// A box of `n` × `n` quads a face, with a cylinder of `seg` segments standing on its top (a separate
/// closed piece that touches it): flat regions, sharp creases, long thin cylinder-wall triangles.
pub fn cad_block(n: u32, seg: u32) -> Mesh {
    let mut positions: Vec<DVec3> = Vec::new();
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut faces: Vec<Vec<u32>> = Vec::new();
    let mut vid = |p: DVec3, positions: &mut Vec<DVec3>| -> u32 {
        let key = (p * 1e6).round().as_i64vec3().to_array();
        *index.entry(key).or_insert_with(|| {
            positions.push(p);
            positions.len() as u32 - 1
        })
    };
    // The six faces of [0, 2] × [0, 2] × [0, 1], each an n × n grid, outward.
    let size = DVec3::new(2.0, 2.0, 1.0);
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for j in 0..n {
                for i in 0..n {
                    let corner = |di: u32, dj: u32| {
                        let mut p = DVec3::ZERO;
                        p[axis] = side * size[axis];
                        p[u] = (i + di) as f64 / n as f64 * size[u];
                        p[v] = (j + dj) as f64 / n as f64 * size[v];
                        p
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                    let mut ids: Vec<u32> = q.iter().map(|&p| vid(p, &mut positions)).collect();
                    if side == 0.0 {
                        ids.reverse();
                    }
                    faces.push(vec![ids[0], ids[1], ids[2]]);
                    faces.push(vec![ids[0], ids[2], ids[3]]);
                }
            }
        }
    }
    // The boss: a cylinder of radius 0.5 and height 0.5 on the top face's centre (its own vertices).
    let base = positions.len() as u32;
    let rings = 8;
    for r in 0..=rings {
        for s in 0..seg {
            let a = std::f64::consts::TAU * s as f64 / seg as f64;
            positions.push(DVec3::new(
                1.0 + 0.5 * a.cos(),
                1.0 + 0.5 * a.sin(),
                1.0 + 0.5 * r as f64 / rings as f64,
            ));
        }
    }
    let at = |r: u32, s: u32| base + r * seg + s % seg;
    for r in 0..rings {
        for s in 0..seg {
            faces.push(vec![at(r, s), at(r, s + 1), at(r + 1, s + 1)]);
            faces.push(vec![at(r, s), at(r + 1, s + 1), at(r + 1, s)]);
        }
    }
    let (bottom, top) = (positions.len() as u32, positions.len() as u32 + 1);
    positions.push(DVec3::new(1.0, 1.0, 1.0));
    positions.push(DVec3::new(1.0, 1.0, 1.5));
    for s in 0..seg {
        faces.push(vec![bottom, at(0, s + 1), at(0, s)]);
        faces.push(vec![top, at(rings, s), at(rings, s + 1)]);
    }
    Mesh::from_polygons(positions, &faces).expect("a valid block")
}

/// One polygon of `n` corners on the unit circle (its fan vertex has valence n: the attack on per-vertex
/// work).
pub fn disc(n: u32) -> Mesh {
    let ring: Vec<DVec3> = (0..n)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            DVec3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    Mesh::from_polygons(ring, &[(0..n).collect()]).expect("a valid polygon")
}

/// The exposed faces of a voxel grid as triangles, corners welded on the lattice.
pub fn voxel_surface(tri: &TriMesh, res: u32) -> Mesh {
    let (lo, hi) = tri.positions.iter().fold(
        ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
        |(lo, hi), p| {
            (
                std::array::from_fn(|a| lo[a].min(p[a])),
                std::array::from_fn(|a| hi[a].max(p[a])),
            )
        },
    );
    let side = (0..3).map(|a| (hi[a] - lo[a]) as f64).fold(0.0, f64::max) * 1.02;
    let origin = std::array::from_fn(|a| lo[a] as f64 - 0.01 * side);
    let frame = GridFrame::cubic(res, origin, side);
    let g = voxelize_cpu(tri, &frame, Axis::Z, FillRule::Winding);
    let h = side / res as f64;
    let solid = |i: i64, j: i64, k: i64| {
        i >= 0
            && j >= 0
            && k >= 0
            && i < res as i64
            && j < res as i64
            && k < res as i64
            && g.get(i as u32, j as u32, k as u32)
    };
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    for i in 0..res as i64 {
        for j in 0..res as i64 {
            for k in 0..res as i64 {
                if !solid(i, j, k) {
                    continue;
                }
                for axis in 0..3 {
                    for dir in [-1i64, 1] {
                        let mut n = [i, j, k];
                        n[axis] += dir;
                        if solid(n[0], n[1], n[2]) {
                            continue;
                        }
                        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                        let mut ids = Vec::with_capacity(4);
                        for (du, dv) in [(0, 0), (1, 0), (1, 1), (0, 1)] {
                            let mut c = [i, j, k];
                            c[axis] += (dir + 1) / 2;
                            c[u] += du;
                            c[v] += dv;
                            let id = *index.entry(c).or_insert_with(|| {
                                positions.push(DVec3::new(
                                    origin[0] + c[0] as f64 * h,
                                    origin[1] + c[1] as f64 * h,
                                    origin[2] + c[2] as f64 * h,
                                ));
                                positions.len() as u32 - 1
                            });
                            ids.push(id);
                        }
                        if dir < 0 {
                            ids.reverse();
                        }
                        faces.push(vec![ids[0], ids[1], ids[2]]);
                        faces.push(vec![ids[0], ids[2], ids[3]]);
                    }
                }
            }
        }
    }
    Mesh::from_polygons(positions, &faces).expect("a valid voxel surface")
}

/// `repeats` (at least one) `api::simplify` calls reducing `mesh` to `ratio` with the default options: the
/// median wall time in ms and the last output (the bench's gregvox column; `examples/simplify_profile.rs`).
pub fn timed_simplify(
    mesh: &Mesh,
    ratio: f64,
    repeats: usize,
) -> anyhow::Result<(f64, crate::api::SimplifiedMesh)> {
    let opts = SimplifyOptions {
        ratio: Some(ratio),
        ..Default::default()
    };
    let mut times = Vec::new();
    let mut out = None;
    for _ in 0..repeats.max(1) {
        let t0 = Instant::now();
        out = Some(simplify(mesh, &opts)?);
        times.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    Ok((median(&times), out.expect("one repeat")))
}

/// Runs the suite.
pub fn run(cfg: &BenchConfig, report: &mut Report) -> anyhow::Result<()> {
    let repeats = if cfg.quick { 1 } else { 3 };
    let ratios: &[f64] = if cfg.quick {
        &[0.5, 0.1]
    } else {
        &[0.5, 0.1, 0.01]
    };
    let bunny = load_mesh_file(cfg.model("stanford-bunny.obj")?)?;
    let mut cases: Vec<(&str, Mesh)> = Vec::new();
    if cfg.quick {
        cases.push(("spot", load_mesh_file(cfg.model("spot.obj")?)?));
        cases.push(("cad_block", cad_block(24, 64)));
        cases.push(("one 20,000-gon (fan)", disc(20_000)));
    } else {
        cases.push(("stanford-bunny", bunny.clone()));
        cases.push((
            "bunny_loop2 (1.1 M)",
            loop_subdivide(&bunny, 2, LoopBeta::Warren)?,
        ));
        cases.push(("cad_block", cad_block(96, 256)));
        cases.push((
            "bunny voxel surface 96³",
            voxel_surface(&TriMesh::fan(&bunny), 96),
        ));
        // Unwelded along its Bézier patches' boundaries: 662 vertices share a position with another. gregvox
        // reduces such seams both sides together and locks the 192 copies where three or more patches meet;
        // meshoptimizer collapses along seams too.
        cases.push((
            "teapot (unwelded patches: seams)",
            load_mesh_file(cfg.model("teapot.obj")?)?,
        ));
        cases.push(("one 100,000-gon (fan)", disc(100_000)));
        let soup = crate::voxel::stress::soup(&TriMesh::fan(&bunny), 1e-7, 5);
        cases.push((
            "bunny soup (unwelded, noisy)",
            crate::mesh::parse_obj(&crate::voxel::stress::obj_text(&soup), "soup.obj")?,
        ));
    }
    let dir = std::env::temp_dir().join(format!("gregvox-bench-simplify-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let threads = rayon::current_num_threads();
    let mut t = Table::new(
        "simplify",
        "Mesh reduction vs meshoptimizer, fast-simplification and pyfqmr (speed and quality, same run)",
        &format!(
            "Each reducer gets the same OBJ and the same triangle target. gregvox: one api::simplify call \
             (optimal placement, the defaults), median of {repeats}, {threads} rayon threads; \
             meshoptimizer: meshopt_simplify without error limit (examples/meshopt_peer.rs, one thread: it \
             has none other), fast-simplification and pyfqmr (aggressiveness 7, borders kept) as their \
             users call them (bench/peers/simplify_peers.py); best of {repeats}. Hausdorff and mean: \
             symmetric distances in % of the input's diagonal, by tests/oracle/simplify_quality.py \
             (trimesh samples, libigl distances). H ratio = gregvox Hausdorff / meshoptimizer's (goal \
             ≤ 1.1); speed = meshoptimizer ms / gregvox ms (goal ≥ 1). faces = triangles reached (a \
             reducer that keeps its guarantees may stop above the target). The fan rows have no distances \
             (every query of the oracle visits every sliver: hours), only speed and counts."
        ),
        &[
            "mesh",
            "triangles",
            "ratio",
            "gregvox ms",
            "gregvox faces",
            "gregvox Hausdorff %",
            "gregvox mean %",
            "meshopt ms",
            "meshopt faces",
            "meshopt Hausdorff %",
            "meshopt mean %",
            "speed vs meshopt",
            "H ratio",
            "fast-simplification ms / Hausdorff %",
            "pyfqmr ms / Hausdorff %",
        ],
    );
    for (name, mesh) in &cases {
        let input = dir.join("input.obj");
        write_obj(&input, mesh)?;
        let list = ratios
            .iter()
            .map(|r| r.to_string())
            .collect::<Vec<_>>()
            .join(",");
        let meshopt = peers::run(
            &cfg.peers.join("meshopt_peer"),
            &[
                input.display().to_string(),
                list.clone(),
                "--out".into(),
                dir.display().to_string(),
                "--repeat".into(),
                repeats.to_string(),
            ],
        );
        let python = peers::python(
            &cfg.repo.join("bench/peers/simplify_peers.py"),
            &[
                input.display().to_string(),
                list.clone(),
                dir.display().to_string(),
                "--repeat".into(),
                repeats.to_string(),
            ],
        );
        let mut outputs = Vec::new();
        let mut ours = Vec::new();
        for &r in ratios {
            let (ms, out) = timed_simplify(mesh, r, repeats)?;
            let path = dir.join(format!("gregvox_{r}.obj"));
            write_obj(&path, &out.mesh)?;
            outputs.push(path.display().to_string());
            outputs.push(dir.join(format!("meshopt_{r}.obj")).display().to_string());
            outputs.push(
                dir.join(format!("fast-simplification_{r}.obj"))
                    .display()
                    .to_string(),
            );
            outputs.push(dir.join(format!("pyfqmr_{r}.obj")).display().to_string());
            ours.push((ms, out.report.faces));
        }
        // Quality of every output that exists, in one run of the oracle script.
        let present: Vec<String> = outputs
            .into_iter()
            .filter(|p| std::path::Path::new(p).is_file())
            .collect();
        let samples = if cfg.quick { "20000" } else { "200000" };
        let mut args = vec![input.display().to_string()];
        args.extend(present);
        args.extend(["--samples".to_string(), samples.to_string()]);
        // A fan of slivers around one vertex makes every distance query visit every triangle (the attack
        // works on the oracle's tree too: hours at 100,000 corners): its rows give speed and counts only.
        let quality = if name.contains("-gon") {
            Peer::Skipped("distances to a fan of slivers: every query visits every triangle".into())
        } else {
            peers::python(&cfg.repo.join("tests/oracle/simplify_quality.py"), &args)
        };
        let q = |file: &str| -> Option<(f64, f64)> {
            let Peer::Ran(v) = &quality else { return None };
            let want = dir.join(file).display().to_string();
            v.iter()
                .find(|o| o["mesh"].as_str() == Some(want.as_str()))
                .and_then(|o| Some((o["hausdorff"].as_f64()?, o["mean"].as_f64()?)))
        };
        let peer_row = |p: &Peer, peer: &str, r: f64| -> Option<(f64, u64)> {
            let Peer::Ran(v) = p else { return None };
            v.iter()
                .find(|o| o["peer"].as_str() == Some(peer) && o["ratio"].as_f64() == Some(r))
                .and_then(|o| Some((o["seconds"].as_f64()? * 1e3, o["faces"].as_u64()?)))
        };
        let status = |p: &Peer| Value::from(p.status());
        for (k, &r) in ratios.iter().enumerate() {
            let (ms, faces) = ours[k];
            let gq = q(&format!("gregvox_{r}.obj"));
            let mo = peer_row(&meshopt, "meshoptimizer", r);
            let mq = q(&format!("meshopt_{r}.obj"));
            let cell = |x: Option<f64>, p: &Peer| match (x, p) {
                (Some(x), _) => num(x),
                (None, Peer::Skipped(_)) => Value::from("–"),
                (None, p) => status(p),
            };
            let py = |peer: &str| match (peer_row(&python, peer, r), q(&format!("{peer}_{r}.obj")))
            {
                (Some((ms, _)), Some((h, _))) => Value::from(format!("{ms:.1} / {h:.3}")),
                (Some((ms, _)), None) => Value::from(format!("{ms:.1} / –")),
                _ => match &python {
                    Peer::Ran(v)
                        if v.iter().any(|o| {
                            o["peer"].as_str() == Some(peer) && o["missing"].is_string()
                        }) =>
                    {
                        Value::from(format!("peer not installed: run `{}`", peers::INSTALL))
                    }
                    p => status(p),
                },
            };
            t.push(vec![
                Value::from(*name),
                Value::from(mesh.fan_triangles().len()),
                num(r),
                num(ms),
                Value::from(faces),
                cell(gq.map(|x| x.0), &quality),
                cell(gq.map(|x| x.1), &quality),
                cell(mo.map(|x| x.0), &meshopt),
                mo.map(|x| Value::from(x.1))
                    .unwrap_or_else(|| status(&meshopt)),
                cell(mq.map(|x| x.0), &quality),
                cell(mq.map(|x| x.1), &quality),
                match mo {
                    Some((m, _)) => num(m / ms),
                    None => Value::from("–"),
                },
                match (gq, mq) {
                    (Some(g), Some(m)) if m.0 > 0.0 => num(g.0 / m.0),
                    _ => Value::from("–"),
                },
                py("fast-simplification"),
                py("pyfqmr"),
            ]);
            eprintln!(
                "gregvox bench: simplify {name} {r}: gregvox {ms:.1} ms ({faces} faces, quality {gq:?}), meshopt {mo:?} {mq:?}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    report.tables.push(t);
    Ok(())
}
