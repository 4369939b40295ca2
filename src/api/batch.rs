//! Many models, one device: the library side of `gregvox batch`. [`collect_inputs`] turns files, folders,
//! globs and manifests into one sorted list; [`Shard`] takes every N-th of it; [`OutputNames`] names each
//! model's output; [`run_batch`] voxelizes the list with one [`Gpu`] (or the CPU), loading models on worker
//! threads ahead of the device and writing outputs behind it, and reports one [`ModelRecord`] a model.
//! With [`BatchOptions::query`] the same pipeline answers a point query on each model instead
//! ([`QueryJob::for_model`](super::query::QueryJob::for_model): its own seed) and writes its `.npz`.
//!
//! Invariants:
//! - The input list is sorted by path (bytes) and has no duplicates, so every process of a sharded run
//!   sees the same list: shard I of N is the models at positions I, I + N, I + 2N, …, and the N shards
//!   partition the list whatever N.
//! - Outputs are written through `io::write_atomic` (temporary file, then rename; the grid, then its
//!   sidecar), so a file that exists is complete: resuming skips exactly the models whose output and
//!   sidecar both exist, and a run killed at any moment and started again does every model exactly once.
//! - Temporaries of killed runs (their process gone) are removed from the output folder when a batch
//!   starts.
//! - A model that fails (unreadable, malformed, over a limit, a panic while loading or voxelizing) is
//!   recorded with its one-line error and the batch goes on; nothing is written for it.
//! - Memory stays flat however long the list: at most `queue` loaded models wait for the device and at most
//!   `queue` grids wait for their writer.
use super::{
    load_mesh, voxelize, voxelize_on_cpu, Deadline, Gpu, Method, Voxelization, VoxelizeOptions,
};
use crate::engine::voxelize::checkpoint;
use crate::error::{Error, Result};
use crate::voxel::export::SaveOptions;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, Mutex};
use std::time::Instant;

/// Mesh file extensions a folder is searched for (lower case).
pub const MESH_EXTENSIONS: [&str; 6] = ["obj", "stl", "ply", "off", "gltf", "glb"];

/// One model of a batch.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct BatchInput {
    /// The file.
    pub path: PathBuf,
    /// Its path below the folder it was found in (its file name for a file given directly): outputs keep it.
    pub relative: PathBuf,
}

fn is_mesh(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| MESH_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
}

fn file_input(path: &Path) -> BatchInput {
    BatchInput {
        path: path.to_path_buf(),
        relative: path.file_name().map(PathBuf::from).unwrap_or_default(),
    }
}

/// The paths of a manifest: one a line (`.txt`, `.lst`), the `path` column of a CSV with a header
/// (`.csv`), or the `"path"` member of each JSON object line (`.jsonl`). Relative paths are relative to the
/// manifest's folder; blank lines and lines starting with `#` are skipped.
pub fn read_manifest(manifest: &Path) -> Result<Vec<PathBuf>> {
    let text = std::fs::read_to_string(manifest).map_err(|e| Error::io(manifest, e))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let base = manifest.parent().unwrap_or(Path::new(""));
    let bad = |line: usize, what: String| {
        Error::Invalid(format!("{}: line {line}: {what}", manifest.display()))
    };
    let ext = manifest
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let mut paths = Vec::new();
    match ext.as_deref() {
        Some("csv") => {
            let mut reader = csv::ReaderBuilder::new()
                .flexible(true)
                .from_reader(text.as_bytes());
            let headers = reader
                .headers()
                .map_err(|e| bad(1, format!("not a CSV header ({e})")))?
                .clone();
            let column = headers
                .iter()
                .position(|h| h.trim().eq_ignore_ascii_case("path"))
                .ok_or_else(|| bad(1, "no `path` column in the header".into()))?;
            for (n, record) in reader.records().enumerate() {
                let record = record.map_err(|e| bad(n + 2, e.to_string()))?;
                let p = record
                    .get(column)
                    .map(str::trim)
                    .filter(|p| !p.is_empty())
                    .ok_or_else(|| bad(n + 2, "no path in the `path` column".into()))?;
                paths.push(base.join(p));
            }
        }
        Some("jsonl") => {
            for (n, line) in text.lines().enumerate() {
                let line = line.trim();
                if line.is_empty() {
                    continue;
                }
                let v: serde_json::Value =
                    serde_json::from_str(line).map_err(|e| bad(n + 1, e.to_string()))?;
                let p = v["path"]
                    .as_str()
                    .ok_or_else(|| bad(n + 1, "no string member \"path\"".into()))?;
                paths.push(base.join(p));
            }
        }
        _ => {
            for line in text.lines() {
                let line = line.trim();
                if !line.is_empty() && !line.starts_with('#') {
                    paths.push(base.join(line));
                }
            }
        }
    }
    Ok(paths)
}

