//! `gregvox tessellate CAGE|IN.gzjson --level N --out OUT.obj` (CAGE: any mesh file): argument parsing and printing over
//! `Gpu::tessellate` (api::tessellate), which evaluates every patch on the GPU (compute or vertex-pull path)
//! in the contract order of docs/ARCHITECTURE.md (one (L+1)² grid per patch, u along the face's first edge,
//! rows of u inner).
use crate::api::tessellate::{is_beziex, AdaptiveView, EvalPath, Patches, TessellateOptions};
use crate::api::{Deformation, Gpu, Profiler, Tangents};
use crate::args::ProfileArgs;
use anyhow::{bail, Context as _};
use clap::{Args, ValueEnum};
use std::path::PathBuf;

/// Edge-point masks at extraordinary vertices (docs/notes/gregory.md §3.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TangentMode {
    /// OpenSubdiv's masks (its GREGORY_BASIS points).
    Opensubdiv,
    /// The exact Catmull–Clark limit-tangent masks (EV normals on the limit tangent plane).
    Exact,
}

impl From<TangentMode> for Tangents {
    fn from(t: TangentMode) -> Tangents {
        match t {
            TangentMode::Opensubdiv => Tangents::OpenSubdiv,
            TangentMode::Exact => Tangents::Exact,
        }
    }
}

/// Arguments of `gregvox tessellate`.
#[derive(Debug, Args)]
pub struct TessellateArgs {
    /// A quad cage as a mesh file (OBJ, STL, PLY, OFF, glTF/GLB), for ACC-2 Gregory patches, or a Beziex model (.gzjson).
    pub input: PathBuf,
    /// Tessellation level L (1–64): (L+1)² vertices per patch.
    #[arg(long, default_value_t = 8)]
    pub level: u32,
    /// Output OBJ (v, vn and f lines); `-` writes it to standard output (the summary then goes to stderr).
    /// One welded mesh: a closed cage gives a closed, watertight surface (see --no-weld).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write one separate (L+1)² grid per patch in the contract order (rows of u inner) instead of the
    /// welded mesh: shared edges then appear once per patch.
    #[arg(long)]
    pub no_weld: bool,
    /// Evaluation path.
    #[arg(long, value_enum, default_value = "compute")]
    pub path: EvalPath,
    /// One frame of cage animation before evaluation: twist, bend or wave, optionally `:AMOUNT` (default 1).
    #[arg(long)]
    pub deform: Option<String>,
    /// Re-run the GPU passes K times (for timing).
    #[arg(long, default_value_t = 1)]
    pub repeat: u32,
    /// Edge-point masks of a cage's ACC-2 patches at extraordinary vertices.
    #[arg(long, value_enum, default_value = "opensubdiv")]
    pub tangents: TangentMode,
    /// Isolation level L of a cage: refine it L times before building patches, as OpenSubdiv's
    /// RefineAdaptive(L) isolates irregular features (default: the least exact level, ⌈largest
    /// semi-sharp sharpness⌉, 1 with non-quad faces, else 0).
    #[arg(long, value_name = "L")]
    pub isolation: Option<u32>,
    /// Screen-space adaptive levels: target PIXELS per tessellation segment on screen, each patch's level
    /// between 1 and --level (compute path, cages only), listed in a `# levels` comment. Welded and
    /// crack-free; with --no-weld the OBJ holds every patch's own (L_p+1)² grid in patch order (rows of u
    /// inner).
    #[arg(long, value_name = "PIXELS")]
    pub adaptive: Option<f32>,
    /// With --adaptive: the eye position `X,Y,Z`, looking at the cage's bounding-box centre (up +Y, 45°
    /// vertical field of view). Default: on +Z, 1.5 bounding-box diagonals from the centre.
    #[arg(long, value_name = "X,Y,Z")]
    pub eye: Option<String>,
    /// With --adaptive: the viewport `WxH` in pixels (default 1280x720).
    #[arg(long, value_name = "WxH")]
    pub viewport: Option<String>,
    /// Print vertex count, the largest normal jump across shared patch edges and the throughput.
    #[arg(long)]
    pub stats: bool,
    #[command(flatten)]
    pub profile: ProfileArgs,
}

/// Parses `twist|bend|wave[:AMOUNT]`.
pub fn parse_deform(s: &str) -> anyhow::Result<(Deformation, f32)> {
    let (name, amount) = match s.split_once(':') {
        Some((n, a)) => {
            let x: f64 = a
                .parse()
                .ok()
                .filter(|x: &f64| !x.is_nan())
                .with_context(|| format!("--deform amount '{a}' is not a number"))?;
            if x.abs() > f32::MAX as f64 {
                bail!("--deform amount {a} is out of range (at most ±3.4e38, the f32 range)");
            }
            (n, x as f32)
        }
        None => (s, 1.0),
    };
    let mode = match name {
        "twist" => Deformation::Twist,
        "bend" => Deformation::Bend,
        "wave" => Deformation::Wave,
        other => bail!("--deform '{other}' is not one of twist, bend, wave"),
    };
    Ok((mode, amount))
}

