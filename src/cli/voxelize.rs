//! `gregvox voxelize IN.{obj,stl,ply,off,gltf,glb} --res R | --dims X,Y,Z | --voxel-size H [--bbox …] [--pad N]
//! [--fill …] [--out OUT]`: argument parsing and printing over `voxelize` / `Gpu::voxelize` /
//! `voxelize_on_cpu` of the library API (which holds the policy: hygiene, open-mesh
//! detection, axis choice, the memory estimate).
use crate::api::{
    grid_frame, load_mesh, voxelize, voxelize_on_cpu, Axes, Axis, Fill, FillRule, Gpu, GridFrame,
    Method, SaveOptions, Voxelization, VoxelizeOptions, MAX_RES,
};
use crate::args::ProfileArgs;
use crate::voxel::export::check_format;
use anyhow::bail;
use clap::Args;
use std::path::PathBuf;
use std::time::Instant;

/// The grid and voxelization flags `voxelize` and `batch` share.
#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("size").required(true).args(["res", "dims", "voxel_size"])))]
pub struct GridArgs {
    /// A cubic R×R×R grid (1–2048) whose side is the box's longest extent.
    #[arg(long)]
    pub res: Option<u32>,
    /// The box divided into X×Y×Z voxels (voxel size extent/dims on each axis).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_dims)]
    pub dims: Option<[u32; 3]>,
    /// Cubic voxels of side H: ceil(extent/H) voxels on each axis from the box's minimum.
    #[arg(long, value_name = "H")]
    pub voxel_size: Option<f64>,
    /// Voxelize this box instead of the mesh's (min corner, then max corner); inside or outside is still
    /// decided by the whole mesh.
    #[arg(long, value_name = "X0,Y0,Z0,X1,Y1,Z1", value_parser = parse_bbox, allow_hyphen_values = true)]
    pub bbox: Option<[f64; 6]>,
    /// N empty voxels added on every side (the grid grows by 2N, the origin moves by N voxels).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub pad: u32,
    /// Write .npy as packed bits (uint8, X×Y×ceil(Z/8), little bit order) instead of a bool X×Y×Z array.
    #[arg(long)]
    pub npy_packed: bool,
    /// Write .ply as the solid's boundary mesh (as .obj, .stl and .glb are) instead of the solid voxels'
    /// centres.
    #[arg(long)]
    pub ply_boundary: bool,
    /// Peel along 1 axis, or 3 with a 2-of-3 vote of the winding rule on the uncapped mesh (default: 1; 3
    /// for open meshes under --rule winding or parity).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["1", "3"]))]
    pub axes: Option<String>,
    /// The single peel axis (default: the smallest layers × covered area).
    #[arg(long, value_enum)]
    pub axis: Option<Axis>,
    /// Inside rule: gwn = the exact generalized winding number w of the cleaned triangles, solid where |w| ≥ ½
    /// at the voxel centre (an inverted closed part is solid; open meshes, holes, seams and soups need no
    /// repair; on closed meshes it is the winding rule, bit for bit); gwn-positive = the same with w ≥ ½
    /// (libigl's convention: inverted parts are empty); winding = non-zero crossing count; positive =
    /// positive crossing count; parity = odd crossing count.
    #[arg(long, value_enum, default_value = "gwn")]
    pub rule: FillRule,
    /// Memory (MiB) the generalized winding number may spend on its trees and the voxels it resolves one by
    /// one; past it the model is refused with a clear error.
    #[arg(long, value_name = "MIB", default_value_t = 1024)]
    pub gwn_budget: u64,
    /// Which voxels: inside the solid, touched by a triangle (exact triangle–box test), or both (thin walls
    /// kept).
    #[arg(long, value_enum, default_value = "solid")]
    pub fill: Fill,
    /// Method (auto: the CPU scanline on a CPU device such as lavapipe or with no Vulkan device, the
    /// A-buffer on a GPU).
    #[arg(long, value_enum, default_value = "auto")]
    pub method: Method,
    /// Refuse meshes needing more peeling passes than this.
    #[arg(long, default_value_t = 256)]
    pub max_layers: u32,
}