/// Whether `spec` names a manifest rather than a mesh.
fn is_manifest(spec: &Path) -> bool {
    spec.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| ["txt", "lst", "csv", "jsonl"].contains(&e.to_ascii_lowercase().as_str()))
}

/// The models `specs` name, sorted by path, each once: a mesh file as it is, a folder searched recursively
/// for [`MESH_EXTENSIONS`] (in any case; `.mtl` and textures beside the meshes are ignored), a glob pattern
/// (`*`, `?`, `[…]`, `**`), or a manifest ([`read_manifest`]). A spec that names nothing is an error, as is
/// a manifest line naming a missing file (so a typo never shrinks a dataset silently).
pub fn collect_inputs(specs: &[PathBuf]) -> Result<Vec<BatchInput>> {
    let mut out = Vec::new();
    for spec in specs {
        let text = spec.to_string_lossy();
        if spec.is_dir() {
            let before = out.len();
            for entry in walkdir::WalkDir::new(spec).follow_links(true) {
                let entry = entry.map_err(|e| {
                    Error::Invalid(format!("{}: cannot list the folder: {e}", spec.display()))
                })?;
                if entry.file_type().is_file() && is_mesh(entry.path()) {
                    out.push(BatchInput {
                        path: entry.path().to_path_buf(),
                        relative: entry
                            .path()
                            .strip_prefix(spec)
                            .unwrap_or(entry.path())
                            .to_path_buf(),
                    });
                }
            }
            if out.len() == before {
                return Err(Error::Invalid(format!(
                    "{}: no mesh file ({}) in this folder",
                    spec.display(),
                    MESH_EXTENSIONS.join(", ")
                )));
            }
        } else if spec.is_file() && is_manifest(spec) {
            for p in read_manifest(spec)? {
                if !p.is_file() {
                    return Err(Error::Invalid(format!(
                        "{}: lists {}, which is not a file",
                        spec.display(),
                        p.display()
                    )));
                }
                out.push(file_input(&p));
            }
        } else if spec.is_file() {
            out.push(file_input(spec));
        } else if text.contains(['*', '?', '[']) {
            let paths = glob::glob(&text)
                .map_err(|e| Error::Invalid(format!("{text}: not a valid glob pattern ({e})")))?;
            let before = out.len();
            for p in paths {
                let p = p.map_err(|e| Error::Invalid(format!("{text}: {e}")))?;
                if p.is_file() {
                    out.push(file_input(&p));
                }
            }
            if out.len() == before {
                return Err(Error::Invalid(format!(
                    "{text}: the pattern matches no file"
                )));
            }
        } else {
            return Err(Error::Invalid(format!(
                "{}: no such file, folder or pattern",
                spec.display()
            )));
        }
    }
    out.sort();
    out.dedup_by(|a, b| a.path == b.path);
    Ok(out)
}

/// Shard `index` of `count` of a sorted list: the models at positions index, index + count, …
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    /// `I/N` with 0 ≤ I < N.
    pub fn parse(s: &str) -> Result<Shard> {
        let bad = || Error::Invalid(format!("--shard {s}: give I/N with 0 ≤ I < N (e.g. 0/4)"));
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) = (
            i.trim().parse::<usize>().map_err(|_| bad())?,
            n.trim().parse::<usize>().map_err(|_| bad())?,
        );
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }

    /// The shard a job runner set in the environment `var` reads: Slurm's `SLURM_ARRAY_TASK_ID` with
    /// `SLURM_ARRAY_TASK_COUNT` (the task id made relative to `SLURM_ARRAY_TASK_MIN` when set), else
    /// `RANK` with `WORLD_SIZE` (torch.distributed, MPI wrappers). `None` when neither pair is set.
    pub fn from_env(var: impl Fn(&str) -> Option<String>) -> Result<Option<Shard>> {
        let num =
            |name: &str| -> Result<Option<usize>> {
                match var(name) {
                    None => Ok(None),
                    Some(v) => v.trim().parse::<usize>().map(Some).map_err(|_| {
                        Error::Invalid(format!("{name}={v}: not a non-negative integer"))
                    }),
                }
            };
        let pairs = [
            ("SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_COUNT"),
            ("RANK", "WORLD_SIZE"),
        ];
        for (id, count) in pairs {
            if let (Some(mut i), Some(n)) = (num(id)?, num(count)?) {
                if id.starts_with("SLURM") {
                    i -= num("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0).min(i);
                }
                if n == 0 || i >= n {
                    return Err(Error::Invalid(format!(
                        "{id}={i} and {count}={n}: the task index must be below the count"
                    )));
                }
                return Ok(Some(Shard { index: i, count: n }));
            }
        }
        Ok(None)
    }

    /// This shard's part of `items` (sorted).
    pub fn select<T: Clone>(&self, items: &[T]) -> Vec<T> {
        items
            .iter()
            .skip(self.index)
            .step_by(self.count)
            .cloned()
            .collect()
    }
}

