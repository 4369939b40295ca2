//! `gregvox query`: winding numbers, occupancy and distances at given or sampled points, into an `.npz`
//! (a thin client of `api::query`).
use crate::api::query::{QueryJob, QueryOptions, QueryPoints, QueryWhat, SampleSpec, SdfSign};
use crate::api::{load_mesh, FillRule};
use crate::npy::write_npz;
use crate::voxel::gwn::Inside;
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use std::time::Instant;

/// `--sdf-sign`.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum SdfSignArg {
    /// Negative inside (libigl, Open3D, Warp).
    InsideNegative,
    /// Positive inside (trimesh, pysdf).
    InsidePositive,
}

/// `gregvox query`.
#[derive(Debug, Args)]
pub struct QueryArgs {
    /// The mesh (OBJ, STL, PLY, OFF, glTF/GLB).
    pub input: PathBuf,
    /// Query points: an (N, 3) float32 or float64 .npy array (world coordinates).
    #[arg(long, value_name = "P.npy", required_unless_present = "sample")]
    pub points: Option<PathBuf>,
    /// Sample the points instead: uniform:N (the padded box), near:SIGMA:N (area-weighted surface points
    /// moved by normal offsets of standard deviation SIGMA, mesh units), surface:N (surface points and
    /// normals, written as surface_points/surface_normals, not queried); comma-separated, in order.
    #[arg(long, value_name = "SPECS", conflicts_with = "points")]
    pub sample: Option<String>,
    /// What to compute, comma-separated: winding (float64), occupancy (bool), sdf and udf (float32).
    /// Default: winding,occupancy with --points, occupancy with --sample.
    #[arg(long, value_delimiter = ',')]
    pub what: Vec<String>,
    /// The output .npz: one array per name asked, in the order of the points (with --sample also
    /// `points`, the points queried).
    #[arg(long, value_name = "Q.npz")]
    pub out: PathBuf,
    /// Inside rule: gwn = |w| ≥ ½ (the default), gwn-positive = w ≥ ½ (libigl's convention).
    #[arg(long, value_enum, default_value = "gwn")]
    pub rule: FillRule,
    /// The sign of sdf.
    #[arg(long, value_enum, default_value = "inside-negative")]
    pub sdf_sign: SdfSignArg,
    /// Also write the nearest triangle's index (`face`, uint32), the closest point (`closest`) and its
    /// barycentric coordinates (`barycentric`), float32 (N, 3), for sdf/udf.
    #[arg(long)]
    pub closest: bool,
    /// The largest error of a winding number in `winding` (occupancy and sdf signs are decided by bounds,
    /// whatever this is).
    #[arg(long, default_value_t = 1e-6)]
    pub tolerance: f64,
    /// Seed of the samplers.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Padding of the uniform sampler's box, a fraction of its size on each side.
    #[arg(long, default_value_t = 0.1)]
    pub pad: f64,
    /// The Occupancy Networks layout: `occupancy` as packed bits (uint8, `np.unpackbits(a)[:N]`) and
    /// `points` as float16.
    #[arg(long)]
    pub compact: bool,
    /// Search the nearest triangles of sdf and udf on the Vulkan device (in f64, the CPU's search operation
    /// for operation: the same arrays; needs shaderFloat64, else the CPU searches).
    #[arg(long)]
    pub device: bool,
    /// With --device: also check every device answer on the host (about the CPU search's time again); the
    /// JSON summary's `device_check` counts the answers checked and corrected
    #[arg(long)]
    pub device_check: bool,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gregvox query`.
pub fn run(args: &QueryArgs) -> anyhow::Result<()> {
    let points = match (&args.points, &args.sample) {
        (Some(p), _) => QueryPoints::Given(std::sync::Arc::new(crate::npy::read_points(p)?)),
        (None, Some(specs)) => QueryPoints::Sample {
            specs: SampleSpec::parse_list(specs)?,
            pad: args.pad,
            seed: args.seed,
        },
        (None, None) => unreachable!("clap requires --points or --sample"),
    };
    let what = if args.what.is_empty() {
        points.default_what()
    } else {
        QueryWhat::parse_list(&args.what)?
    };
    let job = QueryJob {
        what,
        points,
        compact: args.compact,
        closest: args.closest,
        opts: query_options(args.rule, args.sdf_sign, args.tolerance)?,
    };
    job.check()?;
    if args.out.extension().and_then(|e| e.to_str()) != Some("npz") {
        anyhow::bail!("{}: the output must be an .npz", args.out.display());
    }
    crate::io::check_output(&args.out)?;
    let mesh = load_mesh(&args.input)?;
    let gpu = if args.device || args.device_check {
        if !job
            .what
            .iter()
            .any(|w| matches!(w, QueryWhat::Sdf | QueryWhat::Udf))
        {
            anyhow::bail!("--device searches the distances' nearest triangles: ask for sdf or udf");
        }
        Some(crate::api::Gpu::new()?)
    } else {
        None
    };
    let start = Instant::now();
    let out = job
        .run_on(&mesh, &None, gpu.as_ref(), args.device_check)
        .map_err(|e| e.for_input(&args.input))?;
    let seconds = start.elapsed().as_secs_f64();
    write_npz(&args.out, &out.arrays)?;
    let names: Vec<&str> = out.arrays.iter().map(|(n, _)| *n).collect();
    if args.json {
        let j = serde_json::json!({
            "input": args.input.display().to_string(),
            "points": out.points,
            "arrays": names,
            "prepare_seconds": out.prepare_seconds,
            "seconds": seconds,
            "device_check": out.device_check,
            "out": args.out.display().to_string(),
        });
        crate::cli::print_out(&format!("{j}\n"))?;
    } else {
        crate::cli::print_out(&format!(
            "{} points of {}: {} in {:.3} s (preparing {:.3} s) → {}\n",
            out.points,
            args.input.display(),
            names.join(", "),
            seconds,
            out.prepare_seconds,
            args.out.display()
        ))?;
    }
    Ok(())
}

/// The query options of `--rule`, `--sdf-sign` and `--tolerance` (shared with `gregvox batch --query`).
pub fn query_options(
    rule: FillRule,
    sdf_sign: SdfSignArg,
    tolerance: f64,
) -> anyhow::Result<QueryOptions> {
    let inside = match rule {
        FillRule::Gwn => Inside::Magnitude,
        FillRule::GwnPositive => Inside::Positive,
        r => anyhow::bail!(
            "--rule {}: queries take gwn or gwn-positive",
            r.to_possible_value()
                .map_or("?".into(), |v| v.get_name().to_string())
        ),
    };
    Ok(QueryOptions {
        inside,
        sdf_sign: match sdf_sign {
            SdfSignArg::InsideNegative => SdfSign::InsideNegative,
            SdfSignArg::InsidePositive => SdfSign::InsidePositive,
        },
        tolerance,
        ..QueryOptions::default()
    })
}