/// Runs `gregvox tessellate`: argument parsing, one `Gpu::tessellate` call, the OBJ and the statistics.
pub fn run(args: &TessellateArgs) -> anyhow::Result<()> {
    let deform = args.deform.as_deref().map(parse_deform).transpose()?;
    let opts = TessellateOptions {
        level: args.level,
        path: args.path,
        deform,
        adaptive: parse_adaptive(args)?,
        repeat: args.repeat,
    };
    opts.validate()?;
    if is_beziex(&args.input) && args.tangents != TangentMode::Opensubdiv {
        bail!(
            "--tangents chooses a cage's edge-point masks; {} is a Beziex model",
            args.input.display()
        );
    }
    // Outputs before any work: a path that cannot be written fails now, not after the evaluation.
    if let Some(out) = &args.out {
        crate::io::check_output(out)?;
    }
    args.profile.check_outputs()?;
    if is_beziex(&args.input) && args.isolation.is_some() {
        bail!(
            "--isolation refines a cage; {} is a Beziex model",
            args.input.display()
        );
    }
    let patches = if is_beziex(&args.input) {
        Patches::load(&args.input, args.tangents.into())?
    } else {
        let mut cage = crate::api::load_cage(&args.input)?;
        cage.tags.isolation = args.isolation;
        Patches::from_tagged_cage(&cage, args.tangents.into())
            .map_err(|e| e.for_input(&args.input))?
    };
    if let Some(n) = patches.note() {
        eprintln!("gregvox tessellate: {n}");
    }
    let gpu = Gpu::new()?;
    let mut profiler = Profiler::new(gpu.context(), 1, 4 * args.repeat.min(1000) + 8)?;
    let t = gpu
        .tessellate(&patches, &opts, &mut profiler)
        .map_err(|e| e.for_input(&args.input))?;
    args.profile.emit(&profiler)?;
    let to_stdout = args.out.as_deref().is_some_and(crate::io::is_stdout);
    // What was done and where it went, on stderr (stdout may be the OBJ itself).
    match &args.out {
        Some(path) => {
            let (vertices, triangles) = t.write_obj(path, !args.no_weld)?;
            let target = if to_stdout {
                "standard output".to_string()
            } else {
                path.display().to_string()
            };
            let layout = if args.no_weld {
                "one grid per patch"
            } else {
                "welded"
            };
            eprintln!(
                "wrote {target} ({} patches, {layout}: {vertices} vertices, {triangles} triangles)",
                t.patches
            );
        }
        None if !args.stats => eprintln!(
            "gregvox tessellate: evaluated {} patches ({} vertices); nothing written: give --out FILE.obj \
             (or --out - for standard output), or --stats",
            t.patches,
            t.vertices.len()
        ),
        None => {}
    }
    if args.stats {
        // One pass over the samples: a cage's jumps carry the G1 figure and the singular points.
        let cage = t.cage_jumps(&patches);
        let jump = cage
            .as_ref()
            .map_or_else(|| t.max_normal_jump(&patches), |j| j.worst);
        let eval_ms: f64 = profiler
            .stats()
            .iter()
            .filter(|s| {
                s.name.starts_with("gregory_eval")
                    || s.name == "beziex_eval"
                    || s.name == "vertex_pull"
            })
            .map(|s| s.median_ms)
            .sum();
        let rate = if eval_ms > 0.0 {
            t.vertices.len() as f64 / (eval_ms * 1e-3)
        } else {
            0.0
        };
        let mut text = format!("vertices: {}\npatches: {}\n", t.vertices.len(), t.patches);
        let singular = cage.map(|j| j.singular).unwrap_or_default();
        if singular.is_empty() {
            text += &format!("max normal jump across shared edges: {jump:.3e} rad\n");
        } else {
            // A valence-2 interior vertex has no tangent plane: its patches' normals differ there by
            // construction, so it is reported by vertex and left out of the G1 measure.
            text += &format!(
                "singular points (interior cage vertices of valence 2, no tangent plane): {}\n",
                singular.len()
            );
            for s in singular.iter().take(20) {
                let o = t.origin;
                let p = [0, 1, 2].map(|k| s.position[k] as f64 + o[k]);
                text += &format!(
                    "  vertex {} at ({}, {}, {}): normals of its {} patches differ by {:.3} rad\n",
                    s.point.vertex + 1,
                    p[0],
                    p[1],
                    p[2],
                    s.point.corners.len(),
                    s.jump
                );
            }
            if singular.len() > 20 {
                text += &format!("  … and {} more\n", singular.len() - 20);
            }
            text += &format!(
                "max normal jump across shared edges, away from the singular points: {jump:.3e} rad\n"
            );
        }
        text += &format!(
            "evaluation: {eval_ms:.3} ms median ({:.1} M vertices/s)\n",
            rate / 1e6
        );
        if to_stdout {
            eprint!("{text}");
        } else {
            super::print_out(&text)?;
        }
    }
    Ok(())
}

/// Parses `--adaptive PIXELS [--eye X,Y,Z] [--viewport WxH]`.
fn parse_adaptive(args: &TessellateArgs) -> anyhow::Result<Option<AdaptiveView>> {
    let Some(px) = args.adaptive else {
        if args.eye.is_some() {
            bail!("--eye sets the view of --adaptive, which is not given");
        }
        if args.viewport.is_some() {
            bail!("--viewport sets the view of --adaptive, which is not given");
        }
        return Ok(None);
    };
    let eye = match &args.eye {
        None => None,
        Some(e) => {
            let c: Vec<f32> = e
                .split(',')
                .map(|x| x.trim().parse::<f32>())
                .collect::<Result<_, _>>()
                .ok()
                .filter(|c: &Vec<f32>| c.len() == 3 && c.iter().all(|x| x.is_finite()))
                .ok_or_else(|| anyhow::anyhow!("--eye '{e}' is not three numbers X,Y,Z"))?;
            Some([c[0], c[1], c[2]])
        }
    };
    let viewport = args.viewport.as_deref().unwrap_or("1280x720");
    let vp = viewport
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some([w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?]))
        .filter(|v| v[0] > 0 && v[1] > 0)
        .ok_or_else(|| anyhow::anyhow!("--viewport '{viewport}' is not WIDTHxHEIGHT in pixels"))?;
    Ok(Some(AdaptiveView {
        pixels_per_segment: px,
        eye,
        viewport: [vp[0] as f32, vp[1] as f32],
    }))
}