/// How outputs are named: in `dir`, keeping each input's relative folder, either `{stem}.{format}` or a
/// template with `{stem}` (file name without extension), `{name}` (file name), `{dir}` (relative folder),
/// `{res}` (the grid's largest dimension) and `{index}` (position in the sorted list).
#[derive(Clone, Debug)]
pub struct OutputNames {
    pub dir: PathBuf,
    /// The template, e.g. `{stem}_{res}.npy`; `None`: `{stem}.` + `format`.
    pub template: Option<String>,
    /// The output extension when no template is given (binvox, npy, nrrd, raw, vox).
    pub format: String,
}

impl OutputNames {
    /// The output of `input` (at `index` of the list) on a grid whose largest dimension is `res`.
    pub fn output(&self, input: &BatchInput, index: usize, res: u32) -> PathBuf {
        let stem = input
            .relative
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let name = input
            .relative
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let folder = input.relative.parent().unwrap_or(Path::new(""));
        let file = match &self.template {
            Some(t) => t
                .replace("{stem}", &stem)
                .replace("{name}", &name)
                .replace("{dir}", &folder.to_string_lossy())
                .replace("{res}", &res.to_string())
                .replace("{index}", &index.to_string()),
            None => format!("{stem}.{}", self.format),
        };
        if self
            .template
            .as_deref()
            .is_some_and(|t| t.contains("{dir}"))
        {
            self.dir.join(file)
        } else {
            self.dir.join(folder).join(file)
        }
    }
}

impl OutputNames {
    /// Whether a name depends on the grid (`{res}`), which only the loaded mesh gives.
    pub fn needs_grid(&self) -> bool {
        self.template
            .as_deref()
            .is_some_and(|t| t.contains("{res}"))
    }
}

/// Whether every file of output `out` exists: written atomically, so complete.
fn complete(out: &Path) -> bool {
    output_files(out).iter().all(|f| f.is_file())
}

/// The files an output path stands for: the grid, and its sidecar (`PATH.json`) for `.npy`, `.raw` and `.vox`.
pub fn output_files(out: &Path) -> Vec<PathBuf> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let mut files = vec![out.to_path_buf()];
    if matches!(ext.as_deref(), Some("npy" | "raw" | "vox")) {
        files.push(crate::voxel::export::sidecar_path(out));
    }
    files
}

/// What happened to one model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ModelStatus {
    Done,
    /// Its output existed (resume).
    Skipped,
    Failed,
}

/// One line of the batch report.
#[derive(Clone, Debug, Serialize)]
pub struct ModelRecord {
    pub input: String,
    pub output: Option<String>,
    pub status: ModelStatus,
    pub error: Option<String>,
    pub triangles: Option<usize>,
    pub watertight: Option<bool>,
    pub boundary_loops: Option<usize>,
    pub layers: Option<u32>,
    pub solid_voxels: Option<u64>,
    pub method: Option<Method>,
    /// Points queried (`--query`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub points: Option<usize>,
    /// Points found inside (`--query` with occupancy).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inside_points: Option<u64>,
    /// The seed the model's points were drawn with (`--query` with samplers; see `QueryJob::for_model`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// The model's own work: loading, voxelizing and writing it (not the time it spent queued between
    /// them, behind other models).
    pub seconds: f64,
    /// The process's resident memory when the model was finished, in MiB (Linux; `None` elsewhere): flat
    /// over a long batch.
    pub rss_mib: Option<f64>,
}

