//! Suite `mesh`: vertex normals and one subdivision level on the bunny (and, in the full run, the bunny after
//! two Loop levels: 1.1 M triangles), gregvox (CPU, one thread) beside libigl and trimesh measured by
//! tests/oracle/bench_mesh_peers.py in the same run; then the same normals and Catmull–Clark S·P on the
//! device (`engine::mesh`: the evaluator the device uses, and both evaluators where both run) against that
//! CPU code, in the same run.
//!
//! Invariants: gregvox's figures are the same operations as benches/mesh.rs (`normals`, `loop_level`,
//! `cc_level`); each row pairs an operation with the peer operation the script names (its docstring says what
//! each peer computes); neither libigl nor trimesh has Catmull–Clark, so that row has no peer and says so.
use super::peak::Peak;
use super::peers::{self, Peer};
use super::{num, speedup, time_cpu, time_gpu, BenchConfig, Report, Table};
use crate::engine::evaluator::Evaluator;
use crate::engine::mesh::{point_buffer, DeviceNormals, DeviceSpmv};
use crate::gpu::profiler::scoped;
use crate::gpu::Context;
use crate::mesh::host_kernels::KernelCounts;
use crate::mesh::{
    catmull_clark_matrix, load_mesh_file, loop_matrix, loop_subdivide, LoopBeta, MeshMatrix,
    NormalWeighting,
};
use ash::vk;
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
            "gregvox: median of {} runs (single thread, as the peers); peers: tests/oracle/bench_mesh_peers.py (`--repeat 1`: one run after a warm-up on the bunny, median of 2 on 1.1 M faces;              one process), same meshes (the peers drop the bunny's 1,113 unreferenced vertices). speed-up = peer /              gregvox. Floor = max(flops, bytes) at the measured peaks (normals: {NORMALS_FLOPS_PER_FACE} flops,              {NORMALS_BYTES_PER_FACE} B per face; S·P: {SPMV_FLOPS_PER_NNZ} flops, {SPMV_BYTES_PER_NNZ} B per              non-zero).",
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
    let mut cpu_ms = Vec::new();
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
        cpu_ms.push((name, normals, cc_spmv));
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
    let ctx = super::compute_context()?;
    let r = device(&ctx, cfg, peak, &meshes, &cpu_ms, report);
    super::finish_context(ctx)?;
    r
}

