//! `gregvox voxelize IN.obj --res R [--out OUT.binvox] …`: solid voxels by depth peeling (GPU) or the CPU
//! scanline, with hygiene, open-mesh detection, axis choice, a memory estimate and per-pass times.
use super::profile::ProfileArgs;
use crate::engine::voxelize::{
    memory_estimate, AbufferVoxelizer, GpuTriangles, GpuVoxelizer, PeelVoxelizer,
};
use crate::gpu::{Context, ContextDesc, Profiler};
use crate::mesh::{load_obj, Mesh, MeshMatrix};
use crate::voxel::cpu::{voxelize_cpu, FillRule};
use crate::voxel::export::write_grid;
use crate::voxel::grid::{Axis, GridFrame, VoxelGrid};
use crate::voxel::mesh::TriMesh;
use anyhow::{bail, Context as _};
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use std::time::Instant;

/// Largest resolution accepted (2048³ bits = 1 GiB).
pub const MAX_RES: u32 = 2048;

/// The voxelization method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Raster depth peeling + compute fill on the GPU.
    Peel,
    /// GPU A-buffer: count, prefix sum, one scatter pass, per-column sort + fill (no equal-depth loss).
    Abuffer,
    /// The same-sampling CPU column scanline (all cores).
    Cpu,
}

/// Arguments of `gregvox voxelize`.
#[derive(Debug, Args)]
pub struct VoxelizeArgs {
    /// The OBJ file to voxelize.
    pub input: PathBuf,
    /// Voxels per side of the cubic grid (1–2048).
    #[arg(long)]
    pub res: u32,
    /// Output file: .binvox, .npy, .nrrd, .raw (+ .json sidecar) or .vox (MagicaVoxel).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Peel along 1 axis, or 3 with a 2-of-3 vote (default: 3 for open meshes, else 1).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["1", "3"]))]
    pub axes: Option<String>,
    /// The single peel axis (default: the smallest layers × covered area).
    #[arg(long, value_enum)]
    pub axis: Option<Axis>,
    /// Inside rule.
    #[arg(long, value_enum, default_value = "winding")]
    pub rule: FillRule,
    /// Method.
    #[arg(long, value_enum, default_value = "peel")]
    pub method: Method,
    /// Refuse meshes needing more peeling passes than this.
    #[arg(long, default_value_t = 256)]
    pub max_layers: u32,
    /// Treat the input as a quad cage: evaluate its ACC-2 Gregory surface at this level on the GPU and voxelize
    /// it straight from the device-local vertex buffer (no CPU round trip of the surface).
    #[arg(long, value_name = "LEVEL")]
    pub gregory_level: Option<u32>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub profile: ProfileArgs,
}

/// Fan-triangulates a polygon mesh for the voxelizers.
pub fn triangles_of(mesh: &Mesh) -> TriMesh {
    let positions = mesh
        .positions
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    let mut triangles = Vec::new();
    for f in 0..mesh.n_faces() {
        let face = mesh.face(f);
        for k in 1..face.len() - 1 {
            triangles.push([face[0], face[k], face[k + 1]]);
        }
    }
    TriMesh {
        positions,
        triangles,
    }
}