/// The process's resident set size in MiB, from `/proc/self/status` (`None` where there is none).
pub fn resident_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

impl ModelRecord {
    fn new(input: &BatchInput, status: ModelStatus) -> ModelRecord {
        ModelRecord {
            input: input.path.display().to_string(),
            output: None,
            status,
            error: None,
            triangles: None,
            watertight: None,
            boundary_loops: None,
            layers: None,
            solid_voxels: None,
            method: None,
            points: None,
            inside_points: None,
            seed: None,
            seconds: 0.0,
            rss_mib: None,
        }
    }
}

/// A batch's options.
#[derive(Clone)]
pub struct BatchOptions {
    /// Applied to every model.
    pub voxelize: VoxelizeOptions,
    /// Query points instead of voxelizing: each model's job is this one's
    /// [`QueryJob::for_model`](super::query::QueryJob::for_model), written as an `.npz`.
    pub query: Option<super::query::QueryJob>,
    /// `None`: voxelize without writing (a dry run, or timing).
    pub names: Option<OutputNames>,
    pub save: SaveOptions,
    /// Skip models whose output exists (the default).
    pub resume: bool,
    /// Seconds a model's own work may take (its load, then its voxelization; time queued behind other
    /// models does not count), checked after the load, between the stages of its voxelization and inside
    /// the generalized winding number's loops: past it, the model fails.
    pub timeout: Option<f64>,
    /// Loader and writer threads each.
    pub workers: usize,
    /// Loaded models waiting for the device, and grids waiting for a writer, at most.
    pub queue: usize,
}

/// The end of a batch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct BatchSummary {
    pub done: usize,
    pub skipped: usize,
    pub failed: usize,
    pub seconds: f64,
    /// Stopped early by the caller's flag.
    pub interrupted: bool,
}

fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic".into())
}

/// Runs `f`, turning a panic into an error naming `input`.
fn guarded<T>(input: &Path, f: impl FnOnce() -> Result<T>) -> Result<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => Err(Error::Invalid(format!(
            "{}: internal error while processing: {}",
            input.display(),
            panic_message(p)
        ))),
    }
}

/// Writes a model's output `out` with `write` (its folder made first, a panic turned into an error naming
/// `input`), and records the output or the failure in `rec`.
fn write_output(
    input: &Path,
    out: &Path,
    rec: &mut ModelRecord,
    write: impl FnOnce() -> Result<()>,
) {
    let written = guarded(input, || {
        if let Some(parent) = out.parent() {
            std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
        }
        write()
    });
    match written {
        Ok(()) => rec.output = Some(out.display().to_string()),
        Err(e) => {
            rec.status = ModelStatus::Failed;
            rec.error = Some(e.to_string());
        }
    }
}

/// A model loaded and waiting for the device, or found complete without loading (`skipped`).
struct Loaded {
    index: usize,
    mesh: Result<super::Mesh>,
    skipped: Option<PathBuf>,
    /// Seconds the load took.
    load_seconds: f64,
}

/// What a model made: a grid, or a query's arrays.
enum Product {
    Grid(Box<Voxelization>),
    Query(super::query::QueryOutput),
}

/// A grid (or a query's arrays) waiting for its writer.
struct Finished {
    index: usize,
    result: Result<Product>,
    output: Option<PathBuf>,
    /// Seconds of the model's own work so far (load and voxelization).
    work_seconds: f64,
}

/// The device a batch of `method` needs, made once for the whole batch: none for `cpu`, and none for `auto`
/// on a CPU device (lavapipe) or without a usable Vulkan device, where `auto` means the CPU scanline.
/// The device's pipelines are built here, before any model's clock starts.
pub fn batch_device(method: Method) -> Result<Option<Gpu>> {
    let gpu = match method {
        Method::Cpu => None,
        Method::Auto => match crate::gpu::context::probe_device() {
            Ok((_, kind)) if kind != "CPU" => Some(Gpu::new()?),
            _ => None,
        },
        _ => Some(Gpu::new()?),
    };
    if let Some(g) = &gpu {
        g.prepare(method)?;
    }
    Ok(gpu)
}