/// The device table: normals and S·P through `engine::mesh` on each evaluator, beside the CPU code's
/// times measured above (`cpu_ms`: mesh, normals ms, S·P ms).
fn device(
    ctx: &Context,
    cfg: &BenchConfig,
    peak: Option<&Peak>,
    meshes: &[(&str, crate::mesh::Mesh)],
    cpu_ms: &[(&&str, f64, f64)],
    report: &mut Report,
) -> anyhow::Result<()> {
    let evaluator = Evaluator::for_device(ctx)?;
    let both = ctx.info.device_type == "CPU";
    let mut t = Table::new(
        "mesh_device",
        "Mesh kernels on the device vs gregvox's CPU code",
        &format!(
            "device = engine::mesh::{{DeviceNormals, DeviceSpmv}}::evaluate on the evaluator this device uses \
             (Evaluator::for_device: the host kernels — f32, the shaders' operations, rayon over all cores — on \
             CPU devices, the Vulkan kernels elsewhere), wall clock per call (Vulkan: record + submit + wait), \
             median of {} calls; Vulkan kernel = the passes' timestamps (face + vertex kernels for normals), \
             measured where both run. CPU = gregvox's f64 single-thread code of the table above \
             (MeshMatrix::vertex_normals, SparseMatrix::spmv), same run. speed-up = CPU ms / device ms \
             (the aim: ≥ 1). flops and bytes are counted from the kernels' code \
             (mesh::host_kernels::KernelCounts: NormalsLayout::counts, spmv_counts); floor = max(flops / \
             FMA peak, bytes / bandwidth) at this run's peaks; % of FMA peak and % of bandwidth = the \
             device time's achieved rates over the peaks.",
            cfg.repeats
        ),
        &[
            "mesh",
            "faces",
            "operation",
            "device evaluator",
            "device ms",
            "Vulkan kernel ms",
            "Vulkan submission ms",
            "host kernels ms",
            "CPU ms",
            "speed-up vs CPU",
            "flops (code)",
            "bytes (code)",
            "floor ms",
            "% of FMA peak",
            "% of bandwidth",
        ],
    );
    for ((name, mesh), (_, cpu_normals, cpu_spmv)) in meshes.iter().zip(cpu_ms) {
        let m = MeshMatrix::from_mesh(mesh);
        let pts = crate::mesh::host_kernels::to_vec4(&mesh.positions);
        let s = catmull_clark_matrix(&m).s;
        // Per evaluator: [normals, S·P] wall ms, and (Vulkan) their timestamps.
        let mut runs: Vec<(Evaluator, [f64; 2], Option<[f64; 2]>)> = Vec::new();
        let mut counts = [KernelCounts::default(); 2];
        for e in [Evaluator::Vulkan, Evaluator::Host] {
            if e == Evaluator::Host && !both && evaluator != Evaluator::Host {
                continue;
            }
            let x = point_buffer(ctx, "bench positions", e, pts.len(), Some(&pts))?;
            let mut n = point_buffer(ctx, "bench normals", e, pts.len(), None)?;
            let mut y = point_buffer(ctx, "bench refined", e, s.n_rows as usize, None)?;
            let mut dn = DeviceNormals::new(ctx, &m, e)?;
            let ds = DeviceSpmv::new(ctx, &s, e)?;
            counts = [dn.counts(), ds.counts()];
            let normals_ms = time_cpu(cfg.repeats, || {
                dn.evaluate(ctx, &x, &mut n)
                    .expect("normals of a checked mesh")
            });
            let spmv_ms = time_cpu(cfg.repeats, || {
                ds.evaluate(ctx, &x, &mut y)
                    .expect("S·P of a checked matrix")
            });
            let stamps = if e == Evaluator::Vulkan {
                let stamp =
                    |name: &str, record: &dyn Fn(vk::CommandBuffer) -> crate::Result<()>| {
                        time_gpu(ctx, 1, cfg.repeats, |cmd, mut prof| {
                            scoped(ctx, cmd, &mut prof, name, || record(cmd))
                        })
                        .map(|t| t.pass(name))
                    };
                Some([
                    stamp("normals", &|cmd| dn.record(ctx, cmd, &x, &n))?,
                    stamp("spmv", &|cmd| ds.record(ctx, cmd, &x, &y))?,
                ])
            } else {
                None
            };
            runs.push((e, [normals_ms, spmv_ms], stamps));
        }
        for (op, cpu, k) in [
            ("AREA vertex normals", *cpu_normals, 0usize),
            ("Catmull–Clark S·P (one level)", *cpu_spmv, 1),
        ] {
            let ms = |e: Evaluator| runs.iter().find(|r| r.0 == e).map(|r| r.1[k]);
            let stamps = runs.iter().find_map(|r| r.2).map(|t| t[k]);
            let device_ms = ms(evaluator).expect("the device's evaluator ran");
            let (flops, bytes) = (counts[k].flops as f64, counts[k].bytes as f64);
            let rates = peak.map(|p| p.percent_of_peaks(flops, bytes, device_ms));
            t.push(vec![
                (*name).into(),
                m.n_faces().into(),
                op.into(),
                evaluator.label().into(),
                num(device_ms),
                stamps.map(num).unwrap_or(Value::Null),
                ms(Evaluator::Vulkan).map(num).unwrap_or(Value::Null),
                ms(Evaluator::Host)
                    .map(num)
                    .unwrap_or_else(|| "not used (GPU device)".into()),
                num(cpu),
                speedup(Some(cpu), device_ms),
                counts[k].flops.into(),
                counts[k].bytes.into(),
                peak.map(|p| num(p.floor_ms(1.0, flops, bytes)))
                    .unwrap_or(Value::Null),
                rates.map(|r| num(r.0)).unwrap_or(Value::Null),
                rates.map(|r| num(r.1)).unwrap_or(Value::Null),
            ]);
        }
    }
    report.tables.push(t);
    Ok(())
}