/// Runs `gregvox voxelize`.
pub fn run(args: &VoxelizeArgs) -> anyhow::Result<()> {
    if args.res == 0 || args.res > MAX_RES {
        bail!(
            "--res {} is out of range: the resolution must be between 1 and {MAX_RES}",
            args.res
        );
    }
    if let Some(out) = &args.out {
        let ext = out
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if !["binvox", "npy", "nrrd", "raw", "vox"].contains(&ext.as_str()) {
            bail!(
                "{}: unknown voxel format '.{ext}' (use .binvox, .npy, .nrrd, .raw or .vox)",
                out.display()
            );
        }
    }
    if let Some(level) = args.gregory_level {
        return run_gregory(args, level);
    }
    let mesh = load_obj(&args.input)?;
    let topo = MeshMatrix::from_mesh(&mesh).report();
    let (tri, clean) = triangles_of(&mesh).clean();
    if tri.triangles.is_empty() {
        bail!(
            "{}: no triangle with a non-zero area to voxelize",
            args.input.display()
        );
    }
    let frame = GridFrame::from_points(&tri.positions, args.res)
        .with_context(|| args.input.display().to_string())?;
    let mut notes = Vec::new();
    if clean.duplicates + clean.cancelled + clean.zero_area > 0 {
        notes.push(format!(
            "removed {} duplicate, {} cancelling and {} zero-area triangles",
            clean.duplicates, clean.cancelled, clean.zero_area
        ));
    }
    let open = !topo.closed;
    let three = match args.axes.as_deref() {
        Some("3") => true,
        Some(_) => false,
        None => open && args.axis.is_none(),
    };
    if open {
        notes.push(format!(
            "open mesh ({} boundary and {} non-manifold edges){}",
            topo.boundary_edges,
            topo.non_manifold_edges,
            if three {
                ": peeling along x, y and z with a 2-of-3 vote"
            } else {
                ""
            }
        ));
    }
    for n in &notes {
        eprintln!("gregvox voxelize: {n}");
    }

    let start = Instant::now();
    let (grid, layers, profiler_json, table) = match args.method {
        Method::Cpu => {
            let axes: Vec<Axis> = if three {
                Axis::ALL.to_vec()
            } else {
                vec![args.axis.unwrap_or(Axis::Z)]
            };
            let grids: Vec<VoxelGrid> = axes
                .iter()
                .map(|&a| voxelize_cpu(&tri, &frame, a, args.rule))
                .collect();
            let grid = if three {
                VoxelGrid::majority([&grids[0], &grids[1], &grids[2]])
            } else {
                grids.into_iter().next().unwrap()
            };
            (grid, Vec::new(), None, None)
        }
        Method::Peel | Method::Abuffer => run_peel(args, &tri, &frame, three)?,
    };
    let seconds = start.elapsed().as_secs_f64();
    if let Some(out) = &args.out {
        write_grid(&grid, out)?;
    }
    let summary = serde_json::json!({
        "input": args.input.display().to_string(),
        "res": args.res,
        "method": format!("{:?}", args.method).to_lowercase(),
        "rule": format!("{:?}", args.rule).to_lowercase(),
        "triangles": tri.triangles.len(),
        "removed": clean,
        "closed": topo.closed,
        "layers": layers.iter().map(|(a, l): &(Axis, u32)| (a.name().to_string(), *l)).collect::<std::collections::BTreeMap<_, _>>(),
        "solid_voxels": grid.count(),
        "origin": frame.origin,
        "pitch": frame.pitch(),
        "seconds": seconds,
        "profile": profiler_json,
    });
    if args.json {
        super::print_out(&format!("{}\n", serde_json::to_string_pretty(&summary)?))?;
    } else {
        let l: Vec<String> = layers
            .iter()
            .map(|(a, l)| format!("{} {l}", a.name()))
            .collect();
        let mut text = format!(
            "{}: {} triangles, {}³ grid, pitch {:.6}\n",
            args.input.display(),
            tri.triangles.len(),
            args.res,
            frame.pitch()
        );
        if !l.is_empty() {
            text.push_str(&format!("layers per axis: {}\n", l.join(", ")));
        }
        text.push_str(&format!(
            "solid voxels: {}\ntotal time: {:.1} ms\n",
            grid.count(),
            seconds * 1e3
        ));
        if let Some(t) = table {
            text.push_str(&t);
        }
        super::print_out(&text)?;
    }
    Ok(())
}

type PeelResult = (
    VoxelGrid,
    Vec<(Axis, u32)>,
    Option<serde_json::Value>,
    Option<String>,
);

/// `--gregory-level`: cage → GPU Gregory surface → peel, all on the device.
fn run_gregory(args: &VoxelizeArgs, level: u32) -> anyhow::Result<()> {
    use crate::engine::gregory::GregorySurface;
    use crate::engine::voxelize::voxelize_gregory_surface;
    if args.method != Method::Peel {
        bail!("--gregory-level voxelizes the GPU surface by depth peeling: use --method peel");
    }
    let mesh = load_obj(&args.input)?;
    let open = !MeshMatrix::from_mesh(&mesh).report().closed;
    let (topo, cage, note) =
        super::cage::cage_topology(&mesh, crate::surface::Tangents::OpenSubdiv)
            .map_err(|e| anyhow::anyhow!("{}: {e}", args.input.display()))?;
    if let Some(n) = note {
        eprintln!("gregvox voxelize: {n}");
    }
    let three = match args.axes.as_deref() {
        Some("3") => true,
        Some(_) => false,
        None => open && args.axis.is_none(),
    };
    let axes: Vec<Axis> = if three {
        Axis::ALL.to_vec()
    } else {
        vec![args.axis.unwrap_or(Axis::Z)]
    };
    let ctx = Context::with_desc(&ContextDesc::default())?;
    let mut profiler = Profiler::new(&ctx, 1, 4096)?;
    let start = Instant::now();
    let result = (|| -> anyhow::Result<(VoxelGrid, Vec<crate::engine::voxelize::AxisStats>)> {
        let surface = GregorySurface::new(&ctx, &topo, &cage, level)?;
        let r = ctx
            .one_shot(|cmd| surface.record(&ctx, cmd, None, Some((&mut profiler, 0))))
            .map_err(anyhow::Error::from)
            .and_then(|()| {
                profiler.collect(&ctx, 0)?;
                Ok(voxelize_gregory_surface(
                    &ctx,
                    &surface,
                    args.res,
                    &axes,
                    args.rule,
                    args.max_layers,
                    Some(&mut profiler),
                )?)
            });
        r
    })();
    let out = result.and_then(|(grid, stats)| {
        args.profile.emit(&profiler)?;
        if let Some(path) = &args.out {
            write_grid(&grid, path)?;
        }
        let layers: Vec<String> = stats.iter().map(|s| format!("{} {}", s.axis.name(), s.layers)).collect();
        super::print_out(&format!(
            "{}: Gregory surface at level {level}, {}³ grid\nlayers per axis: {}\nsolid voxels: {}\ntotal time: {:.1} ms\n",
            args.input.display(),
            args.res,
            layers.join(", "),
            grid.count(),
            start.elapsed().as_secs_f64() * 1e3
        ))
    });
    out
}