/// Arguments of `gregvox voxelize`.
#[derive(Debug, Args)]
pub struct VoxelizeArgs {
    /// The mesh file (OBJ, STL, PLY, OFF, glTF/GLB) to voxelize.
    pub input: PathBuf,
    #[command(flatten)]
    pub grid: GridArgs,
    /// Output file: .binvox (cubic grids only), .npy, .nrrd, .raw, .vox or .vdb (an OpenVDB BoolGrid); sparse: .npz (`coords` int32
    /// N×3 of the solid voxels, sorted, with `origin`, `voxel_size`, `dims`) or .ply (their centres); the
    /// solid's boundary as a closed, manifold, outward quad mesh: .obj, .stl, .glb (.ply with
    /// --ply-boundary). A
    /// .npy/.raw/.vox output gets a sidecar named after the whole file (a.npy → a.npy.json) with dims,
    /// voxel_size, origin and the index-to-world matrix, so a.npy and a.raw side by side keep their own.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Treat the input as a quad cage: evaluate its ACC-2 Gregory surface at this level on the GPU and voxelize
    /// it straight from the device-local vertex buffer (no CPU round trip of the surface).
    #[arg(long, value_name = "LEVEL")]
    pub gregory_level: Option<u32>,
    /// With --gregory-level: the cage's isolation level L (refined L times first, as OpenSubdiv's
    /// RefineAdaptive(L); default: ⌈largest semi-sharp sharpness⌉, 1 with non-quad faces, else 0).
    #[arg(long, value_name = "L", requires = "gregory_level")]
    pub isolation: Option<u32>,
    /// What the output holds: `occupancy` (the solid voxels), or `sdf`, a narrow-band signed distance level
    /// set (an OpenVDB FloatGrid of class "level set" named `sdf`, .vdb only): exact distances at the band's
    /// voxel centres, negative on the solid voxels, ±half-width voxels elsewhere.
    #[arg(long, value_enum, default_value = "occupancy")]
    pub what: GridWhat,
    /// The level set's half-width in voxels on each side of the surface (--what sdf).
    #[arg(long, value_name = "N", default_value_t = crate::api::levelset::HALF_WIDTH)]
    pub half_width: u32,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub profile: ProfileArgs,
}

/// What `voxelize --out` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum GridWhat {
    /// The solid voxels.
    Occupancy,
    /// A narrow-band signed distance level set (.vdb).
    Sdf,
}

fn parse_numbers<T: std::str::FromStr, const N: usize>(
    s: &str,
    what: &str,
) -> Result<[T; N], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != N {
        return Err(format!(
            "{what} needs {N} comma-separated numbers, got {}",
            parts.len()
        ));
    }
    let mut out = Vec::with_capacity(N);
    for p in parts {
        out.push(
            p.parse::<T>()
                .map_err(|_| format!("cannot read '{p}' as a number ({what})"))?,
        );
    }
    out.try_into().map_err(|_| "internal: count checked".into())
}

fn parse_dims(s: &str) -> Result<[u32; 3], String> {
    let d = parse_numbers::<u32, 3>(s, "X,Y,Z")?;
    if let Some(bad) = d.iter().find(|&&n| n == 0 || n > MAX_RES) {
        return Err(format!(
            "{bad} voxels: every axis needs between 1 and {MAX_RES}"
        ));
    }
    Ok(d)
}

fn parse_bbox(s: &str) -> Result<[f64; 6], String> {
    let b = parse_numbers::<f64, 6>(s, "X0,Y0,Z0,X1,Y1,Z1")?;
    if b.iter().any(|x| !x.is_finite()) {
        return Err("every coordinate must be finite".into());
    }
    if (0..3).any(|a| b[a] >= b[a + 3]) {
        return Err("the min corner must be below the max corner on every axis".into());
    }
    Ok(b)
}

