//! Suite `gregory`: Gregory evaluation throughput (vertices/s from timestamps) on spot_quadrangulated, a
//! large cage (spot after one Catmull–Clark level) and a cage where half the vertices are extraordinary
//! ([`crate::engine::cage::icosphere_quad_cage`]), compute path vs vertex-pull path, beside OpenSubdiv's
//! CPU evaluation of the same samples on one thread and on all cores (bench/peers/osd_eval_bench.cpp) and
//! OpenSubdiv's GLComputeEvaluator on the same device family (bench/peers/osd_glcompute_bench.cpp); and (suite
//! `scaling`) time against the tessellation level 1…64.
//! - "compute" is the evaluator `GregorySurface` uses on the device ([`Evaluator::for_device`]): on a CPU
//!   device the host kernel (surface::gregory_host, wall clock of the evaluation alone), elsewhere the Vulkan
//!   kernel (timestamps); the Vulkan kernel is measured on every device, the host kernel on CPU devices.
//!
//! Invariants:
//! - Both gregvox paths evaluate the same (level+1)² samples per patch with position and normal (from both
//!   derivatives); OpenSubdiv evaluates the same samples with position and both derivatives. W·cage is not
//!   in either figure (OpenSubdiv's local points are likewise computed before timing).
//! - A size that exceeds a device limit is a row that says so: the compute path binds batches of patches, so
//!   one allocation (maxMemoryAllocationSize) bounds it; the vertex-pull path's capture buffer is one storage
//!   binding (maxStorageBufferRange).
//! - Uniform vs adaptive tessellation ([`adaptive`], in suite `gregory`): the whole chain is timed (the
//!   adaptive mode adds its level pass), and the vertices each mode produces are counted from the levels.
//! - Curvature ([`curvature`], in suite `gregory`): the curvature pass and the host curvature kernel on the
//!   same control points.
use super::peak::Peak;
use super::peers::{self, Peer};
use super::{num, speedup, time_cpu, time_gpu, BenchConfig, Curve, Report, Series, Table};
use crate::engine::gregory::{Evaluator, GregorySurface, GregoryTopology};
use crate::gpu::{Context, MemoryLocation, Profiler};
use crate::mesh::{catmull_clark, load_mesh_file, Mesh};
use crate::passes::gregory_eval::{vertex_count, GregoryEvalPass};
use crate::passes::patch_pull::PatchKind;
use crate::surface::{gregory_host, tessellate, GregoryStencils, Tangents};
use ash::vk;
use glam::DVec3;
use serde_json::Value;

/// The evaluation paths compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EvalPath {
    /// Compute shader into the device-local vertex buffer (`gregory_eval`).
    Compute,
    /// Instanced grid, evaluation in the vertex shader, captured to a buffer (`vertex_pull`).
    VertexPull,
}

impl EvalPath {
    /// Every path measured.
    pub const ALL: [EvalPath; 2] = [EvalPath::Compute, EvalPath::VertexPull];

    /// Column / series name.
    pub fn name(self) -> &'static str {
        match self {
            EvalPath::Compute => "compute",
            EvalPath::VertexPull => "vertex pull",
        }
    }
}

/// Median evaluation ms of `path` at `level` (timestamps of the evaluation pass only), or the limit hit.
pub fn time_path(
    ctx: &Context,
    topo: &GregoryTopology,
    cage: &[DVec3],
    level: u32,
    path: EvalPath,
    repeats: usize,
) -> anyhow::Result<Result<f64, String>> {
    let surface = match GregorySurface::new(ctx, topo, cage, level) {
        Ok(s) => s,
        Err(e @ crate::Error::Limit { .. }) => return Ok(Err(format!("{e}"))),
        Err(e) => return Err(e.into()),
    };
    let r = (|| -> anyhow::Result<f64> {
        match path {
            EvalPath::Compute => {
                // The evaluation pass alone in its own submission (the control points are computed once
                // before): on lavapipe, consecutive timestamp scopes in one command buffer can attribute a
                // dispatch's time to its neighbour, so the pass is timed by itself.
                ctx.one_shot(|cmd| surface.record(ctx, cmd, None, None))?;
                let eval = GregoryEvalPass::new(ctx)?;
                let ids: Vec<u32> = topo.patch_points.iter().flatten().copied().collect();
                let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
                let patch_points =
                    ctx.upload_buffer("bench patch points", bytemuck::cast_slice(&ids), storage)?;
                let patch_flags = ctx.upload_buffer(
                    "bench patch flags",
                    bytemuck::cast_slice(&topo.patch_flags),
                    storage,
                )?;
                let vertices = ctx.create_buffer(
                    "bench vertices",
                    vertex_count(surface.patch_count(), level) * 32,
                    storage,
                    MemoryLocation::GpuOnly,
                )?;
                let g = time_gpu(ctx, 2, repeats, |cmd, prof| {
                    let run = || {
                        eval.record(
                            ctx,
                            cmd,
                            surface.control_points(),
                            &patch_points,
                            &patch_flags,
                            surface.patch_count(),
                            level,
                            true,
                            &vertices,
                        )
                    };
                    match prof {
                        Some((p, slot)) => p.scope(ctx, cmd, slot, "gregory_eval", run),
                        None => run(),
                    }
                })?;
                Ok(g.pass("gregory_eval"))
            }
            EvalPath::VertexPull => {
                ctx.one_shot(|cmd| surface.record(ctx, cmd, None, None))?;
                let ids: Vec<u32> = topo.patch_points.iter().flatten().copied().collect();
                let pp = ctx.upload_buffer(
                    "bench patch points",
                    bytemuck::cast_slice(&ids),
                    vk::BufferUsageFlags::STORAGE_BUFFER,
                )?;
                let mut profiler = Profiler::new(ctx, 1, repeats as u32 + 8)?;
                // One untimed draw pays the pipeline JIT; the median of the next `repeats` is reported.
                crate::engine::vertex_pull::vertex_pull(
                    ctx,
                    PatchKind::Gregory,
                    surface.control_points(),
                    &pp,
                    surface.patch_count(),
                    level,
                    1 + repeats as u32,
                    &mut profiler,
                )
                .map_err(anyhow::Error::from)
                .map(|_| {
                    let mut times: Vec<f64> = profiler
                        .trace()
                        .iter()
                        .filter(|e| e.name == "vertex_pull")
                        .map(|e| e.duration_ns * 1e-6)
                        .collect();
                    if times.len() > 1 {
                        times.remove(0);
                    }
                    super::median(&times)
                })
            }
        }
    })();
    match r {
        Ok(ms) => Ok(Ok(ms)),
        Err(e) => match e.downcast_ref::<crate::Error>() {
            Some(crate::Error::Limit { .. }) => Ok(Err(format!("{e}"))),
            _ => Err(e),
        },
    }
}

