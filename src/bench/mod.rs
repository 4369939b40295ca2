//! `gregvox bench`: the benchmark suites of issue 8, their result model and its outputs.
//!
//! Invariants:
//! - A run produces one [`Report`] (tables + scaling curves + machine); every output — markdown on stdout,
//!   `results.json`, one CSV per table and per curve, one PNG per curve, `benchmarks.md` — is a pure function of
//!   that report, so `docs/benchmarks.md` can be regenerated from a saved JSON (`gregvox bench --from-json`).
//! - Times are medians of several repeats measured in this run: GPU times from the timestamp profiler (which on
//!   lavapipe measures the CPU driver's execution), CPU times from `std::time::Instant`. Nothing here asserts a
//!   speed; speed is stated as ratios of figures measured side by side.
//! - Ratios are always `peer time / gregvox time` ("speed-up": above 1 means gregvox is faster), and a missing
//!   peer is a row that says so and how to install it, never a number.
//! - Every GPU resource a suite creates is dropped (released through the release queue) before the suite
//!   returns, on success and on error.
pub mod batch;
pub mod gregory;
pub mod gwn;
pub mod mesh;
pub mod peak;
pub mod peers;
pub mod plot;
pub mod query;
pub mod simplify;
pub mod thesis;
pub mod voxel;
pub mod writers;

use crate::gpu::{Context, Profiler};
use ash::vk;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The suites, in run order. `peak` runs first: the floors of the other tables divide by its figures.
pub const SUITES: [&str; 11] = [
    "peak", "thesis", "gregory", "voxel", "gwn", "query", "batch", "mesh", "writers", "simplify",
    "scaling",
];

/// What a run measures and where the inputs are.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    /// Small sizes and few repeats (the CI smoke test, < 2 minutes).
    pub quick: bool,
    /// Suites to run (names from [`SUITES`]).
    pub suites: Vec<String>,
    /// Repeats per measurement (the median is reported).
    pub repeats: usize,
    /// The test models folder (stanford-bunny.obj, spot_quadrangulated.obj, cow.obj, …).
    pub models: PathBuf,
    /// Where the peer programs live (`bench/peers/install.sh` builds the OpenSubdiv one into it).
    pub peers: PathBuf,
    /// The repository root (the peer scripts are found from it).
    pub repo: PathBuf,
}

impl BenchConfig {
    /// The defaults for this checkout: models in `assets/models`, peers in `target/bench-peers`.
    pub fn new(quick: bool) -> Self {
        let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
        BenchConfig {
            quick,
            suites: SUITES.iter().map(|s| s.to_string()).collect(),
            repeats: if quick { 3 } else { 7 },
            models: repo.join("assets/models"),
            peers: repo.join("target/bench-peers"),
            repo,
        }
    }

    /// Path of a shared model, or a clear error naming it.
    pub fn model(&self, name: &str) -> anyhow::Result<PathBuf> {
        let p = self.models.join(name);
        if !p.is_file() {
            anyhow::bail!(
                "model {} not found (pass --models DIR: the folder with the shared test models)",
                p.display()
            );
        }
        Ok(p)
    }

    /// Whether `suite` was asked for.
    pub fn wants(&self, suite: &str) -> bool {
        self.suites.iter().any(|s| s == suite)
    }
}

/// One results table. Cells are JSON numbers (times in ms unless the column says otherwise) or strings.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Table {
    /// File-name-safe id (CSV name).
    pub id: String,
    pub title: String,
    /// What was measured, how, and what the columns mean.
    pub note: String,
    pub columns: Vec<String>,
    pub rows: Vec<Vec<Value>>,
}

