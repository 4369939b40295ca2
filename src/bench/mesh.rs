//! Suite `mesh`: vertex normals and one subdivision level on the bunny (and, in the full run, the bunny after
//! two Loop levels: 1.1 M triangles), gregvox (CPU, one thread) beside libigl and trimesh measured by
//! tests/oracle/bench_mesh_peers.py in the same run.
//!
//! Invariants: gregvox's figures are the same operations as benches/mesh.rs (`normals`, `loop_level`,
//! `cc_level`); each row pairs an operation with the peer operation the script names (its docstring says what
//! each peer computes); neither libigl nor trimesh has Catmull–Clark, so that row has no peer and says so.
use super::peak::Peak;
use super::peers::{self, Peer};
use super::{num, speedup, time_cpu, BenchConfig, Report, Table};
use crate::mesh::{
    catmull_clark_matrix, load_mesh_file, loop_matrix, loop_subdivide, LoopBeta, MeshMatrix,
    NormalWeighting,
};
use serde_json::Value;

/// Floor model of AREA vertex normals per face: ~20 flops (cross product, three scatter-adds); bytes: three
/// u32 indices, three f64 positions gathered and three f64 normals scattered.
pub const NORMALS_FLOPS_PER_FACE: f64 = 20.0;
pub const NORMALS_BYTES_PER_FACE: f64 = 12.0 + 3.0 * 24.0 + 3.0 * 24.0;
/// Floor model of S·P per non-zero: 3 FMA (6 flops); bytes: column u32 + value f64 + the gathered f64 point.
pub const SPMV_FLOPS_PER_NNZ: f64 = 6.0;
pub const SPMV_BYTES_PER_NNZ: f64 = 4.0 + 8.0 + 24.0;