fn run_peel(
    args: &VoxelizeArgs,
    tri: &TriMesh,
    frame: &GridFrame,
    three: bool,
) -> anyhow::Result<PeelResult> {
    let ctx = Context::with_desc(&ContextDesc::default())?;
    let progress = progress_bar(
        frame.res,
        tri.triangles.len(),
        if three { 3 } else { 1 },
        args.max_layers,
    );
    let mut profiler = Profiler::new(&ctx, 1, 4096)?;
    let result = (|| -> anyhow::Result<PeelResult> {
        let v = if args.method == Method::Abuffer {
            let mut v = AbufferVoxelizer::new(&ctx, 12)?;
            v.progress = progress.clone();
            GpuVoxelizer::Abuffer(Box::new(v))
        } else {
            let mut v = PeelVoxelizer::new(&ctx, 12)?;
            v.max_layers = args.max_layers;
            v.progress = progress.clone();
            GpuVoxelizer::Peel(Box::new(v))
        };
        let gpu = GpuTriangles::upload(&ctx, tri)?;
        let out = (|| -> anyhow::Result<PeelResult> {
            let geom = gpu.geometry();
            let need = memory_estimate(&ctx, frame.res, 16);
            let heap = ctx.info.device_local_heap_bytes;
            if heap > 0 && need > heap {
                bail!(
                    "--res {} needs about {} MiB of device memory; the device has {} MiB",
                    frame.res,
                    need >> 20,
                    heap >> 20
                );
            }
            let axes: Vec<Axis> = if three {
                Axis::ALL.to_vec()
            } else if let Some(a) = args.axis {
                vec![a]
            } else {
                // The cheapest axis: fewest layers × columns covered, from the count pre-pass.
                let mut best = (u128::MAX, Axis::Z);
                for a in Axis::ALL {
                    let (l, area) = v.count_layers(&ctx, &geom, frame, a)?;
                    best = best.min(((l as u128) * (area as u128), a));
                }
                vec![best.1]
            };
            let (grid, stats) =
                v.voxelize(&ctx, &geom, frame, &axes, args.rule, Some(&mut profiler))?;
            let layers = stats.iter().map(|s| (s.axis, s.layers)).collect();
            args.profile.emit(&profiler)?;
            let per_pass: String = profiler
                .stats()
                .iter()
                .map(|p| {
                    format!(
                        "{}: {} call(s), {:.2} ms total\n",
                        p.name, p.calls, p.total_ms
                    )
                })
                .collect();
            Ok((grid, layers, Some(profiler.json()), Some(per_pass)))
        })();
        out
    })();
    if let Some(p) = progress {
        p.finish_and_clear();
    }
    let leaks = ctx.live_allocations();
    if !leaks.is_empty() {
        bail!("internal error: GPU allocations still alive: {leaks:?}");
    }
    result
}

/// A progress bar on stderr for long voxelizations, only when stderr is a terminal: piped output and tests
/// never see it. Long = R ≥ 512, or ≥ 1 M triangles (each of the L peeling passes re-rasterizes them all:
/// ~0.2 s per pass on lavapipe), or a layer cap raised above the default. The layer count itself is known
/// only after the count pre-pass, too late to decide. Three stages per axis (count, peel or scatter, fill); a
/// steady tick keeps the spinner alive during a long GPU submission.
fn progress_bar(
    res: u32,
    triangles: usize,
    axes: u64,
    max_layers: u32,
) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    let long = res >= 512
        || triangles >= 1_000_000
        || max_layers > crate::engine::voxelize::DEFAULT_MAX_LAYERS;
    if !long || !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::with_draw_target(
        Some(3 * axes),
        indicatif::ProgressDrawTarget::stderr(),
    );
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} voxelize [{bar:20}] {pos}/{len} {msg} ({elapsed})",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    Some(bar)
}