/// Median ms of the host evaluator (surface::gregory_host, every core) at `level`, the control points computed
/// once before on the device: the evaluation alone, as the Vulkan kernel's timestamps time it alone.
pub fn time_host(
    ctx: &Context,
    topo: &GregoryTopology,
    cage: &[DVec3],
    level: u32,
    repeats: usize,
) -> anyhow::Result<Result<f64, String>> {
    let mut surface = match GregorySurface::with_evaluator(ctx, topo, cage, level, Evaluator::Host)
    {
        Ok(s) => s,
        Err(e @ crate::Error::Limit { .. }) => return Ok(Err(format!("{e}"))),
        Err(e) => return Err(e.into()),
    };
    surface.evaluate(ctx, None, None)?;
    Ok(Ok(time_cpu(repeats, || {
        surface
            .evaluate_host()
            .expect("host evaluation of a checked surface")
    })))
}

/// Runs the OpenSubdiv peer program `name` (`CAGE.obj REPEATS LEVEL...`, one JSON object per level).
fn run_osd_peer(
    cfg: &BenchConfig,
    name: &str,
    cage_obj: &std::path::Path,
    levels: &[u32],
    repeats: usize,
) -> Peer {
    let bin = cfg.peers.join(name);
    let mut args = vec![cage_obj.display().to_string(), repeats.to_string()];
    args.extend(levels.iter().map(|l| l.to_string()));
    if bin.is_file() {
        peers::run(&bin, &args)
    } else {
        Peer::Missing(format!("{} not built", bin.display()))
    }
}

/// OpenSubdiv's GLComputeEvaluator (bench/peers/osd_glcompute_bench.cpp) at `levels`: seconds per level, the
/// GL renderer, or why it did not run.
fn osd_gl(
    cfg: &BenchConfig,
    cage_obj: &std::path::Path,
    levels: &[u32],
    repeats: usize,
) -> (Peer, Vec<(u32, f64, String)>) {
    let peer = run_osd_peer(cfg, "osd_glcompute_bench", cage_obj, levels, repeats);
    let rows = match &peer {
        Peer::Ran(v) => v
            .iter()
            .filter_map(|o| {
                Some((
                    o["level"].as_u64()? as u32,
                    o["median_s"].as_f64()?,
                    o["renderer"].as_str().unwrap_or("?").to_string(),
                ))
            })
            .collect(),
        _ => Vec::new(),
    };
    (peer, rows)
}

/// OpenSubdiv's times at one level (seconds): one thread, and its best all-core evaluation.
struct OsdTimes {
    level: u32,
    single: f64,
    /// The faster of the threaded FindPatch + EvaluateBasis loop and `Osd::OmpEvaluator::EvalPatches`,
    /// with which one and the thread count.
    all_core: Option<(f64, String)>,
}

/// Runs OpenSubdiv's evaluation of `cage_obj` at `levels` (bench/peers/osd_eval_bench.cpp).
fn osd(
    cfg: &BenchConfig,
    cage_obj: &std::path::Path,
    levels: &[u32],
    repeats: usize,
) -> (Peer, Vec<OsdTimes>) {
    let peer = run_osd_peer(cfg, "osd_eval_bench", cage_obj, levels, repeats);
    let rows = match &peer {
        Peer::Ran(v) => v
            .iter()
            .filter_map(|o| {
                let threads = o["threads"].as_u64().unwrap_or(1);
                let candidates = [
                    (o["threads_median_s"].as_f64(), "threaded loop"),
                    (o["omp_median_s"].as_f64(), "OmpEvaluator"),
                ];
                let all_core = candidates
                    .iter()
                    .filter_map(|&(t, name)| Some((t?, format!("{name}, {threads} threads"))))
                    .min_by(|a, b| a.0.total_cmp(&b.0));
                Some(OsdTimes {
                    level: o["level"].as_u64()? as u32,
                    single: o["median_s"].as_f64()?,
                    all_core,
                })
            })
            .collect(),
        _ => Vec::new(),
    };
    (peer, rows)
}