impl Table {
    /// An empty table.
    pub fn new(id: &str, title: &str, note: &str, columns: &[&str]) -> Self {
        Table {
            id: id.into(),
            title: title.into(),
            note: note.into(),
            columns: columns.iter().map(|c| c.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row (must have one cell per column).
    pub fn push(&mut self, row: Vec<Value>) {
        debug_assert_eq!(row.len(), self.columns.len(), "table {}", self.id);
        self.rows.push(row);
    }

    /// The table as markdown (numbers to 4 significant digits).
    pub fn markdown(&self) -> String {
        let mut s = format!("### {}\n\n", self.title);
        if !self.note.is_empty() {
            s.push_str(&format!("{}\n\n", self.note));
        }
        s.push_str(&format!("| {} |\n", self.columns.join(" | ")));
        s.push_str(&format!(
            "|{}\n",
            self.columns
                .iter()
                .enumerate()
                .map(|(i, _)| if i == 0 { "---|" } else { "---:|" })
                .collect::<String>()
        ));
        for r in &self.rows {
            let cells: Vec<String> = r.iter().map(fmt_cell).collect();
            s.push_str(&format!("| {} |\n", cells.join(" | ")));
        }
        s.push('\n');
        s
    }

    /// The table as CSV (RFC 4180 quoting; numbers in full precision).
    pub fn csv(&self) -> String {
        let mut s = self
            .columns
            .iter()
            .map(|c| csv_field(c))
            .collect::<Vec<_>>()
            .join(",");
        s.push('\n');
        for r in &self.rows {
            let cells: Vec<String> = r
                .iter()
                .map(|v| match v {
                    Value::String(t) => csv_field(t),
                    Value::Null => String::new(),
                    other => other.to_string(),
                })
                .collect();
            s.push_str(&cells.join(","));
            s.push('\n');
        }
        s
    }
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// A number to 4 significant digits (no exponent between 1e-3 and 1e7); strings as they are; null as "–".
pub fn fmt_cell(v: &Value) -> String {
    match v {
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                return i.to_string();
            }
            let x = n.as_f64().unwrap_or(f64::NAN);
            // Sizes stored as f64 (curve x values) print as integers.
            if x.fract() == 0.0 && x.abs() >= 1.0 && x.abs() < 1e15 {
                return format!("{x:.0}");
            }
            fmt_num(x)
        }
        Value::String(s) => s.clone(),
        Value::Null => "–".into(),
        other => other.to_string(),
    }
}

/// `x` to 4 significant digits.
pub fn fmt_num(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let a = x.abs();
    if !(1e-3..1e7).contains(&a) {
        return format!("{x:.3e}");
    }
    let digits = (3 - a.log10().floor() as i32).max(0) as usize;
    format!("{x:.digits$}")
}

/// One series of a scaling curve with its fitted growth.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Series {
    pub name: String,
    /// (x, y) with y in ms.
    pub points: Vec<(f64, f64)>,
    /// Least-squares slope of ln y against ln x (the growth exponent), if at least two positive points.
    pub slope: Option<f64>,
}

impl Series {
    /// A series with its slope fitted.
    pub fn new(name: &str, points: Vec<(f64, f64)>) -> Self {
        let slope = loglog_slope(&points);
        Series {
            name: name.into(),
            points,
            slope,
        }
    }
}

/// A scaling curve: time against a size, log-log, one or more series.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Curve {
    pub id: String,
    pub title: String,
    pub note: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
}

impl Curve {
    /// The curve's points as a long-format table (series, x, y) with the slope per series in the note.
    pub fn table(&self) -> Table {
        let slopes: Vec<String> = self
            .series
            .iter()
            .map(|s| match s.slope {
                Some(k) => format!("{}: {:.2}", s.name, k),
                None => format!("{}: –", s.name),
            })
            .collect();
        let mut t = Table::new(
            &self.id,
            &self.title,
            &format!(
                "{} Fitted growth (least-squares slope of log time vs log {}): {}.",
                self.note,
                self.x_label,
                slopes.join("; ")
            ),
            &["series", &self.x_label, &self.y_label],
        );
        for s in &self.series {
            for &(x, y) in &s.points {
                t.push(vec![s.name.clone().into(), num(x), num(y)]);
            }
        }
        t
    }
}

/// The machine a run measured.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Machine {
    pub cpu: String,
    pub logical_cpus: usize,
    pub device: String,
    pub driver: String,
    pub lp_num_threads: String,
    pub build: String,
}

impl Machine {
    /// CPU model and count from /proc/cpuinfo, the Vulkan device and driver from `ctx`.
    pub fn detect(ctx: Option<&Context>) -> Self {
        let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        let cpu = cpuinfo
            .lines()
            .find(|l| l.starts_with("model name"))
            .and_then(|l| l.split(':').nth(1))
            .map(|s| s.trim().to_string())
            .unwrap_or_else(|| std::env::consts::ARCH.to_string());
        Machine {
            cpu,
            logical_cpus: std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1),
            device: ctx.map(|c| c.info.name.clone()).unwrap_or_default(),
            driver: ctx
                .map(|c| format!("{} {}", c.info.driver_name, c.info.driver_info))
                .unwrap_or_default(),
            lp_num_threads: std::env::var("LP_NUM_THREADS").unwrap_or_else(|_| "(unset)".into()),
            build: if cfg!(debug_assertions) {
                "debug (dependencies at opt-level 2)".into()
            } else {
                "release".into()
            },
        }
    }
}

