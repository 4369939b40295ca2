//! `gregvox bench [--quick] [--out DIR] [--suite NAME…] [--doc FILE]`: runs the benchmark suites
//! (src/bench/), prints the markdown tables, writes `results.json`, CSV and PNG plots into DIR; with `--doc`
//! also the markdown document (its plots copied into a `bench/` folder beside it). `--from-json FILE` skips
//! the measurements and regenerates every output from a saved `results.json`.
use crate::bench::{self, BenchConfig, Report, SUITES};
use anyhow::Context as _;
use clap::Args;
use std::path::{Path, PathBuf};

/// Arguments of `gregvox bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Small sizes and few repeats: under two minutes on a 2-core lavapipe machine (the CI smoke test).
    #[arg(long)]
    pub quick: bool,
    /// Output folder for results.json, benchmarks.md, the CSV tables and the PNG plots.
    #[arg(long, default_value = "out/bench")]
    pub out: PathBuf,
    /// Run only these suites (repeatable): peak, thesis, gregory, voxel, gwn, query, batch, mesh, writers, scaling.
    #[arg(long = "suite", value_name = "NAME")]
    pub suites: Vec<String>,
    /// Repeats per measurement (the median is reported); default 3 with --quick, else 7.
    #[arg(long)]
    pub repeats: Option<usize>,
    /// Folder of the test models (default: assets/models of the source checkout).
    #[arg(long)]
    pub models: Option<PathBuf>,
    /// Folder of the built peer programs (default: target/bench-peers; see bench/peers/install.sh).
    #[arg(long)]
    pub peers: Option<PathBuf>,
    /// Also write the markdown document here (e.g. docs/benchmarks.md), plots into `bench/` beside it.
    #[arg(long, value_name = "FILE")]
    pub doc: Option<PathBuf>,
    /// Do not measure: regenerate every output from this saved results.json.
    #[arg(long, value_name = "FILE")]
    pub from_json: Option<PathBuf>,
}

/// Runs `gregvox bench`.
pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    // Outputs before the measurements (minutes of them).
    crate::io::check_output_folder(&args.out)?;
    if let Some(doc) = &args.doc {
        // Its folder is made if missing, as the output folder is.
        match doc
            .parent()
            .filter(|p| !p.as_os_str().is_empty() && !p.exists())
        {
            Some(folder) => crate::io::check_output_folder(folder)?,
            None => crate::io::check_output(doc)?,
        }
    }
    let report = match &args.from_json {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("{}: cannot read", path.display()))?;
            serde_json::from_str::<Report>(&text)
                .with_context(|| format!("{}: not a gregvox bench results.json", path.display()))?
        }
        None => measure(args)?,
    };
    let notes = report.write(&args.out)?;
    for n in &notes {
        eprintln!("gregvox bench: {n}");
    }
    if let Some(doc) = &args.doc {
        write_doc(&report, &args.out, doc)?;
    }
    let mut text = String::new();
    for t in &report.tables {
        text.push_str(&t.markdown());
    }
    for c in &report.curves {
        text.push_str(&c.table().markdown());
    }
    text.push_str(&format!(
        "bench: {} run of suites {} took {:.1} s; results in {}\n",
        if report.quick { "quick" } else { "full" },
        report.suites.join(", "),
        report.duration_s,
        args.out.display()
    ));
    super::print_out(&text)
}

fn measure(args: &BenchArgs) -> anyhow::Result<Report> {
    let mut cfg = BenchConfig::new(args.quick);
    if !args.suites.is_empty() {
        for s in &args.suites {
            if !SUITES.contains(&s.as_str()) {
                anyhow::bail!(
                    "--suite '{s}' is not a suite (choose from {})",
                    SUITES.join(", ")
                );
            }
        }
        cfg.suites = args.suites.clone();
    }
    if let Some(r) = args.repeats {
        if r == 0 {
            anyhow::bail!("--repeats must be at least 1");
        }
        cfg.repeats = r;
    }
    if let Some(m) = &args.models {
        if !m.is_dir() {
            anyhow::bail!("--models {}: not a folder", m.display());
        }
        cfg.models = m.clone();
    }
    if let Some(p) = &args.peers {
        cfg.peers = p.clone();
    }
    let command: Vec<String> = std::env::args()
        .enumerate()
        .map(|(i, a)| if i == 0 { "gregvox".into() } else { a })
        .collect();
    bench::run(&cfg, &command.join(" "))
}

/// Writes the document to `doc` and copies the plots from `out` into `bench/` beside it.
fn write_doc(report: &Report, out: &Path, doc: &Path) -> anyhow::Result<()> {
    let dir = doc
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let images = dir.join("bench");
    std::fs::create_dir_all(&images).with_context(|| images.display().to_string())?;
    for c in &report.curves {
        let png = out.join(format!("{}.png", c.id));
        if png.is_file() {
            std::fs::copy(&png, images.join(format!("{}.png", c.id)))
                .with_context(|| format!("copying {}", png.display()))?;
        }
    }
    std::fs::write(doc, report.markdown("bench/")).with_context(|| doc.display().to_string())
}