fn topology(mesh: &Mesh) -> anyhow::Result<(GregoryTopology, Vec<DVec3>)> {
    let (t, c, _) = crate::engine::cage::cage_topology(mesh, Tangents::OpenSubdiv)?;
    Ok((t, c))
}

/// Runs the throughput table.
pub fn run(
    ctx: &Context,
    cfg: &BenchConfig,
    peak: Option<&Peak>,
    report: &mut Report,
) -> anyhow::Result<()> {
    let spot_path = cfg.model("spot_quadrangulated.obj")?;
    let spot = load_mesh_file(&spot_path)?;
    let mut cages: Vec<(String, Mesh, std::path::PathBuf, Vec<u32>)> = vec![(
        "spot_quadrangulated".into(),
        spot.clone(),
        spot_path,
        if cfg.quick {
            vec![4, 8]
        } else {
            vec![4, 8, 16, 32, 64]
        },
    )];
    let mut tmp_objs = Vec::new();
    if !cfg.quick {
        // Two more cages, each written as OBJ for the OSD peer: spot after one Catmull–Clark level (4× the
        // patches, EVs as sparse as spot's) and a cage where half the vertices are extraordinary (the
        // icosphere of 1,280 triangles after one level: 3,840 patches, small enough for level 64).
        for (label, file, mesh) in [
            ("spot_cc1 (large cage)", "spot-cc1", catmull_clark(&spot, 1)),
            (
                "icosphere3_cc1 (half EVs)",
                "icosphere3-cc1",
                crate::engine::cage::icosphere_quad_cage(3),
            ),
        ] {
            let p = std::env::temp_dir()
                .join(format!("gregvox-bench-{file}-{}.obj", std::process::id()));
            crate::mesh::write_obj(&p, &mesh)?;
            tmp_objs.push(p.clone());
            cages.push((label.into(), mesh, p, vec![4, 8, 16, 32, 64]));
        }
    }
    let mut t = Table::new(
        "gregory_throughput",
        "Gregory evaluation throughput: compute vs vertex pull vs OpenSubdiv (CPU: 1 thread and all cores)",
        &format!(
            "Vertices/s = patches·(level+1)² / median evaluation time ({} repeats; gregvox: timestamps of the \
             evaluation pass; OpenSubdiv 3.5: FindPatch + EvaluateBasis + weighted sums for position and both \
             derivatives in double, std::chrono; on one thread, and on all cores as the faster of that loop \
             split over faces with OpenMP and Osd::OmpEvaluator::EvalPatches in float with the patch \
             coordinates found before timing; OSD GLCompute: Osd::GLComputeEvaluator::EvalPatches on the GL \
             driver of the same device family, e.g. llvmpipe through surfaceless EGL, EvalPatches + glFinish). \
             compute = the evaluator GregorySurface uses on this device (Evaluator::for_device: the host kernel \
             — native SIMD + threads, wall clock — on CPU devices, the Vulkan kernel elsewhere); both are \
             measured where both run. speed-up = OSD time / compute time (the aim: ≥ 2 against all cores). \
             flops and bytes per vertex are counted from the kernel's code \
             (surface::gregory_host::operation_counts: every lane operation of the host kernel counted once \
             per patch it computes, on one regular patch at that level; the shader's per-sample operations \
             with what depends on (u, v) alone — Bernstein, rational and exact-derivative weights — computed \
             once per level, the u-only row terms once per column and the patch-local points once per patch; \
             adds, multiplies, divides and square roots, 1 flop each; bytes: the 20 points and 20 residuals \
             read, the vertices written). Floor = max(flops / FMA peak, bytes / bandwidth) at this run's \
             peaks; floor % = floor / compute time; % of FMA peak and % of bandwidth = the achieved flop \
             and byte rates of the compute time over the peaks. The kernels never fuse a multiply and an \
             add (the bits of the f32 mirror), so a core that issues multiplies and adds on separate pipes \
             can still reach the FMA peak.",
            cfg.repeats
        ),
        &[
            "cage",
            "patches",
            "level",
            "vertices",
            "device evaluator",
            "compute ms",
            "compute Mvert/s",
            "Vulkan kernel ms",
            "host kernel ms",
            "vertex-pull ms",
            "vertex-pull Mvert/s",
            "OSD 1 thread ms",
            "OSD all cores ms",
            "OSD all-core path",
            "OSD GLCompute ms",
            "speed-up vs OSD all cores",
            "speed-up vs OSD 1 thread",
            "Vulkan kernel vs OSD GLCompute",
            "flops/vertex (code)",
            "B/vertex (code)",
            "floor ms",
            "floor %",
            "% of FMA peak",
            "% of bandwidth",
        ],
    );
    let osd_repeats = if cfg.quick { 1 } else { 3 };
    let compute_ctx = super::compute_context()?;
    let r = (|| -> anyhow::Result<()> {
        for (name, mesh, obj, levels) in &cages {
            let (topo, cage) = topology(mesh)?;
            let patches = topo.patch_points.len() as u32;
            let fits: Vec<u32> = levels
                .iter()
                .copied()
                .filter(|&l| {
                    // The levels the compute path can hold (it binds batches of patches, so one
                    // allocation, not one storage binding, is the limit).
                    vertex_count(patches, l) * 32 <= ctx.info.max_memory_allocation_size
                })
                .collect();
            let (peer, osd_rows) = osd(cfg, obj, &fits, osd_repeats);
            let (gl_peer, gl_rows) = osd_gl(cfg, obj, &fits, osd_repeats);
            let evaluator = Evaluator::for_device(&compute_ctx)?;
            for &level in levels {
                let n = vertex_count(patches, level) as f64;
                let kernel = time_path(
                    &compute_ctx,
                    &topo,
                    &cage,
                    level,
                    EvalPath::Compute,
                    cfg.repeats,
                )?;
                // Where the host kernel is the device's choice (CPU devices, or GREGVOX_EVALUATOR=host).
                let host = if compute_ctx.info.device_type == "CPU" || evaluator == Evaluator::Host
                {
                    Some(time_host(&compute_ctx, &topo, &cage, level, cfg.repeats)?)
                } else {
                    None
                };
                let c = match (evaluator, &host) {
                    (Evaluator::Host, Some(h)) => h.clone(),
                    _ => kernel.clone(),
                };
                let v = time_path(ctx, &topo, &cage, level, EvalPath::VertexPull, cfg.repeats)?;
                let cell = |r: &Result<f64, String>| -> (Value, Value) {
                    match r {
                        Ok(ms) => (num(*ms), num(n / (ms * 1e-3) / 1e6)),
                        Err(e) if e.contains("allocates at most") => {
                            ("exceeds maxMemoryAllocationSize".into(), Value::Null)
                        }
                        Err(_) => ("exceeds maxStorageBufferRange".into(), Value::Null),
                    }
                };
                let (cm, cr) = cell(&c);
                let (vm, vr) = cell(&v);
                let times = osd_rows.iter().find(|r| r.level == level);
                let single = times.map(|r| r.single * 1e3);
                let all_core = times.and_then(|r| r.all_core.as_ref());
                let missing = |peer: &Peer| -> Value {
                    match peer {
                        Peer::Ran(_) => "not run (size past the GPU limit)".into(),
                        p => p.status().into(),
                    }
                };
                let om = single.map(num).unwrap_or_else(|| missing(&peer));
                let (am, which) = match all_core {
                    Some((s, which)) => (num(s * 1e3), which.clone().into()),
                    None => (missing(&peer), Value::Null),
                };
                let ms_all = all_core.map(|(s, _)| s * 1e3);
                let counts = gregory_host::operation_counts(level)?;
                let (flops, bytes) = (counts.ops.flops() as f64, counts.bytes as f64);
                let floor = peak.map(|p| p.floor_ms(patches as f64, flops, bytes));
                let per_vertex = (level as f64 + 1.0).powi(2);
                let [fma_pct, bw_pct] = match (peak, &c) {
                    (Some(p), Ok(ms)) => {
                        let (f, b) =
                            p.percent_of_peaks(flops * patches as f64, bytes * patches as f64, *ms);
                        [num(f), num(b)]
                    }
                    _ => [Value::Null, Value::Null],
                };
                let gl = gl_rows.iter().find(|r| r.0 == level);
                let gl_ms = gl.map(|r| r.1 * 1e3);
                t.push(vec![
                    name.clone().into(),
                    patches.into(),
                    level.into(),
                    (n as u64).into(),
                    evaluator.label().into(),
                    cm,
                    cr,
                    cell(&kernel).0,
                    host.as_ref()
                        .map(|h| cell(h).0)
                        .unwrap_or_else(|| "not used (GPU device)".into()),
                    vm,
                    vr,
                    om,
                    am,
                    which,
                    match gl {
                        Some((_, s, renderer)) => {
                            format!("{} ({renderer})", super::fmt_num(s * 1e3)).into()
                        }
                        None => missing(&gl_peer),
                    },
                    c.as_ref()
                        .map(|&ms| speedup(ms_all, ms))
                        .unwrap_or(Value::Null),
                    c.as_ref()
                        .map(|&ms| speedup(single, ms))
                        .unwrap_or(Value::Null),
                    kernel
                        .as_ref()
                        .map(|&ms| speedup(gl_ms, ms))
                        .unwrap_or(Value::Null),
                    num(flops / per_vertex),
                    num(bytes / per_vertex),
                    floor.map(num).unwrap_or(Value::Null),
                    match (floor, &c) {
                        (Some(f), Ok(ms)) => num(100.0 * f / ms),
                        _ => Value::Null,
                    },
                    fma_pct,
                    bw_pct,
                ]);
            }
        }
        Ok(())
    })();
    super::finish_context(compute_ctx)?;
    for p in tmp_objs {
        let _ = std::fs::remove_file(p);
    }
    r?;
    report.tables.push(t);
    Ok(())
}