/// Everything one run measured.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Report {
    pub machine: Machine,
    pub quick: bool,
    pub suites: Vec<String>,
    pub started_utc: String,
    pub duration_s: f64,
    /// The command that reproduces the run.
    pub command: String,
    pub tables: Vec<Table>,
    pub curves: Vec<Curve>,
}

impl Report {
    /// The markdown document (`benchmarks.md`): machine, how to reproduce, every table, every curve.
    /// `images` is the folder of the PNGs relative to the document ("" when they sit beside it).
    pub fn markdown(&self, images: &str) -> String {
        let mut s = String::from("# gregvox benchmarks\n\n");
        s.push_str(
            "Generated by `gregvox bench` from its `results.json` (do not edit by hand: re-run the command \
             below, or `gregvox bench --from-json out/bench/results.json --doc docs/benchmarks.md`).\n\n",
        );
        s.push_str("## Machine and run\n\n");
        let m = &self.machine;
        s.push_str(&format!(
            "- CPU: {} ({} logical CPUs)\n- Vulkan device: {} — driver {}\n- LP_NUM_THREADS: {}\n- build: {}\n\
             - run: {} mode, suites {}, started {} UTC, took {:.1} s\n- reproduce: `{}`\n\n",
            m.cpu,
            m.logical_cpus,
            m.device,
            m.driver,
            m.lp_num_threads,
            m.build,
            if self.quick { "quick" } else { "full" },
            self.suites.join(", "),
            self.started_utc,
            self.duration_s,
            self.command
        ));
        s.push_str(
            "Reproduce every table and plot (one command, from the repository root, on a quiet machine):\n\n\
             ```sh\n\
             bash bench/peers/install.sh && cargo build --release && \\\n  \
             VK_DRIVER_FILES=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json LP_NUM_THREADS=2 \\\n  \
             ./target/release/gregvox bench --doc docs/benchmarks.md\n\
             ```\n\n",
        );
        if m.build.starts_with("debug") {
            s.push_str(
                "**This run used a debug build**: gregvox's own CPU code (the CPU columns, the peak kernels) ran \
                 unoptimised, so CPU figures and floors are not representative; GPU (lavapipe) figures are, as \
                 the driver is optimised either way.\n\n",
            );
        }
        s.push_str(&format!(
            "Conventions: times are medians of repeats measured in this run, in ms unless a column says \
             otherwise; gregvox's CPU wall-clock times repeat at least as often as stated and, when short, \
             until the runs fill {CPU_TIMING_FILL_S} s (at most {CPU_TIMING_MAX_RUNS} runs). GPU times are \
             Vulkan timestamp queries; on lavapipe they measure the CPU driver executing the commands on the \
             same cores. \"speed-up\" = peer time / gregvox time (above 1: gregvox is faster). Growth \
             exponents are least-squares slopes of log time against log size.\n\n",
        ));
        for t in &self.tables {
            s.push_str(&t.markdown());
        }
        if !self.curves.is_empty() {
            s.push_str("## Scaling curves\n\n");
            for c in &self.curves {
                s.push_str(&c.table().markdown());
                s.push_str(&format!("![{}]({images}{}.png)\n\n", c.title, c.id));
            }
        }
        s
    }

    /// Writes `results.json`, `benchmarks.md`, one CSV per table and per curve, and one PNG per curve into
    /// `dir`. Returns the notes of outputs that could not be made (plots without a font).
    pub fn write(&self, dir: &Path) -> anyhow::Result<Vec<String>> {
        std::fs::create_dir_all(dir).map_err(|e| anyhow::anyhow!("{}: {e}", dir.display()))?;
        let write = |name: &str, text: &str| -> anyhow::Result<()> {
            let p = dir.join(name);
            std::fs::write(&p, text).map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))
        };
        write("results.json", &serde_json::to_string_pretty(self)?)?;
        write("benchmarks.md", &self.markdown(""))?;
        for t in &self.tables {
            write(&format!("{}.csv", t.id), &t.csv())?;
        }
        let mut notes = Vec::new();
        for c in &self.curves {
            write(&format!("{}.csv", c.id), &c.table().csv())?;
            if let Err(e) = plot::draw(c, &dir.join(format!("{}.png", c.id))) {
                notes.push(format!("plot {} not drawn: {e:#}", c.id));
            }
        }
        Ok(notes)
    }
}

