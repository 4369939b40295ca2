//! Suite `writers`: every grid format encoded from a 1024³ grid (256³ with `--quick`), and the same bytes
//! written to a file, against the goal of ≥ 1 G voxels/s of encoding.
//!
//! Invariants: the grids are made here, not voxelized (the suite measures the writers alone): a solid ball
//! (the friendly case: long runs, whole words of one value) and hashed noise with about one voxel in three
//! solid (the attack on run-length coding and on any per-word shortcut: every word mixed, a run every
//! 1.5 voxels, binvox's worst case at twice the voxel count in bytes). Encode = the format's bytes in
//! memory (`voxel::export::*_bytes`, or the bit-axis change and cast for `.raw`); write = the whole
//! `write_grid` call to a file in the temporary folder (encoding, the temporary file, the rename; the
//! sidecar), which is removed afterwards. `.vox` holds at most 256³ per model and is measured at 256³.
//! Table `boundary` measures the solid's boundary mesh (`.obj`/`.stl`/`.glb`/`.ply` with `--ply-boundary`)
//! on the ball and on the noise, whose every voxel is on the boundary. Table `level_set` measures the
//! narrow-band level set (`--what sdf`) against OpenVDB's own `createLevelSetFromPolygons`
//! (`bench/peers/levelset_peer.py`, Debian's `python3-openvdb`) on the bunny, the bunny with a third of its
//! triangles removed and one 100,000-gon (the attack on per-triangle work).
use super::{median, num, BenchConfig, Report, Table};
use crate::voxel::export::{
    binvox_bytes, npy_bytes, npy_packed_bytes, nrrd_bytes, vox_bytes, write_grid, SaveOptions,
};
use crate::voxel::grid::{Axis, GridFrame, VoxelGrid};
use rayon::prelude::*;
use serde_json::Value;
use std::time::Instant;

/// A solid ball filling the grid's inscribed sphere, bits along z (the voxelizers' usual axis).
fn ball(res: u32) -> VoxelGrid {
    let mut g = VoxelGrid::empty(GridFrame::cubic(res, [0.0; 3], 1.0), Axis::Z);
    let w = g.frame.words_per_column(Axis::Z) as usize;
    let c = res as f64 / 2.0;
    g.words
        .par_chunks_mut(w * res as usize)
        .enumerate()
        .for_each(|(y, plane)| {
            for (x, col) in plane.chunks_mut(w).enumerate() {
                let d2 = (x as f64 + 0.5 - c).powi(2) + (y as f64 + 0.5 - c).powi(2);
                let r2 = (0.45 * res as f64).powi(2) - d2;
                if r2 <= 0.0 {
                    continue;
                }
                let h = r2.sqrt();
                let (z0, z1) = ((c - h).ceil().max(0.0) as u32, ((c + h) as u32).min(res));
                for z in z0..z1 {
                    col[z as usize / 32] |= 1 << (z % 32);
                }
            }
        });
    g
}

/// Hashed noise, about one voxel in three solid, bits along z.
fn noise(res: u32) -> VoxelGrid {
    let mut g = VoxelGrid::empty(GridFrame::cubic(res, [0.0; 3], 1.0), Axis::Z);
    g.words.par_iter_mut().enumerate().for_each(|(i, w)| {
        let mut x = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x2545_F491_4F6C_DD1D;
        x ^= x >> 29;
        x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x ^= x >> 32;
        // a & b of two uniform words: a quarter; | a sparse third word: about a third.
        let (a, b, c) = (x as u32, (x >> 32) as u32, (x as u32).rotate_left(13));
        *w = (a & b) | (c & a.rotate_left(7) & b.rotate_left(19));
    });
    // Clear the bits past z = res in each column's last word (none when res is a multiple of 32).
    let rem = res % 32;
    if rem != 0 {
        let w = g.frame.words_per_column(Axis::Z) as usize;
        for col in g.words.chunks_mut(w) {
            col[w - 1] &= (1u32 << rem) - 1;
        }
    }
    g
}