/// Table `gregory_curvature`: mean and Gaussian curvature (H, K) per vertex on spot_quadrangulated, the
/// curvature pass (glsl/surface_curvature.comp, timestamps) against the host curvature kernel
/// (surface::gregory_host::curvature, wall clock), on a compute-only context.
pub fn curvature(cfg: &BenchConfig, report: &mut Report) -> anyhow::Result<()> {
    use crate::gpu::profiler::scoped;
    use crate::passes::surface_curvature::{SurfaceCurvaturePass, CURVATURE_STRIDE};
    let spot = load_mesh_file(&cfg.model("spot_quadrangulated.obj")?)?;
    let (topo, cage) = topology(&spot)?;
    let levels: &[u32] = if cfg.quick { &[4] } else { &[4, 8, 16, 32] };
    let mut t = Table::new(
        "gregory_curvature",
        "Surface curvature (H, K) per vertex: the curvature pass vs the host curvature kernel",
        &format!(
            "spot_quadrangulated, from the same control points. Vulkan pass = timestamps of \
             glsl/surface_curvature.comp (first and second partials with the rational points' exact terms, \
             the fundamental forms); host kernel = surface::gregory_host::curvature, the same arithmetic in \
             native SIMD (a lane per patch) on every core, wall clock; median of {} repeats (the host \
             kernel: more when short, see the conventions). device evaluator = what \
             GregorySurface::curvature uses on this device; speed-up = Vulkan pass / host kernel.",
            cfg.repeats
        ),
        &[
            "cage",
            "patches",
            "level",
            "vertices",
            "device evaluator",
            "Vulkan pass ms",
            "host kernel ms",
            "speed-up host vs Vulkan pass",
        ],
    );
    let ctx = super::compute_context()?;
    let r = (|| -> anyhow::Result<()> {
        let pass = SurfaceCurvaturePass::new(&ctx)?;
        let evaluator = Evaluator::for_device(&ctx)?;
        for &level in levels {
            let mut surface =
                GregorySurface::with_evaluator(&ctx, &topo, &cage, level, Evaluator::Vulkan)?;
            surface.evaluate(&ctx, None, None)?;
            let n = vertex_count(surface.patch_count(), level);
            let out = ctx.create_buffer(
                "bench curvature",
                n * CURVATURE_STRIDE,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::GpuOnly,
            )?;
            let gpu = time_gpu(&ctx, 1, cfg.repeats, |cmd, mut prof| {
                scoped(&ctx, cmd, &mut prof, "curvature", || {
                    pass.record(
                        &ctx,
                        cmd,
                        surface.points(),
                        surface.patch_points(),
                        surface.patch_count(),
                        level,
                        &out,
                    )
                })
            })?
            .pass("curvature");
            let points = surface.read_points(&ctx)?;
            let hp = gregory_host::HostPatches {
                points: &points,
                residual_rows: 0,
                patch_points: &topo.patch_points,
                patch_flags: &topo.patch_flags,
            };
            let mut hk = vec![[0.0f32; 2]; n as usize];
            let host = time_cpu(cfg.repeats, || {
                gregory_host::curvature(&hp, level, gregory_host::HostSimd::Auto, &mut hk)
                    .expect("curvature of a checked surface")
            });
            t.push(vec![
                "spot_quadrangulated".into(),
                surface.patch_count().into(),
                level.into(),
                n.into(),
                evaluator.label().into(),
                num(gpu),
                num(host),
                speedup(Some(gpu), host),
            ]);
        }
        Ok(())
    })();
    super::finish_context(ctx)?;
    r?;
    report.tables.push(t);
    Ok(())
}