/// Voxelizes `inputs` (already sorted and sharded) with `gpu` (or the CPU where `gpu` is `None` and the
/// method is `auto` or `cpu`; see [`batch_device`]), calling `record` once a model, in completion order, from the calling thread. Stops
/// after the models in flight when `stop` turns true.
pub fn run_batch(
    gpu: Option<&Gpu>,
    inputs: &[BatchInput],
    opts: &BatchOptions,
    stop: &AtomicBool,
    mut record: impl FnMut(&ModelRecord) -> Result<()>,
) -> Result<BatchSummary> {
    let start = Instant::now();
    let mut summary = BatchSummary::default();
    // A batch killed mid-write left temporaries; their outputs were never complete and will be redone.
    if let Some(n) = &opts.names {
        crate::io::remove_stale_temporaries(&n.dir)?;
    }
    let workers = opts.workers.max(1);
    let queue = opts.queue.max(1);
    // Resume: what is complete is skipped before anything is loaded.
    let planned_output =
        |i: usize, res: u32| opts.names.as_ref().map(|n| n.output(&inputs[i], i, res));
    // The limit covers a model's own work: what its load took, then its voxelization or query.
    let model_deadline = |working: Instant, load_seconds: f64| {
        opts.timeout.map(|seconds| Deadline {
            at: working + std::time::Duration::from_secs_f64((seconds - load_seconds).max(0.0)),
            seconds,
        })
    };
    let next = AtomicUsize::new(0);
    let (load_tx, load_rx) = mpsc::sync_channel::<Loaded>(queue);
    let (write_tx, write_rx) = mpsc::sync_channel::<Finished>(queue);
    let write_rx = Mutex::new(write_rx);
    let (done_tx, done_rx) = mpsc::channel::<ModelRecord>();
    let result = std::thread::scope(|scope| -> Result<()> {
        for _ in 0..workers {
            let load_tx = load_tx.clone();
            let (next, stop) = (&next, stop);
            scope.spawn(move || loop {
                if stop.load(Ordering::Relaxed) {
                    return;
                }
                let index = next.fetch_add(1, Ordering::Relaxed);
                let Some(input) = inputs.get(index) else {
                    return;
                };
                let started = Instant::now();
                // Resume without reading the model where its output's name does not depend on it.
                let early = match &opts.names {
                    Some(n) if opts.resume && !n.needs_grid() => {
                        Some(n.output(input, index, 0)).filter(|o| complete(o))
                    }
                    _ => None,
                };
                let mesh = match early {
                    Some(_) => Err(Error::Invalid("skipped".into())),
                    None => guarded(&input.path, || load_mesh(&input.path)),
                };
                let loaded = Loaded {
                    index,
                    mesh,
                    skipped: early,
                    load_seconds: started.elapsed().as_secs_f64(),
                };
                if load_tx.send(loaded).is_err() {
                    return;
                }
            });
        }
        drop(load_tx);
        for _ in 0..workers {
            let (write_rx, done_tx) = (&write_rx, done_tx.clone());
            let save = &opts.save;
            scope.spawn(move || loop {
                let job = match write_rx.lock().map(|rx| rx.recv()) {
                    Ok(Ok(job)) => job,
                    _ => return,
                };
                let input = &inputs[job.index];
                let writing = Instant::now();
                let mut rec = ModelRecord::new(input, ModelStatus::Done);
                match job.result {
                    Err(e) => {
                        rec.status = ModelStatus::Failed;
                        let msg = e.for_input(&input.path).to_string();
                        let path = input.path.display().to_string();
                        // Every report line names its model, whatever the error.
                        rec.error = Some(if msg.contains(&path) {
                            msg
                        } else {
                            format!("{path}: {msg}")
                        });
                    }
                    Ok(Product::Query(q)) => {
                        rec.points = Some(q.points);
                        rec.inside_points = q.inside;
                        rec.seed = q.seed;
                        if let Some(out) = &job.output {
                            write_output(&input.path, out, &mut rec, || {
                                crate::npy::write_npz(out, &q.arrays)
                            });
                        }
                    }
                    Ok(Product::Grid(v)) => {
                        let r = &v.report;
                        rec.triangles = Some(r.triangles);
                        rec.watertight = Some(r.closed);
                        rec.boundary_loops = r.gwn.map(|g| g.loops_capped);
                        rec.layers = r.layers.iter().map(|l| l.1).max();
                        rec.solid_voxels = Some(v.grid.count());
                        rec.method = Some(r.method);
                        if let Some(out) = &job.output {
                            write_output(&input.path, out, &mut rec, || {
                                v.grid.save_with(out, save)
                            });
                        }
                    }
                }
                rec.seconds = job.work_seconds + writing.elapsed().as_secs_f64();
                rec.rss_mib = resident_mib();
                if done_tx.send(rec).is_err() {
                    return;
                }
            });
        }
        drop(done_tx);
        // The device loop, on this thread; records are passed on as writers finish them.
        let mut pass_on = |summary: &mut BatchSummary, rec: ModelRecord| -> Result<()> {
            match rec.status {
                ModelStatus::Done => summary.done += 1,
                ModelStatus::Skipped => summary.skipped += 1,
                ModelStatus::Failed => summary.failed += 1,
            }
            record(&rec)
        };
        for loaded in load_rx.iter() {
            let input = &inputs[loaded.index];
            if let Some(out) = loaded.skipped {
                let mut rec = ModelRecord::new(input, ModelStatus::Skipped);
                rec.output = Some(out.display().to_string());
                pass_on(&mut summary, rec)?;
                continue;
            }
            let job = match loaded.mesh {
                Err(e) => Finished {
                    index: loaded.index,
                    result: Err(e),
                    output: None,
                    work_seconds: loaded.load_seconds,
                },
                Ok(mesh) if opts.query.is_some() => {
                    let output = planned_output(loaded.index, 0);
                    let working = Instant::now();
                    let deadline = model_deadline(working, loaded.load_seconds);
                    let job = opts.query.as_ref().map(|q| q.for_model(&input.relative));
                    let result = guarded(&input.path, || {
                        checkpoint(&deadline, "after loading")?;
                        let job = job.as_ref().expect("a query batch");
                        job.run(&mesh, &deadline).map(Product::Query)
                    });
                    Finished {
                        index: loaded.index,
                        result,
                        output,
                        work_seconds: loaded.load_seconds + working.elapsed().as_secs_f64(),
                    }
                }
                Ok(mesh) => {
                    let frame = super::grid_frame(&mesh, &opts.voxelize);
                    let res = frame
                        .as_ref()
                        .map(|f| f.dims.iter().copied().max().unwrap_or(0))
                        .unwrap_or(0);
                    let output = planned_output(loaded.index, res);
                    if opts.resume && output.as_deref().is_some_and(complete) {
                        let mut rec = ModelRecord::new(input, ModelStatus::Skipped);
                        rec.output = output.map(|o| o.display().to_string());
                        pass_on(&mut summary, rec)?;
                        continue;
                    }
                    let working = Instant::now();
                    let mut model_opts = opts.voxelize.clone();
                    model_opts.deadline = model_deadline(working, loaded.load_seconds);
                    let result = guarded(&input.path, || {
                        checkpoint(&model_opts.deadline, "after loading")?;
                        frame?;
                        match (gpu, opts.voxelize.method) {
                            (_, Method::Cpu) | (None, Method::Auto) => {
                                voxelize_on_cpu(&mesh, &model_opts)
                            }
                            (Some(g), _) => g.voxelize(&mesh, &model_opts),
                            (None, _) => voxelize(&mesh, &model_opts),
                        }
                        .map(|v| Product::Grid(Box::new(v)))
                    });
                    Finished {
                        index: loaded.index,
                        result,
                        output,
                        work_seconds: loaded.load_seconds + working.elapsed().as_secs_f64(),
                    }
                }
            };
            if write_tx.send(job).is_err() {
                break;
            }
            while let Ok(rec) = done_rx.try_recv() {
                pass_on(&mut summary, rec)?;
            }
            if stop.load(Ordering::Relaxed) {
                summary.interrupted = true;
                break;
            }
        }
        // Loaders blocked on a full queue see the channel closed and end.
        drop(load_rx);
        drop(write_tx);
        for rec in done_rx.iter() {
            pass_on(&mut summary, rec)?;
        }
        Ok(())
    });
    result?;
    summary.seconds = start.elapsed().as_secs_f64();
    Ok(summary)
}

/// Appends `record` to the JSONL report at `path` as one line in one write (O_APPEND: lines of concurrent
/// shard processes never interleave).
pub fn append_record(path: &Path, record: &ModelRecord) -> Result<()> {
    let mut line = serde_json::to_vec(record)
        .map_err(|e| Error::Invalid(format!("cannot encode a report line: {e}")))?;
    line.push(b'\n');
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(|e| Error::io(path, e))?;
    f.write_all(&line).map_err(|e| Error::io(path, e))
}