impl GridArgs {
    /// The library options these flags give.
    pub fn options(&self) -> anyhow::Result<VoxelizeOptions> {
        let axes = match (self.axes.as_deref(), self.axis) {
            (Some("3"), Some(a)) => bail!(
                "--axis {} picks the one axis of --axes 1; --axes 3 votes over all three",
                a.name()
            ),
            (Some("3"), _) => Axes::Three,
            (_, Some(a)) => Axes::One(a),
            (Some(_), None) => Axes::Best,
            (None, None) => Axes::Auto,
        };
        let mut opts = VoxelizeOptions::default()
            .method(self.method)
            .rule(self.rule)
            .fill(self.fill)
            .axes(axes)
            .max_layers(self.max_layers)
            .gwn_budget(self.gwn_budget.saturating_mul(1 << 20))
            .pad(self.pad);
        opts = match (self.res, self.dims, self.voxel_size) {
            (Some(r), _, _) => {
                if r == 0 || r > MAX_RES {
                    bail!(
                        "--res {r} is out of range: the resolution must be between 1 and {MAX_RES}"
                    );
                }
                opts.res(r)
            }
            (_, Some(d), _) => opts.dims(d),
            (_, _, Some(h)) => {
                if !(h.is_finite() && h > 0.0) {
                    bail!("--voxel-size {h}: the voxel size must be a finite number > 0");
                }
                opts.voxel_size(h)
            }
            _ => bail!("give the grid size: --res R, --dims X,Y,Z or --voxel-size H"),
        };
        if let Some(b) = self.bbox {
            opts = opts.bbox([b[0], b[1], b[2]], [b[3], b[4], b[5]]);
        }
        Ok(opts)
    }
}