/// Runs the suite.
pub fn run(cfg: &BenchConfig, peak: Option<&Peak>, report: &mut Report) -> anyhow::Result<()> {
    let bunny = load_mesh_file(cfg.model("stanford-bunny.obj")?)?;
    let mut meshes = vec![("bunny", bunny.clone())];
    if !cfg.quick {
        meshes.push(("bunny_loop2", loop_subdivide(&bunny, 2, LoopBeta::Warren)?));
    }
    // The peer script takes minutes (trimesh's Loop on 1.1 M faces alone is over a minute): full run only.
    let peer = if cfg.quick {
        Peer::Skipped("--quick (the peer script takes minutes)".into())
    } else {
        let out = std::env::temp_dir().join(format!(
            "gregvox-bench-mesh-peers-{}.json",
            std::process::id()
        ));
        eprintln!("gregvox bench: mesh peers (libigl, trimesh) …");
        let p = peers::python(
            &cfg.repo.join("tests/oracle/bench_mesh_peers.py"),
            &[
                "--repeat".into(),
                "1".into(),
                "--json".into(),
                out.display().to_string(),
            ],
        );
        let p = match p {
            Peer::Ran(_) => match std::fs::read_to_string(&out)
                .ok()
                .and_then(|s| serde_json::from_str::<Value>(&s).ok())
            {
                Some(Value::Array(v)) => Peer::Ran(v),
                _ => Peer::Failed(format!("{} was not written", out.display())),
            },
            other => other,
        };
        let _ = std::fs::remove_file(out);
        p
    };
    let peer_ms = |mesh: &str, op: &str| -> Option<f64> {
        match &peer {
            Peer::Ran(v) => v
                .iter()
                .find(|r| r["mesh"] == mesh && r["op"] == op)
                .and_then(|r| r["seconds"].as_f64())
                .map(|s| s * 1e3),
            _ => None,
        }
    };
    let mut t = Table::new(
        "mesh_peers",
        "Mesh kernels (CPU) vs libigl and trimesh",
        &format!(
            "gregvox: median of {} runs (single thread, as the peers); peers: tests/oracle/bench_mesh_peers.py (`--repeat 1`: one run after a warm-up on the bunny, median of 2 on 1.1 M faces; \
             one process), same meshes (the peers drop the bunny's 1,113 unreferenced vertices). speed-up = peer / \
             gregvox. Floor = max(flops, bytes) at the measured peaks (normals: {NORMALS_FLOPS_PER_FACE} flops, \
             {NORMALS_BYTES_PER_FACE} B per face; S·P: {SPMV_FLOPS_PER_NNZ} flops, {SPMV_BYTES_PER_NNZ} B per \
             non-zero).",
            cfg.repeats
        ),
        &[
            "mesh",
            "faces",
            "gregvox operation",
            "gregvox ms",
            "floor ms",
            "peer operation",
            "peer ms",
            "speed-up",
        ],
    );
    for (name, mesh) in &meshes {
        let m = MeshMatrix::from_mesh(mesh);
        let faces = m.n_faces();
        let normals = time_cpu(cfg.repeats, || {
            m.vertex_normals(&mesh.positions, NormalWeighting::Area)
        });
        let lp = loop_matrix(&m, LoopBeta::Warren)?;
        let loop_ms = time_cpu(cfg.repeats.min(5), || {
            loop_matrix(&m, LoopBeta::Warren).map(|s| s.s.spmv(&mesh.positions))
        });
        let cc = catmull_clark_matrix(&m);
        let cc_ms = time_cpu(cfg.repeats.min(5), || {
            catmull_clark_matrix(&m).s.spmv(&mesh.positions)
        });
        let cc_spmv = time_cpu(cfg.repeats, || cc.s.spmv(&mesh.positions));
        let floor = |elements: f64, f: f64, b: f64| {
            peak.map(|p| num(p.floor_ms(elements, f, b)))
                .unwrap_or(Value::Null)
        };
        let nf = faces as f64;
        let rows: Vec<(&str, f64, Value, &str)> = vec![
            (
                "AREA vertex normals",
                normals,
                floor(nf, NORMALS_FLOPS_PER_FACE, NORMALS_BYTES_PER_FACE),
                "normals/libigl per_vertex_normals (AREA)",
            ),
            (
                "AREA vertex normals",
                normals,
                floor(nf, NORMALS_FLOPS_PER_FACE, NORMALS_BYTES_PER_FACE),
                "normals/trimesh vertex_normals (ANGLE)",
            ),
            (
                "one Loop level (build S + S·P)",
                loop_ms,
                floor(lp.s.nnz() as f64, SPMV_FLOPS_PER_NNZ, SPMV_BYTES_PER_NNZ),
                "subdivide/libigl loop (Warren)",
            ),
            (
                "one Loop level (build S + S·P)",
                loop_ms,
                floor(lp.s.nnz() as f64, SPMV_FLOPS_PER_NNZ, SPMV_BYTES_PER_NNZ),
                "subdivide/trimesh subdivide_loop (Loop beta)",
            ),
            (
                "one Catmull–Clark level (build S + S·P)",
                cc_ms,
                floor(cc.s.nnz() as f64, SPMV_FLOPS_PER_NNZ, SPMV_BYTES_PER_NNZ),
                "",
            ),
            (
                "Catmull–Clark S·P only (deforming cage)",
                cc_spmv,
                floor(cc.s.nnz() as f64, SPMV_FLOPS_PER_NNZ, SPMV_BYTES_PER_NNZ),
                "",
            ),
        ];
        for (op, ms, fl, peer_op) in rows {
            let (po, pm): (Value, Value) = if peer_op.is_empty() {
                (
                    "none (neither libigl nor trimesh has Catmull–Clark)".into(),
                    Value::Null,
                )
            } else {
                match peer_ms(name, peer_op) {
                    Some(p) => (peer_op.into(), num(p)),
                    None => (peer_op.into(), peer.status().into()),
                }
            };
            let sp = if peer_op.is_empty() {
                Value::Null
            } else {
                speedup(peer_ms(name, peer_op), ms)
            };
            t.push(vec![
                (*name).into(),
                faces.into(),
                op.into(),
                num(ms),
                fl,
                po,
                pm,
                sp,
            ]);
        }
    }
    report.tables.push(t);
    Ok(())
}