/// Median milliseconds of `repeats` runs of `f` (its result dropped outside the clock), and its size.
fn time_bytes(repeats: usize, mut f: impl FnMut() -> usize) -> (f64, usize) {
    let mut times = Vec::new();
    let mut size = 0;
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        size = f();
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    (median(&times), size)
}

/// The encoders by format: bytes of `g` in memory.
fn encode(format: &str, g: &VoxelGrid) -> Vec<u8> {
    match format {
        "binvox" => binvox_bytes(g),
        "npy" => npy_bytes(g),
        "npy (packed)" => npy_packed_bytes(g),
        "nrrd" => nrrd_bytes(g),
        "raw" => bytemuck::cast_slice(&g.to_axis(Axis::Z).words).to_vec(),
        "vox" => vox_bytes(g),
        "vdb" => crate::voxel::vdb::vdb_bytes(g),
        _ => unreachable!("formats listed below"),
    }
}

/// Runs the suite.
pub fn run(cfg: &BenchConfig, report: &mut Report) -> anyhow::Result<()> {
    let out_dir =
        std::env::temp_dir().join(format!("gregvox-bench-writers-{}", std::process::id()));
    let res = if cfg.quick { 256 } else { 1024 };
    let repeats = if cfg.quick { 1 } else { 3 };
    let mut t = Table::new(
        "writers",
        &format!("Grid writers: encoding and writing a {res}³ grid (goal ≥ 1 G voxels/s of encoding)"),
        &format!(
            "Encode = the format's bytes in memory; write = the whole write_grid call to a file (encode, \
             temporary file, rename, sidecar), median of {repeats}. G voxels/s = voxels / encode time. \
             ball = a solid ball (long runs); noise = hashed noise, about one voxel in three solid (every \
             word mixed: a run every 1.5 voxels, binvox's worst case). .vox holds at most 256³ per model \
             and is measured at 256³. All {} rayon threads.",
            rayon::current_num_threads()
        ),
        &[
            "grid", "format", "res", "encode ms", "G voxels/s", "write ms", "MB", "write MB/s",
        ],
    );
    std::fs::create_dir_all(&out_dir)?;
    for (name, make) in [("ball", ball as fn(u32) -> VoxelGrid), ("noise", noise)] {
        let big = make(res);
        let small = make(res.min(256));
        for format in ["binvox", "npy", "npy (packed)", "nrrd", "raw", "vdb", "vox"] {
            let g = if format == "vox" { &small } else { &big };
            let voxels = g.frame.voxel_count() as f64;
            let (enc, bytes) = time_bytes(repeats, || encode(format, g).len());
            let ext = format.split(' ').next().unwrap_or(format);
            let path = out_dir.join(format!("writers-{name}.{ext}"));
            let opts = SaveOptions {
                npy_packed: format == "npy (packed)",
                ..Default::default()
            };
            let (write, _) = time_bytes(repeats, || {
                write_grid(g, &path, &opts).map(|_| 0).unwrap_or(usize::MAX)
            });
            let _ = std::fs::remove_file(&path);
            let _ = std::fs::remove_file(crate::voxel::export::sidecar_path(&path));
            let mb = bytes as f64 / 1e6;
            t.push(vec![
                Value::from(name),
                Value::from(format),
                Value::from(g.frame.dims[0]),
                num(enc),
                num(voxels / (enc * 1e-3) / 1e9),
                num(write),
                num(mb),
                num(mb / (write * 1e-3)),
            ]);
            eprintln!(
                "gregvox bench: writers {name} {format}: encode {enc:.1} ms, write {write:.1} ms"
            );
        }
    }
    report.tables.push(t);
    boundary(cfg, report, &out_dir)?;
    level_set(cfg, report, &out_dir)?;
    let _ = std::fs::remove_dir_all(&out_dir);
    Ok(())
}

