//! `gregvox batch INPUT… --res R --out-dir D [--format F | --name TEMPLATE] [--shard I/N] [--report FILE]`,
//! or `gregvox batch INPUT… --query SPECS [--what …] --out-dir D …` (point queries, one `.npz` a model):
//! argument parsing and printing over `api::batch` (which holds the policy: the sorted input list,
//! sharding, resume, output names, the loader → device → writer pipeline).
use super::voxelize::GridArgs;
use crate::api::batch::{
    append_record, batch_device, collect_inputs, run_batch, BatchOptions, ModelStatus, OutputNames,
    Shard,
};
use crate::api::query::{QueryJob, QueryPoints, QueryWhat, SampleSpec};
use crate::api::SaveOptions;
use crate::voxel::export::check_format;
use anyhow::{bail, Context};
use clap::Args;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Arguments of `gregvox batch`.
#[derive(Debug, Args)]
// A query batch has no grid: the grid size is asked for in `run` when there is no --query.
#[command(mut_group("size", |g| g.required(false)))]
pub struct BatchArgs {
    /// Mesh files, folders (searched recursively for .obj .stl .ply .off .gltf .glb), glob patterns
    /// (quoted: 'data/**/*.obj') or manifests (.txt/.lst: one path a line; .csv: a `path` column; .jsonl: a
    /// "path" member).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    #[command(flatten)]
    pub grid: GridArgs,
    /// Output folder; each model's relative folder is kept.
    #[arg(long, value_name = "D")]
    pub out_dir: Option<PathBuf>,
    /// Output format when no --name is given (every voxelize --out format: .obj/.stl/.glb write the
    /// boundary mesh).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(crate::voxel::export::FORMATS), default_value = "binvox")]
    pub format: String,
    /// Output file name template: {stem}, {name}, {dir}, {res}, {index} (e.g. '{stem}_{res}.npy').
    #[arg(long, value_name = "TEMPLATE")]
    pub name: Option<String>,
    /// Redo models whose output exists (default: skip them, so a killed batch resumes).
    #[arg(long)]
    pub no_resume: bool,
    /// Take every N-th model of the sorted list, starting at I (0 ≤ I < N). Without it,
    /// SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT, else RANK/WORLD_SIZE, are read when set.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// Append one JSON line a model here (input, output, status, error, triangles, watertight, boundary
    /// loops, layers, solid voxels, method, seconds).
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// A model taking longer than S seconds from the start of its load fails (checked after the load and
    /// between the stages of its voxelization) and the batch goes on.
    #[arg(long, value_name = "S")]
    pub timeout_per_model: Option<f64>,
    /// Loader and writer threads (each; default: the cores, at most 8).
    #[arg(long, value_name = "N")]
    pub workers: Option<usize>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
    /// Query points instead of voxelizing, one .npz a model: the samplers of `gregvox query --sample`
    /// (uniform:N, near:SIGMA:N, surface:N), drawn for each model with the seed --seed ⊕ FNV-1a of its
    /// relative path (independent between models, the same however the list is sharded or resumed).
    #[arg(long, value_name = "SPECS", conflicts_with = "query_points")]
    pub query: Option<String>,
    /// Query these points (an (N, 3) float32/float64 .npy, world coordinates) on every model instead of
    /// voxelizing.
    #[arg(long, value_name = "P.npy")]
    pub query_points: Option<PathBuf>,
    /// With --query/--query-points: what to compute, comma-separated: winding, occupancy, sdf, udf
    /// (default: occupancy with --query, winding,occupancy with --query-points).
    #[arg(long, value_delimiter = ',')]
    pub what: Vec<String>,
    /// With --query: padding of the uniform sampler's box, a fraction of its size on each side.
    #[arg(long, default_value_t = 0.1)]
    pub query_pad: f64,
    /// With --query: the seed the per-model seeds are made from.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// With --query: the Occupancy Networks layout (occupancy as packed bits, points as float16).
    #[arg(long)]
    pub compact: bool,
    /// With --query: also `face`, `closest` and `barycentric` (needs sdf or udf).
    #[arg(long)]
    pub closest: bool,
    /// With --query: the sign of sdf.
    #[arg(long, value_enum, default_value = "inside-negative")]
    pub sdf_sign: super::query::SdfSignArg,
    /// With --query: the largest error of a winding number in `winding`.
    #[arg(long, default_value_t = 1e-6)]
    pub tolerance: f64,
}

/// The query job of `--query`/`--query-points`, if any.
fn query_job(args: &BatchArgs) -> anyhow::Result<Option<QueryJob>> {
    let points = match (&args.query, &args.query_points) {
        (Some(specs), _) => QueryPoints::Sample {
            specs: SampleSpec::parse_list(specs)?,
            pad: args.query_pad,
            seed: args.seed,
        },
        (None, Some(p)) => QueryPoints::Given(Arc::new(crate::npy::read_points(p)?)),
        (None, None) => {
            if !args.what.is_empty() || args.compact || args.closest {
                bail!("--what, --compact and --closest need --query or --query-points");
            }
            return Ok(None);
        }
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
        opts: super::query::query_options(args.grid.rule, args.sdf_sign, args.tolerance)?,
    };
    job.check()?;
    Ok(Some(job))
}