/// The UV cage's attacking input in `gregory_evaluate_at`: a generated n × n grid whose every face is its
/// own UV island (four `vt` per face, as unwelded exports write them).
const UV_SOUP: &str = "uv_soup_64.obj";

/// Feature-adaptive refinement's attacking input in `gregory_evaluate_at`: an n × n grid whose every interior
/// edge is a crease of 9.5 (every face isolated to level 10), timed until it is refused.
const CREASE_ATTACK: &str = "creases_everywhere_64.obj";

fn creases_everywhere_obj(n: usize) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    for j in 0..=n {
        for i in 0..=n {
            let _ = writeln!(s, "v {i} {j} 0");
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            let _ = writeln!(s, "f {a} {} {} {}", a + 1, a + n + 2, a + n + 1);
        }
    }
    for j in 1..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let _ = writeln!(s, "t crease 2/1/0 {a} {} 9.5", a + 1);
        }
    }
    s
}

/// An n × n grid of quads, gently curved, every face its own UV island.
fn uv_soup_obj(n: usize) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
            let _ = writeln!(s, "v {x} {y} {}", 0.1 * (7.0 * x).sin() * (5.0 * y).cos());
        }
    }
    let mut vt = 0;
    for j in 0..n {
        for i in 0..n {
            let ids = [
                j * (n + 1) + i,
                j * (n + 1) + i + 1,
                (j + 1) * (n + 1) + i + 1,
                (j + 1) * (n + 1) + i,
            ];
            let mut f = String::from("f");
            for (k, id) in ids.iter().enumerate() {
                let _ = writeln!(s, "vt {} {}", (k & 1) as f64, (k >> 1) as f64);
                vt += 1;
                let _ = write!(f, " {}/{vt}", id + 1);
            }
            let _ = writeln!(s, "{f}");
        }
    }
    s
}