/// Table `boundary`: the solid's boundary mesh (`voxel::boundary`) of the ball at 1024³ (256³ quick) and
/// of the noise at 128³ (32³ quick; its 1024³ is past the quad limit and measured as the refusal), built
/// and written as binary PLY.
fn boundary(
    cfg: &BenchConfig,
    report: &mut Report,
    out_dir: &std::path::Path,
) -> anyhow::Result<()> {
    use crate::voxel::boundary::boundary_mesh;
    let repeats = if cfg.quick { 1 } else { 3 };
    let (ball_res, noise_res, refused_res) = if cfg.quick {
        (256, 32, 1024)
    } else {
        (1024, 128, 1024)
    };
    let mut t = Table::new(
        "boundary",
        "The solid's boundary mesh: closed, manifold, outward quads of the voxel faces",
        &format!(
            "build = boundary_mesh (boundary lattice points by whole words, the sheet table, quads by rows), \
             write = the whole .ply (--ply-boundary) write_grid call, median of {repeats}. ball = a solid \
             ball (the friendly case); noise = hashed noise, a third solid (every voxel on the boundary, \
             corners split everywhere: the attack); noise {refused_res}³ = past the {} quad limit, refused \
             after the popcount pass. All {} rayon threads.",
            crate::voxel::boundary::MAX_BOUNDARY_QUADS,
            rayon::current_num_threads()
        ),
        &[
            "grid", "res", "quads", "vertices", "build ms", "M quads/s", "write ms", "MB",
        ],
    );
    for (name, make, res) in [
        ("ball", ball as fn(u32) -> VoxelGrid, ball_res),
        ("noise", noise, noise_res),
    ] {
        let g = make(res);
        let mut size = (0, 0);
        let (build, _) = time_bytes(repeats, || {
            let m = boundary_mesh(&g).expect("under the quad limit");
            size = (m.n_faces(), m.positions.len());
            0
        });
        let path = out_dir.join(format!("boundary-{name}.ply"));
        let opts = SaveOptions {
            ply_boundary: true,
            ..Default::default()
        };
        let (write, _) = time_bytes(repeats, || {
            write_grid(&g, &path, &opts)
                .map(|_| 0)
                .unwrap_or(usize::MAX)
        });
        let mb = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0) as f64 / 1e6;
        let _ = std::fs::remove_file(&path);
        t.push(vec![
            Value::from(name),
            Value::from(res),
            Value::from(size.0),
            Value::from(size.1),
            num(build),
            num(size.0 as f64 / (build * 1e-3) / 1e6),
            num(write),
            num(mb),
        ]);
        eprintln!(
            "gregvox bench: boundary {name} {res}³: build {build:.1} ms, write {write:.1} ms"
        );
    }
    let g = noise(refused_res);
    let (refuse, _) = time_bytes(repeats, || boundary_mesh(&g).map(|_| 0).unwrap_or(1));
    t.push(vec![
        Value::from("noise (refused)"),
        Value::from(refused_res),
        Value::Null,
        Value::Null,
        num(refuse),
        Value::Null,
        Value::Null,
        Value::Null,
    ]);
    report.tables.push(t);
    Ok(())
}

