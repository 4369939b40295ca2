//! `gregvox voxelize IN.obj|.stl|.ply|.off|.gltf|.glb --res R [--out OUT.binvox] …`: argument parsing and printing over
//! `Gpu::voxelize` / `voxelize_on_cpu` of the library API (which holds the policy: hygiene, open-mesh
//! detection, axis choice, the memory estimate).
use crate::api::{
    load_mesh, voxelize_on_cpu, Axes, Axis, FillRule, Gpu, Method, Voxelization, VoxelizeOptions,
    MAX_RES,
};
use crate::args::ProfileArgs;
use anyhow::bail;
use clap::Args;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `gregvox voxelize`.
#[derive(Debug, Args)]
pub struct VoxelizeArgs {
    /// The mesh file (OBJ, STL, PLY, OFF, glTF/GLB) to voxelize.
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

/// Runs `gregvox voxelize`: argument checks, then one call of the library API, then printing.
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
    let axes = match (args.axes.as_deref(), args.axis) {
        (Some("3"), _) => Axes::Three,
        (_, Some(a)) => Axes::One(a),
        (Some(_), None) => Axes::Best,
        (None, None) => Axes::Auto,
    };
    let mesh = load_mesh(&args.input)?;
    let mut opts = VoxelizeOptions::default()
        .res(args.res)
        .method(args.method)
        .rule(args.rule)
        .axes(axes)
        .max_layers(args.max_layers);
    let start = Instant::now();
    // Only the GPU paths need a device (and a profiler); the CPU method runs without Vulkan.
    let gpu = if args.method == Method::Cpu && args.gregory_level.is_none() {
        None
    } else {
        Some(Gpu::new()?)
    };
    let mut profiler = gpu.as_ref().map(Gpu::profiler).transpose()?;
    let bar = progress_bar(
        args.res,
        mesh.n_faces(),
        if axes == Axes::Three { 3 } else { 1 },
        args.max_layers,
    );
    if let Some(bar) = &bar {
        let bar = bar.clone();
        opts = opts.on_progress(move |msg| {
            bar.set_message(msg.to_string());
            bar.inc(1);
        });
    }
    let result = match (&gpu, args.gregory_level) {
        (Some(gpu), Some(level)) => gpu.voxelize_gregory(&mesh, level, &opts, profiler.as_mut()),
        (Some(gpu), None) => gpu.voxelize_profiled(&mesh, &opts, profiler.as_mut()),
        (None, _) => voxelize_on_cpu(&mesh, &opts),
    };
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let Voxelization { grid, report } = result.map_err(|e| e.for_input(&args.input))?;
    let seconds = start.elapsed().as_secs_f64();
    for n in &report.notes {
        eprintln!("gregvox voxelize: {n}");
    }
    if let Some(p) = &profiler {
        args.profile.emit(p)?;
    }
    if let Some(out) = &args.out {
        grid.save(out)?;
    }
    let layers: std::collections::BTreeMap<String, u32> = report
        .layers
        .iter()
        .map(|(a, l)| (a.name().to_string(), *l))
        .collect();
    if args.json {
        let summary = serde_json::json!({
            "input": args.input.display().to_string(),
            "res": args.res,
            "method": report.method,
            "rule": format!("{:?}", args.rule).to_lowercase(),
            "gregory_level": args.gregory_level,
            "triangles": report.triangles,
            "removed": report.removed,
            "closed": report.closed,
            "axes": report.axes.iter().map(|a| a.name()).collect::<Vec<_>>(),
            "layers": layers,
            "solid_voxels": grid.count(),
            "origin": grid.frame.origin,
            "pitch": grid.frame.pitch(),
            "seconds": seconds,
            "profile": profiler.as_ref().map(|p| p.json()),
        });
        super::print_out(&format!("{}\n", serde_json::to_string_pretty(&summary)?))?;
        return Ok(());
    }
    let mut text = match args.gregory_level {
        Some(level) => format!(
            "{}: Gregory surface at level {level}, {}³ grid\n",
            args.input.display(),
            args.res
        ),
        None => format!(
            "{}: {} triangles, {}³ grid, pitch {:.6}\n",
            args.input.display(),
            report.triangles,
            args.res,
            grid.frame.pitch()
        ),
    };
    if !layers.is_empty() {
        let l: Vec<String> = report
            .layers
            .iter()
            .map(|(a, l)| format!("{} {l}", a.name()))
            .collect();
        text.push_str(&format!("layers per axis: {}\n", l.join(", ")));
    }
    text.push_str(&format!(
        "solid voxels: {}\ntotal time: {:.1} ms\n",
        grid.count(),
        seconds * 1e3
    ));
    // Per-pass GPU times only when asked for (--profile, --profile-json, --trace): the summary stays short.
    super::print_out(&text)?;
    Ok(())
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
    let long = res >= 512 || triangles >= 1_000_000 || max_layers > crate::api::DEFAULT_MAX_LAYERS;
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