/// Table `gregory_evaluate_at`: the limit surface at random (ptex face, u, v) — `gregvox evaluate`'s work,
/// [`crate::surface::LimitEvaluator::evaluate`] on every core in f64 with first and second derivatives —
/// beside OpenSubdiv's PatchMap + EvaluateBasis (one thread, every core) and `Osd::OmpEvaluator::EvalPatches`
/// on the same samples (bench/peers/osd_ptex_bench.cpp), on an all-quad cage, a non-quad cage (isolation
/// level 1) and semi-sharp cages (isolation up to 6, feature-adaptive like OpenSubdiv's, with the uniform
/// refinement's patch count beside; the car is past the uniform refinement's limit). The stencils and
/// OpenSubdiv's tables are built before timing; the adaptive stencils' build time is a column.
pub fn evaluate_at(cfg: &BenchConfig, report: &mut Report) -> anyhow::Result<()> {
    use crate::mesh::load_cage_file;
    use crate::surface::LimitEvaluator;
    let n: usize = if cfg.quick { 20_000 } else { 200_000 };
    let mut t = Table::new(
        "gregory_evaluate_at",
        "Evaluation at random (ptex face, u, v): LimitEvaluator vs OpenSubdiv",
        &format!(
            "{n} random samples per cage (seeded), the same for both. gregvox = LimitEvaluator::\
             evaluate_first_order (f64 position and exact first derivatives, what OpenSubdiv computes) and \
             ::evaluate (also exact second derivatives, what gregvox evaluate writes), every core (rayon), \
             wall clock; OpenSubdiv = \
             Far::PatchMap::FindPatch + PatchTable::EvaluateBasis + the sums of position and both first \
             derivatives in double, on one thread and on every core (OpenMP), and Osd::OmpEvaluator::\
             EvalPatches in float (patch coordinates found before timing), the faster all-core figure \
             kept; median of {} repeats. gregvox device = Surface::evaluate_at_with(Vulkan) (host locate, upload, the \
             patch_at pass in f32 with first derivatives, read back: the whole call; on CPU devices \
             evaluate_at itself picks the host evaluation instead). gregvox uv = \
             LimitEvaluator::evaluate_uv on the same samples (cages with vt; uv_soup_64, generated: every \
             face its own UV island, the UV cage's attacking input). Patches: gregvox \
             refines adaptively to the isolation level L as \
             OpenSubdiv does (RefineAdaptive(L)). |Δ sum| = relative difference of Σ(x + y + z) of the \
             positions (the same surface). build ms = AdaptiveStencils::from_cage (gregvox evaluate's \
             feature-adaptive refinement, stencils composed down to the cage); patches uniform = what \
             GregoryStencils::from_cage (the tessellation and device layout) makes, refused past 2^20. \
             creases_everywhere_64 (generated, full runs only): every interior edge of a 64² grid a crease of \
             9.5, feature-adaptive refinement's attacking input; build ms = the time to refuse it.",
            cfg.repeats
        ),
        &[
            "cage",
            "L",
            "patches gregvox",
            "patches uniform",
            "patches OpenSubdiv",
            "build ms",
            "gregvox ms",
            "gregvox with 2nd derivatives ms",
            "gregvox device ms",
            "gregvox uv ms",
            "OpenSubdiv 1 thread ms",
            "OpenSubdiv all cores ms",
            "speed-up vs all cores",
            "|Δ sum|",
        ],
    );
    let dir = std::env::temp_dir().join(format!("gregvox-bench-ptex-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let gpu = crate::api::Gpu::new()?;
    let cages: &[&str] = if cfg.quick {
        &[
            "spot_quadrangulated.obj",
            "opensubdiv/catmark_cube_creases0.obj",
            UV_SOUP,
        ]
    } else {
        &[
            "spot_quadrangulated.obj",
            "opensubdiv/catmark_nonquads.obj",
            "opensubdiv/catmark_cube_creases0.obj",
            "opensubdiv/catmark_chaikin0.obj",
            "opensubdiv/catmark_torus_creases0.obj",
            "opensubdiv/catmark_fvar_bound1.obj",
            "opensubdiv/catmark_car.obj",
            UV_SOUP,
            CREASE_ATTACK,
        ]
    };
    for name in cages {
        let path = match *name {
            UV_SOUP | CREASE_ATTACK => {
                let p = dir.join(name);
                let text = if *name == UV_SOUP {
                    uv_soup_obj(64)
                } else {
                    creases_everywhere_obj(64)
                };
                std::fs::write(&p, text)?;
                p
            }
            _ => cfg.model(name)?,
        };
        let cage = load_cage_file(&path)?;
        let build_start = std::time::Instant::now();
        let built =
            crate::surface::adaptive::AdaptiveStencils::from_cage(&cage, Tangents::OpenSubdiv);
        let build_ms = build_start.elapsed().as_secs_f64() * 1e3;
        let cs = match built {
            Ok(cs) => cs,
            Err(e) if *name == CREASE_ATTACK => {
                // The attack's figure is the time to refuse it (past MAX_ADAPTIVE_PATCHES).
                anyhow::ensure!(e.to_string().contains("limit"), "{name}: {e}");
                let mut row: Vec<Value> = vec![
                    name.trim_end_matches(".obj").into(),
                    10.into(),
                    "refused".into(),
                    "refused (> 2^20)".into(),
                    "—".into(),
                    num(build_ms),
                ];
                row.resize(t.columns.len(), "—".into());
                t.push(row);
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        let uniform: Value = match GregoryStencils::from_cage(&cage, Tangents::OpenSubdiv) {
            Ok(u) => u.stencils.patch_points.len().into(),
            Err(_) => "refused (> 2^20)".into(),
        };
        let e = LimitEvaluator::from_adaptive(&cage, &cs)?.with_uv(&cage, cs.levels)?;
        let mut rng = crate::geom::random::SplitMix64(0x9e37_79b9 ^ n as u64);
        let at: Vec<(u32, f64, f64)> = (0..n)
            .map(|_| (rng.below(e.ptex_faces()) as u32, rng.unit(), rng.unit()))
            .collect();
        let mut samples_out = Vec::new();
        let ours_second = time_cpu(cfg.repeats, || e.evaluate(&at).map(|s| s.len()));
        let ours = time_cpu(cfg.repeats, || -> crate::Result<()> {
            samples_out = e.evaluate_first_order(&at)?;
            Ok(())
        });
        anyhow::ensure!(samples_out.len() == n, "{name}: evaluation failed");
        // The device surface has the uniform layout: past its limit there is no device figure.
        let device: Value = match gpu.tagged_gregory_surface(&cage, 1, Tangents::OpenSubdiv) {
            Ok(surface) => num(time_cpu(cfg.repeats, || {
                surface
                    .evaluate_at_with(&at, crate::engine::gregory::Evaluator::Vulkan)
                    .map(|s| s.position.len())
            })),
            Err(_) => "— (uniform layout refused)".into(),
        };
        let uv_ms: Value = if e.has_uv() {
            num(time_cpu(cfg.repeats, || {
                e.evaluate_uv(&at).map(|u| u.len())
            }))
        } else {
            "—".into()
        };
        let sum: f64 = samples_out
            .iter()
            .map(|s| s.position.x + s.position.y + s.position.z)
            .sum();
        let bin = dir.join("samples.bin");
        let mut bytes = (n as u32).to_le_bytes().to_vec();
        for &(f, u, v) in &at {
            for x in [f as f64, u, v] {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
        }
        std::fs::write(&bin, bytes)?;
        let peer_bin = cfg.peers.join("osd_ptex_bench");
        let peer = if peer_bin.is_file() {
            peers::run(
                &peer_bin,
                &[
                    path.display().to_string(),
                    bin.display().to_string(),
                    cfg.repeats.to_string(),
                ],
            )
        } else {
            Peer::Missing(format!("{} not built", peer_bin.display()))
        };
        let short = name
            .trim_start_matches("opensubdiv/")
            .trim_end_matches(".obj");
        let mut row = vec![
            short.into(),
            cs.levels.into(),
            cs.stencils.patch_points.len().into(),
            uniform,
        ];
        match &peer {
            Peer::Ran(v) if !v.is_empty() => {
                let o = &v[0];
                let single = o["median_s"].as_f64().unwrap_or(f64::NAN) * 1e3;
                let all = [o["threads_median_s"].as_f64(), o["omp_median_s"].as_f64()]
                    .into_iter()
                    .flatten()
                    .fold(f64::INFINITY, f64::min)
                    * 1e3;
                let theirs = o["position_sum"].as_f64().unwrap_or(f64::NAN);
                row.extend([
                    o["patches"].as_u64().unwrap_or(0).into(),
                    num(build_ms),
                    num(ours),
                    num(ours_second),
                    device,
                    uv_ms,
                    num(single),
                    num(all),
                    speedup(Some(all), ours),
                    format!("{:.1e}", ((sum - theirs) / theirs.abs().max(1e-300)).abs()).into(),
                ]);
            }
            other => {
                let why = other.status();
                row.extend([
                    why.clone().into(),
                    num(build_ms),
                    num(ours),
                    num(ours_second),
                    device,
                    uv_ms,
                    why.clone().into(),
                    why.into(),
                    "—".into(),
                    "—".into(),
                ]);
            }
        }
        t.push(row);
    }
    std::fs::remove_dir_all(&dir).ok();
    gpu.finish()?;
    report.tables.push(t);
    Ok(())
}

/// The tessellation-level curve: compute, vertex pull and the f64 CPU evaluation on a 160-patch box cage.
pub fn scaling(ctx: &Context, cfg: &BenchConfig, report: &mut Report) -> anyhow::Result<()> {
    let mesh = crate::engine::cage::builtin_cage(8, 4, 4);
    let (topo, cage) = topology(&mesh)?;
    let stencils = GregoryStencils::from_mesh(&mesh, Tangents::OpenSubdiv)?.stencils;
    let patches = stencils.patches_f64(&cage)?;
    let levels: &[u32] = if cfg.quick {
        &[1, 2, 4, 8]
    } else {
        &[1, 2, 4, 8, 16, 32, 64]
    };
    let mut series: Vec<Series> = Vec::new();
    let compute_ctx = super::compute_context()?;
    let r = (|| -> anyhow::Result<()> {
        for path in EvalPath::ALL {
            let c = if path == EvalPath::Compute {
                &compute_ctx
            } else {
                ctx
            };
            let mut pts = Vec::new();
            for &l in levels {
                if let Ok(ms) = time_path(c, &topo, &cage, l, path, cfg.repeats)? {
                    pts.push((l as f64, ms));
                }
            }
            series.push(Series::new(path.name(), pts));
        }
        Ok(())
    })();
    super::finish_context(compute_ctx)?;
    r?;
    let pts = levels
        .iter()
        .map(|&l| {
            (
                l as f64,
                time_cpu(cfg.repeats.min(5), || tessellate(&patches, l)),
            )
        })
        .collect();
    series.push(Series::new("CPU f64 (1 thread)", pts));
    report.curves.push(Curve {
        id: "scaling_level".into(),
        title: "Gregory evaluation time vs tessellation level".into(),
        note: format!(
            "Box cage of {} patches (builtin_cage 8×4×4); (level+1)² vertices per patch, so the ideal growth \
             is 2 once fixed costs are amortised.",
            topo.patch_points.len()
        ),
        x_label: "level".into(),
        y_label: "ms".into(),
        series,
    });
    Ok(())
}

/// Uniform vs screen-space adaptive tessellation of spot at the same maximum level: the GPU time of the
/// whole chain (control points, (levels,) evaluation) and the vertices each actually produces, from a near
/// view (the model fills a 1280×720 frame) and a far one (a tenth of the frame).
pub fn adaptive(cfg: &BenchConfig, report: &mut Report) -> anyhow::Result<()> {
    use crate::passes::adaptive_levels::AdaptiveParams;
    use glam::{Mat4, Vec3};
    let spot = load_mesh_file(&cfg.model("spot_quadrangulated.obj")?)?;
    let (topo, cage) = topology(&spot)?;
    let (lo, hi) = cage.iter().fold(
        (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)),
        |(a, b), p| (a.min(*p), b.max(*p)),
    );
    let centre = (0.5 * (lo + hi)).as_vec3();
    let radius = (0.5 * (hi - lo).length()) as f32;
    let (w, h) = (1280.0f32, 720.0f32);
    let view = |distance: f32| {
        let eye = centre + Vec3::new(0.6, -1.0, 0.5).normalize() * distance * radius;
        Mat4::perspective_rh(
            45f32.to_radians(),
            w / h,
            0.01 * radius,
            100.0 * distance * radius,
        ) * Mat4::look_at_rh(eye, centre, Vec3::Z)
    };
    let views = [("near", view(2.5)), ("far", view(25.0))];
    let levels: &[u32] = if cfg.quick { &[8] } else { &[8, 16, 24] };
    let pixels = 4.0;
    let mut t = Table::new(
        "gregory_adaptive",
        "Uniform vs screen-space adaptive tessellation (spot_quadrangulated, 1280×720)",
        &format!(
            "Adaptive: per-patch level = longest projected boundary control-polygon edge / {pixels} px, at most \
             L_max; shared edges take the smaller level and boundary rows snap to it (crack-free). Time: median \
             timestamps ({} repeats) of gregory_points + [adaptive_levels +] gregory_eval on a compute-only \
             context. Vertices: the uniform grid, or Σ(L_p+1)² of the patches' own grids.",
            cfg.repeats
        ),
        &[
            "view",
            "L_max",
            "uniform ms",
            "uniform vertices",
            "adaptive ms",
            "adaptive vertices",
            "mean L_p",
            "speed-up",
        ],
    );
    let ctx = super::compute_context()?;
    let r = (|| -> anyhow::Result<()> {
        for &l_max in levels {
            let mut surface = GregorySurface::new(&ctx, &topo, &cage, l_max)?;
            let chain = |s: &GregorySurface| {
                time_gpu(&ctx, 2, cfg.repeats, |cmd, prof| {
                    s.record(&ctx, cmd, None, prof)
                })
                .map(|g| {
                    ["gregory_points", "adaptive_levels", "gregory_eval"]
                        .iter()
                        .map(|n| g.pass(n))
                        .filter(|ms| ms.is_finite())
                        .sum::<f64>()
                })
            };
            let uniform_ms = chain(&surface)?;
            let uniform_n = vertex_count(surface.patch_count(), l_max);
            for (name, vp) in &views {
                surface.set_adaptive(
                    &ctx,
                    Some(AdaptiveParams {
                        view_proj: *vp,
                        viewport: [w, h],
                        pixels_per_segment: pixels,
                    }),
                )?;
                let ms = chain(&surface)?;
                let lv = surface.read_levels(&ctx)?;
                let n: u64 = lv.iter().map(|&l| ((l + 1) * (l + 1)) as u64).sum();
                let mean = lv.iter().map(|&l| l as f64).sum::<f64>() / lv.len().max(1) as f64;
                t.push(vec![
                    (*name).into(),
                    l_max.into(),
                    num(uniform_ms),
                    uniform_n.into(),
                    num(ms),
                    n.into(),
                    num(mean),
                    speedup(Some(uniform_ms), ms),
                ]);
                surface.set_adaptive(&ctx, None)?;
            }
        }
        Ok(())
    })();
    super::finish_context(ctx)?;
    r?;
    report.tables.push(t);
    Ok(())
}