/// Table `level_set`: `voxelize --what sdf` as the library runs it (voxelization, then the band's exact
/// distances and the file's bytes) against OpenVDB's mesh-to-level-set at the same voxels.
fn level_set(
    cfg: &BenchConfig,
    report: &mut Report,
    out_dir: &std::path::Path,
) -> anyhow::Result<()> {
    use super::peers::{self, Peer};
    use crate::api::{levelset::level_set, voxelize_on_cpu, Mesh, VoxelizeOptions};
    use crate::voxel::mesh::TriMesh;
    use crate::voxel::stress::{obj_text, with_holes};
    let res = if cfg.quick { 64 } else { 256 };
    let repeats = if cfg.quick { 1 } else { 3 };
    let half_width = crate::voxel::levelset::HALF_WIDTH;
    let bunny = crate::mesh::load_mesh_file(cfg.model("stanford-bunny.obj")?)?;
    let holes = with_holes(&TriMesh::fan(&bunny), 1.0 / 3.0, 3);
    let as_mesh = |t: &TriMesh| -> anyhow::Result<Mesh> {
        let faces: Vec<Vec<u32>> = t.triangles.iter().map(|f| f.to_vec()).collect();
        let p = t
            .positions
            .iter()
            .map(|p| glam::DVec3::from(p.map(f64::from)))
            .collect();
        Ok(Mesh::from_polygons(p, &faces)?)
    };
    let cases: Vec<(&str, Mesh)> = vec![
        ("stanford-bunny", bunny.clone()),
        ("bunny_holes_third", as_mesh(&holes)?),
        (
            "disc (one 100,000-gon)",
            super::simplify::disc(if cfg.quick { 10_000 } else { 100_000 }),
        ),
    ];
    let mut t = Table::new(
        "level_set",
        &format!("Narrow-band level sets (--what sdf, half-width {half_width}) vs OpenVDB, {res}³"),
        &format!(
            "gregvox: voxelize = voxelize_on_cpu (the exact generalized winding number: the sign); \
             level set = api::levelset::level_set (seeds sampled on the triangles, dilation, exact distances of the band \
             within the half-width) + the .vdb bytes; total = both. OpenVDB = \
             FloatGrid.createLevelSetFromPolygons at the same voxel centres (exact band distances, sign \
             by flood fill: meant for closed meshes), its own threading, through Debian's python3-openvdb \
             (bench/peers/levelset_peer.py). Medians of {repeats}; speed-up = OpenVDB / gregvox total. \
             Active voxels differ where the two bands' edges differ (OpenVDB keeps |d| < half-width·h \
             where its sweep reaches)."
        ),
        &[
            "mesh", "faces", "voxelize ms", "level set ms", "total ms", "active", "OpenVDB ms",
            "OpenVDB active", "speed-up",
        ],
    );
    let openvdb = std::process::Command::new("/usr/bin/python3")
        .args(["-c", "import pyopenvdb"])
        .output()
        .is_ok_and(|o| o.status.success());
    for (name, mesh) in cases {
        let opts = VoxelizeOptions::default().res(res);
        let mut v = None;
        let (vox, _) = time_bytes(repeats, || {
            v = voxelize_on_cpu(&mesh, &opts).ok();
            0
        });
        let Some(v) = v else {
            anyhow::bail!("level_set bench: {name} did not voxelize");
        };
        let mut active = 0;
        let (ls_ms, _) = time_bytes(repeats, || {
            let ls = level_set(&mesh, &v.grid, half_width).expect("within the band limit");
            active = ls.active_count();
            crate::voxel::vdb::level_set_bytes(&ls).len()
        });
        let obj = out_dir.join("level-set-peer.obj");
        let tri = TriMesh::fan(&mesh);
        std::fs::write(&obj, obj_text(&tri))?;
        let f = &v.grid.frame;
        let peer = if openvdb {
            peers::run_within(
                std::path::Path::new("/usr/bin/python3"),
                &[
                    cfg.repo
                        .join("bench/peers/levelset_peer.py")
                        .display()
                        .to_string(),
                    obj.display().to_string(),
                    f.voxel_size[0].to_string(),
                    format!("{},{},{}", f.origin[0], f.origin[1], f.origin[2]),
                    half_width.to_string(),
                    repeats.to_string(),
                ],
                Some(std::time::Duration::from_secs(300)),
            )
        } else {
            Peer::Missing("Debian's python3-openvdb".into())
        };
        let (peer_ms, peer_active) = match &peer {
            Peer::Ran(v) => (
                v.first()
                    .and_then(|o| o["seconds"].as_f64())
                    .map(|s| s * 1e3),
                v.first().and_then(|o| o["active"].as_u64()),
            ),
            _ => (None, None),
        };
        let total = vox + ls_ms;
        t.push(vec![
            Value::from(name),
            Value::from(mesh.n_faces()),
            num(vox),
            num(ls_ms),
            num(total),
            Value::from(active),
            peer_ms
                .map(num)
                .unwrap_or_else(|| Value::from(peer.status())),
            peer_active.map(Value::from).unwrap_or(Value::Null),
            super::speedup(peer_ms, total),
        ]);
        eprintln!(
            "gregvox bench: level_set {name}: voxelize {vox:.1} ms, level set {ls_ms:.1} ms, OpenVDB {}",
            peer_ms.map_or(peer.status(), |m| format!("{m:.1} ms"))
        );
    }
    report.tables.push(t);
    Ok(())
}