/// A JSON number (NaN and infinities become null).
pub fn num(x: f64) -> Value {
    serde_json::Number::from_f64(x)
        .map(Value::Number)
        .unwrap_or(Value::Null)
}

/// Median of `v` (NaN-free; the mean of the middle two for an even count). Empty → NaN.
pub fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// `peer / ours` (the speed-up of gregvox over the peer), or null when either is missing or not positive.
pub fn speedup(peer_ms: Option<f64>, ours_ms: f64) -> Value {
    match peer_ms {
        Some(p) if p > 0.0 && ours_ms > 0.0 && p.is_finite() && ours_ms.is_finite() => {
            num(p / ours_ms)
        }
        _ => Value::Null,
    }
}

/// Least-squares slope of ln y against ln x over the points with x, y > 0; None with fewer than two distinct
/// x.
pub fn loglog_slope(points: &[(f64, f64)]) -> Option<f64> {
    let p: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if p.len() < 2 {
        return None;
    }
    let n = p.len() as f64;
    let mx = p.iter().map(|q| q.0).sum::<f64>() / n;
    let my = p.iter().map(|q| q.1).sum::<f64>() / n;
    let sxx: f64 = p.iter().map(|q| (q.0 - mx) * (q.0 - mx)).sum();
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    if sxx <= 0.0 {
        return None;
    }
    Some(sxy / sxx)
}

/// Median wall time (ms) of at least `repeats` calls of `f` after one warm-up call, more for short calls:
/// until the runs fill [`CPU_TIMING_FILL_S`] (at most [`CPU_TIMING_MAX_RUNS`]), so that a sub-millisecond
/// median is not at the mercy of a few preempted runs on a shared machine.
pub fn time_cpu<T>(repeats: usize, mut f: impl FnMut() -> T) -> f64 {
    std::hint::black_box(f());
    let start = Instant::now();
    let mut times = Vec::new();
    while times.len() < repeats.max(1)
        || (start.elapsed().as_secs_f64() < CPU_TIMING_FILL_S && times.len() < CPU_TIMING_MAX_RUNS)
    {
        let t = Instant::now();
        std::hint::black_box(f());
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    median(&times)
}

/// Seconds of runs [`time_cpu`] fills at least.
pub const CPU_TIMING_FILL_S: f64 = 0.25;
/// Most runs [`time_cpu`] makes.
pub const CPU_TIMING_MAX_RUNS: usize = 1000;

/// GPU timings of one recorded workload: per-pass median (ms, timestamps) and the median wall time of the
/// whole submission (record + submit + wait).
#[derive(Clone, Debug, Default)]
pub struct GpuTiming {
    pub passes: Vec<(String, f64)>,
    pub wall_ms: f64,
}

impl GpuTiming {
    /// The median of pass `name` (0 when it was not timed).
    pub fn pass(&self, name: &str) -> f64 {
        self.passes
            .iter()
            .filter(|(n, _)| n == name)
            .map(|p| p.1)
            .sum()
    }

    /// The sum of every pass's median.
    pub fn total(&self) -> f64 {
        self.passes.iter().map(|p| p.1).sum()
    }
}

/// Records `record` into one command buffer per repeat (after `warmup` untimed runs, which pay the pipeline
/// JIT) and returns the per-pass timestamp medians and the median wall time.
pub fn time_gpu(
    ctx: &Context,
    warmup: usize,
    repeats: usize,
    mut record: impl FnMut(vk::CommandBuffer, Option<(&mut Profiler, usize)>) -> crate::Result<()>,
) -> anyhow::Result<GpuTiming> {
    let mut profiler = Profiler::new(ctx, 1, 64)?;
    for _ in 0..warmup {
        ctx.one_shot(|cmd| record(cmd, None))?;
    }
    let mut walls = Vec::new();
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        ctx.one_shot(|cmd| record(cmd, Some((&mut profiler, 0))))?;
        walls.push(t.elapsed().as_secs_f64() * 1e3);
        profiler.collect(ctx, 0)?;
    }
    Ok(GpuTiming {
        passes: profiler
            .stats()
            .into_iter()
            .map(|s| (s.name, s.median_ms))
            .collect(),
        wall_ms: median(&walls),
    })
}