/// Runs `gregvox voxelize`: argument checks, then one call of the library API, then printing.
pub fn run(args: &VoxelizeArgs) -> anyhow::Result<()> {
    let mut opts = args.grid.options()?;
    if args.what == GridWhat::Sdf {
        let vdb = args
            .out
            .as_ref()
            .and_then(|o| o.extension())
            .and_then(|e| e.to_str());
        if !vdb.is_some_and(|e| e.eq_ignore_ascii_case("vdb")) {
            anyhow::bail!("--what sdf writes an OpenVDB level set: give --out X.vdb");
        }
        if args.gregory_level.is_some() {
            anyhow::bail!(
                "--what sdf needs the mesh's triangles: it does not combine with --gregory-level"
            );
        }
        if !(1..=64).contains(&args.half_width) {
            anyhow::bail!(
                "--half-width {} is out of range: give 1 to 64 voxels",
                args.half_width
            );
        }
        if args.grid.fill != Fill::Solid {
            anyhow::bail!(
                "--what sdf signs the distance by the solid (negative inside): it does not combine with \
                 --fill {}",
                args.grid.fill.name()
            );
        }
    }
    if let Some(out) = &args.out {
        // Unknown formats and unwritable paths before the mesh is even read (nothing is thrown away at the
        // end); the grid-dependent checks once its frame is known.
        let probe = GridFrame::cubic(1, [0.0; 3], 1.0);
        check_format(&probe, out, None)?;
        crate::io::check_output(out)?;
        if let Some(side) = sidecar_of(out) {
            crate::io::check_output(&side)?;
        }
    }
    args.profile.check_outputs()?;
    let mesh = load_mesh(&args.input)?;
    let frame = grid_frame(&mesh, &opts).map_err(|e| e.for_input(&args.input))?;
    if let Some(out) = &args.out {
        if args.gregory_level.is_none() {
            check_format(&frame, out, None)?;
        }
    }
    let start = Instant::now();
    let profiling = args.profile.wanted();
    // A device only where one is needed: --method cpu never touches Vulkan, and auto without --profile
    // probes the device first (no pipelines) and stays on the CPU on a CPU device.
    let gpu = match (args.grid.method, args.gregory_level.is_some(), profiling) {
        (_, true, _) => Some(Gpu::new()?),
        (Method::Cpu, false, _) | (Method::Auto, false, false) => None,
        _ => Some(Gpu::new()?),
    };
    let mut profiler = gpu.as_ref().map(Gpu::profiler).transpose()?;
    let bar = progress_bar(
        frame.dims.iter().copied().max().unwrap_or(1),
        mesh.n_faces(),
        if opts.axes == Axes::Three { 3 } else { 1 },
        args.grid.max_layers,
    );
    if let Some(bar) = &bar {
        let bar = bar.clone();
        opts = opts.on_progress(move |msg| {
            bar.set_message(msg.to_string());
            bar.inc(1);
        });
    }
    let result = match (&gpu, args.gregory_level) {
        (Some(gpu), Some(level)) => {
            // The cage with its OpenSubdiv tags (creases, corners, holes): the mesh above was read for
            // the grid's frame, which tags do not change.
            let mut cage = crate::api::load_cage(&args.input)?;
            cage.tags.isolation = args.isolation;
            gpu.voxelize_gregory(&cage, level, &opts, profiler.as_mut())
        }
        (Some(gpu), None) => gpu.voxelize_profiled(&mesh, &opts, profiler.as_mut()),
        (None, _) if args.grid.method == Method::Cpu => voxelize_on_cpu(&mesh, &opts),
        (None, _) => voxelize(&mesh, &opts),
    };
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let result = result.map_err(|e| e.for_input(&args.input))?;
    let Voxelization { grid, report } = &result;
    let seconds = start.elapsed().as_secs_f64();
    for n in &report.notes {
        eprintln!("gregvox voxelize: {n}");
    }
    if let Some(p) = &profiler {
        args.profile.emit(p)?;
    }
    let mut wrote = None;
    let mut level_set = None;
    if let (Some(out), GridWhat::Sdf) = (&args.out, args.what) {
        let ls = crate::api::levelset::level_set(&mesh, grid, args.half_width)
            .map_err(|e| e.for_input(&args.input))?;
        let bytes = crate::voxel::vdb::level_set_bytes(&ls);
        crate::io::write_atomic(out, |w| w.write_all(&bytes))?;
        wrote = Some(format!("wrote {}\n", out.display()));
        level_set = Some(serde_json::json!({
            "active_voxels": ls.active_count(),
            "leaves": ls.leaves.len(),
            "background": ls.background,
            "half_width": args.half_width,
        }));
    } else if let Some(out) = &args.out {
        grid.save_with(
            out,
            &SaveOptions {
                npy_packed: args.grid.npy_packed,
                ply_boundary: args.grid.ply_boundary,
            },
        )?;
        wrote = Some(match sidecar_of(out) {
            Some(side) => format!("wrote {} and {}\n", out.display(), side.display()),
            None if crate::io::is_stdout(out) => "wrote .binvox to standard output\n".into(),
            None => format!("wrote {}\n", out.display()),
        });
    }
    // With the grid on standard output, everything said goes to stderr.
    let to_stdout = args.out.as_deref().is_some_and(crate::io::is_stdout);
    let f = &grid.frame;
    let [nx, ny, nz] = f.dims;
    if args.json {
        let mut summary = result.summary_json();
        let extra = serde_json::json!({
            "input": args.input.display().to_string(),
            "res": args.grid.res,
            "gregory_level": args.gregory_level,
            "seconds": seconds,
            "profile": profiler.as_ref().map(|p| p.json()),
        });
        if let (Some(s), serde_json::Value::Object(e)) = (summary.as_object_mut(), extra) {
            s.extend(e);
            // Only for --what sdf: the occupancy summary stays as it was.
            if let Some(ls) = level_set {
                s.insert("level_set".into(), ls);
            }
        }
        let json = format!("{}\n", serde_json::to_string_pretty(&summary)?);
        if to_stdout {
            eprint!("{json}");
        } else {
            super::print_out(&json)?;
        }
        return Ok(());
    }
    let size = if f.cubic_voxels() {
        format!("voxel size {}", significant(f.voxel_size[0]))
    } else {
        format!(
            "voxel size {}×{}×{}",
            significant(f.voxel_size[0]),
            significant(f.voxel_size[1]),
            significant(f.voxel_size[2])
        )
    };
    let mut text = match args.gregory_level {
        Some(level) => format!(
            "{}: Gregory surface at level {level}, {nx}×{ny}×{nz} grid, {size}\n",
            args.input.display(),
        ),
        None => format!(
            "{}: {} triangles, {nx}×{ny}×{nz} grid, {size}\n",
            args.input.display(),
            report.triangles,
        ),
    };
    text.push_str(&format!(
        "method: {}{}\n",
        report.method.name(),
        report
            .method_reason
            .as_deref()
            .map(|r| format!(" ({r})"))
            .unwrap_or_default()
    ));
    if !report.layers.is_empty() {
        let l: Vec<String> = report
            .layers
            .iter()
            .map(|(a, l)| format!("{} {l}", a.name()))
            .collect();
        text.push_str(&format!("layers per axis: {}\n", l.join(", ")));
    }
    if let Some(g) = &report.gwn {
        text.push_str(&format!(
            "generalized winding number: {} boundary loops capped ({} edges), {} vertices welded, {} \
             fractional triangles; {} boxes and {} voxels bounded, {} voxels relabelled, {} decided \
             directly ({} by the plain sum), {} flipped\n",
            g.loops_capped,
            g.boundary_edges,
            g.welded_vertices,
            g.fractional_triangles,
            g.boxes_evaluated,
            g.voxels_evaluated,
            g.relabelled_voxels,
            g.direct_voxels,
            g.plain_sums,
            g.flipped
        ));
    }
    let what = match report.fill {
        Fill::Solid => "solid voxels",
        Fill::Surface => "surface voxels",
        Fill::Both => "solid + surface voxels",
    };
    text.push_str(&format!(
        "{what}: {}\ntotal time: {:.1} ms\n",
        grid.count(),
        seconds * 1e3
    ));
    text.push_str(wrote.as_deref().unwrap_or(""));
    // Per-pass GPU times only when asked for (--profile, --profile-json, --trace): the summary stays short.
    if to_stdout {
        eprint!("{text}");
    } else {
        super::print_out(&text)?;
    }
    Ok(())
}

/// The sidecar an output gets (`.npy`, `.raw`, `.vox`), if any.
fn sidecar_of(out: &std::path::Path) -> Option<std::path::PathBuf> {
    let ext = out.extension()?.to_str()?.to_ascii_lowercase();
    matches!(ext.as_str(), "npy" | "raw" | "vox").then(|| crate::voxel::export::sidecar_path(out))
}

/// `x` to 6 significant digits, in scientific notation outside 1e-4 … 1e7 (a tiny mesh's voxel is not
/// "0.000000", nor a huge one's 29 digits).
pub fn significant(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || !a.is_finite() {
        return format!("{x}");
    }
    if !(1e-4..1e7).contains(&a) {
        return format!("{x:.5e}");
    }
    let decimals = (5 - a.log10().floor() as i32).max(0) as usize;
    format!("{x:.decimals$}")
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

/// The bar of `gregvox batch` (models done of `models`, with an ETA), on a terminal only.
pub fn batch_bar(models: u64) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::with_draw_target(
        Some(models),
        indicatif::ProgressDrawTarget::stderr(),
    );
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} batch [{bar:30}] {pos}/{len} models ({per_sec}, ETA {eta})",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    Some(bar)
}