/// Runs `gregvox batch`; fails (after finishing the list) when any model failed.
pub fn run(args: &BatchArgs) -> anyhow::Result<()> {
    let query = query_job(args)?;
    let voxelize = match &query {
        Some(_) => crate::api::VoxelizeOptions::default(),
        None => args.grid.options()?,
    };
    if let Some(t) = args.timeout_per_model {
        if !(t.is_finite() && t > 0.0) {
            bail!("--timeout-per-model {t}: give a number of seconds > 0");
        }
    }
    let names = match (&args.out_dir, &args.name) {
        (Some(dir), name) => Some(OutputNames {
            dir: dir.clone(),
            template: name.clone(),
            // A query writes its arrays: always an .npz.
            format: if query.is_some() {
                "npz".into()
            } else {
                args.format.clone()
            },
        }),
        (None, Some(_)) => bail!("--name needs --out-dir"),
        (None, None) => None,
    };
    if let (Some(n), Some(_)) = (&names, &query) {
        if let Some(t) = &n.template {
            if !t.ends_with(".npz") || t.contains("{res}") {
                bail!("--name {t}: a query batch writes .npz files and has no grid ({{res}})");
            }
        }
        crate::io::check_output_folder(&n.dir)?;
    } else if let Some(n) = &names {
        let probe = crate::api::GridFrame::cubic(1, [0.0; 3], 1.0);
        let example = match &n.template {
            Some(t) => PathBuf::from(t.replace(['{', '}'], "")),
            None => PathBuf::from(format!("x.{}", n.format)),
        };
        check_format(&probe, &example, None)?;
        crate::io::check_output_folder(&n.dir)?;
    }
    if let Some(report) = &args.report {
        // The report's folder is made as the output folder is (`--report out/report.jsonl` beside
        // `--out-dir out/voxels`), then the report itself is tried.
        if let Some(parent) = report.parent().filter(|p| !p.as_os_str().is_empty()) {
            crate::io::check_output_folder(parent)?;
            std::fs::create_dir_all(parent).map_err(|e| crate::Error::io(parent, e))?;
        }
        crate::io::check_output(report)?;
    }
    let shard = match &args.shard {
        Some(s) => Some(Shard::parse(s)?),
        None => Shard::from_env(|k| std::env::var(k).ok())?,
    };
    let all = collect_inputs(&args.inputs)?;
    let inputs = match shard {
        Some(s) => s.select(&all),
        None => all.clone(),
    };
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // A second Ctrl-C kills as usual: the handler only asks once.
        let _ = ctrlc::set_handler(move || {
            if stop.swap(true, Ordering::SeqCst) {
                crate::io::exit_removing_temporaries(130);
            }
            eprintln!("gregvox batch: stopping after the models in flight (Ctrl-C again to kill)");
        });
    }
    // Queries run on the CPU's cores: no device to make.
    let gpu = if query.is_some() {
        None
    } else {
        batch_device(args.grid.method)?
    };
    let workers = args.workers.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(2)
            .min(8)
    });
    let opts = BatchOptions {
        voxelize,
        query,
        names,
        save: SaveOptions {
            npy_packed: args.grid.npy_packed,
            ply_boundary: args.grid.ply_boundary,
        },
        resume: !args.no_resume,
        timeout: args.timeout_per_model,
        workers,
        queue: 2 * workers,
    };
    let bar = super::voxelize::batch_bar(inputs.len() as u64);
    let mut failures = Vec::new();
    let summary = run_batch(gpu.as_ref(), &inputs, &opts, &stop, |rec| {
        if let Some(path) = &args.report {
            append_record(path, rec)?;
        }
        if rec.status == ModelStatus::Failed {
            let msg = rec.error.clone().unwrap_or_default();
            match &bar {
                Some(b) => b.println(format!("gregvox batch: failed: {msg}")),
                None => eprintln!("gregvox batch: failed: {msg}"),
            }
            failures.push(msg);
        }
        if let Some(b) = &bar {
            b.inc(1);
        }
        Ok(())
    })
    .with_context(|| "gregvox batch")?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let rate = (summary.done as f64) / summary.seconds.max(1e-9);
    if args.json {
        let j = serde_json::json!({
            "models": inputs.len(),
            "listed": all.len(),
            "shard": shard.map(|s| format!("{}/{}", s.index, s.count)),
            "done": summary.done,
            "skipped": summary.skipped,
            "failed": summary.failed,
            "interrupted": summary.interrupted,
            "seconds": summary.seconds,
            "models_per_second": rate,
        });
        super::print_out(&format!("{}\n", serde_json::to_string_pretty(&j)?))?;
    } else {
        super::print_out(&format!(
            "{} models{}: {} done, {} skipped, {} failed in {:.1} s ({rate:.2} models/s){}\n",
            inputs.len(),
            shard
                .map(|s| format!(" (shard {}/{} of {})", s.index, s.count, all.len()))
                .unwrap_or_default(),
            summary.done,
            summary.skipped,
            summary.failed,
            summary.seconds,
            if summary.interrupted {
                "; interrupted"
            } else {
                ""
            }
        ))?;
    }
    if summary.interrupted {
        bail!("interrupted: run the same command again to finish (finished models are skipped)");
    }
    if !failures.is_empty() {
        bail!(
            "{} of {} models failed (listed above{})",
            failures.len(),
            inputs.len(),
            if args.report.is_some() {
                " and in the report"
            } else {
                ""
            }
        );
    }
    Ok(())
}