/// A fresh context for compute-only timing. On lavapipe (Mesa 22.3), once a context has rasterized anything,
/// a timestamp scope around a lone compute dispatch reads ~0.1 ms however long the dispatch runs (the wall
/// time is right); a context that never draws times compute correctly. So compute measurements run on their
/// own context, and graphics (vertex pull, peeling) on the shared one.
pub fn compute_context() -> anyhow::Result<Context> {
    Ok(Context::with_desc(&crate::gpu::ContextDesc::default())?)
}

/// Drops a context made by [`compute_context`], failing if a GPU allocation is still alive.
pub fn finish_context(ctx: Context) -> anyhow::Result<()> {
    let leaks = ctx.live_allocations();
    drop(ctx);
    if !leaks.is_empty() {
        anyhow::bail!("internal error: GPU allocations still alive: {leaks:?}");
    }
    Ok(())
}

/// The current UTC time as `YYYY-MM-DD HH:MM:SS` (no time-zone crate: civil-from-days on the Unix clock).
pub fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    let (days, rem) = (secs.div_euclid(86400), secs.rem_euclid(86400));
    // Howard Hinnant's days_from_civil inverse.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + (m <= 2) as i64;
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02}",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// Runs the configured suites and returns the report. Progress goes to stderr.
pub fn run(cfg: &BenchConfig, command: &str) -> anyhow::Result<Report> {
    for s in &cfg.suites {
        if !SUITES.contains(&s.as_str()) {
            anyhow::bail!(
                "--suite '{s}' is not a suite (choose from {})",
                SUITES.join(", ")
            );
        }
    }
    let start = Instant::now();
    let ctx = Context::with_desc(&crate::gpu::ContextDesc::default())?;
    let mut report = Report {
        machine: Machine::detect(Some(&ctx)),
        quick: cfg.quick,
        suites: cfg.suites.clone(),
        started_utc: utc_now(),
        command: command.into(),
        ..Default::default()
    };
    let result = (|| -> anyhow::Result<()> {
        let mut peak = None;
        for suite in SUITES {
            if !cfg.wants(suite) {
                continue;
            }
            eprintln!("gregvox bench: suite {suite} …");
            let t = Instant::now();
            match suite {
                "peak" => peak = Some(peak::run(cfg, &mut report)?),
                "thesis" => {
                    let c = compute_context()?;
                    let r = thesis::run(&c, cfg, &mut report);
                    finish_context(c)?;
                    r?
                }
                "gregory" => {
                    gregory::run(&ctx, cfg, peak.as_ref(), &mut report)?;
                    gregory::adaptive(cfg, &mut report)?;
                    gregory::curvature(cfg, &mut report)?;
                    gregory::evaluate_at(cfg, &mut report)?;
                }
                "voxel" => voxel::run(&ctx, cfg, peak.as_ref(), &mut report)?,
                "gwn" => gwn::run(cfg, &mut report)?,
                "query" => query::run(cfg, &mut report)?,
                "batch" => batch::run(cfg, &mut report)?,
                "mesh" => mesh::run(cfg, peak.as_ref(), &mut report)?,
                "writers" => writers::run(cfg, &mut report)?,
                "simplify" => simplify::run(cfg, &mut report)?,
                "scaling" => {
                    gregory::scaling(&ctx, cfg, &mut report)?;
                    voxel::scaling(&ctx, cfg, &mut report)?;
                }
                _ => unreachable!("suite names are checked above"),
            }
            eprintln!(
                "gregvox bench: suite {suite} done in {:.1} s",
                t.elapsed().as_secs_f64()
            );
        }
        Ok(())
    })();
    let leaks = ctx.live_allocations();
    drop(ctx);
    result?;
    if !leaks.is_empty() {
        anyhow::bail!(
            "internal error: GPU allocations still alive after the benchmarks: {leaks:?}"
        );
    }
    report.duration_s = start.elapsed().as_secs_f64();
    Ok(report)
}
