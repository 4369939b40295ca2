//! The `gregvox` command line. Each subcommand lives in its own file and returns `Result<()>`;
//! [`main`] prints an error as one line on stderr and maps it to a non-zero exit code.
use clap::{Parser, Subcommand};
use std::process::ExitCode;

pub mod batch;
pub mod bench;
pub mod evaluate;
pub mod info;
pub mod mesh;
pub mod query;
pub mod simplify;
pub mod tessellate;
pub mod voxelize;

/// gregvox: Gregory surfaces and solid voxels on Vulkan.
#[derive(Debug, Parser)]
#[command(name = "gregvox", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Print the chosen Vulkan device, its limits and the validation layer's presence.
    Info(info::InfoArgs),
    /// Print a topology report of a mesh file (OBJ, STL, PLY, OFF, glTF/GLB).
    Mesh(mesh::MeshArgs),
    /// Catmull–Clark subdivide a mesh file (OBJ, STL, PLY, OFF, glTF/GLB) and write the result as OBJ.
    Subdivide(mesh::SubdivideArgs),
    /// Evaluate Gregory (ACC-2 from a quad cage) or Beziex patches on the GPU and write the grid as OBJ.
    Tessellate(tessellate::TessellateArgs),
    /// Voxelize a mesh file (OBJ, STL, PLY, OFF, glTF/GLB) into a voxel grid of a chosen size, box and fill (the CPU scanline, depth peeling or the A-buffer; auto picks for the device).
    Voxelize(voxelize::VoxelizeArgs),
    /// Voxelize many models (files, folders, globs, manifests) with one device: sharding for job arrays
    /// (--shard I/N, Slurm, RANK/WORLD_SIZE), resume, a JSONL report.
    Batch(batch::BatchArgs),
    /// Exact winding numbers, occupancy and signed/unsigned distances at given (.npy) or sampled points,
    /// into an .npz (dataset building: Occupancy Networks, DeepSDF, IF-Net).
    Query(query::QueryArgs),
    /// Reduce a mesh (OBJ, STL, PLY, OFF, glTF/GLB) by parallel quadric edge collapses to a ratio, a face
    /// count or an error, keeping its topology, borders and seams; levels of detail with --lod.
    Simplify(simplify::SimplifyArgs),
    /// Evaluate a cage's limit surface at (face, u, v) rows of an (N, 3) .npy (OpenSubdiv's ptex faces):
    /// positions and exact first and second derivatives, into an .npz.
    Evaluate(evaluate::EvaluateArgs),
    /// Run the live demo in a window, or offscreen writing PNG frames.
    Demo(crate::demo::DemoArgs),
    /// Run the benchmark suites: tables (markdown, CSV, JSON) and scaling plots (PNG).
    Bench(bench::BenchArgs),
}

/// Writes `text` to stdout; a closed pipe (`gregvox info | head`) is not an error.
pub fn print_out(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}

/// Runs the command line and returns the process exit code.
pub fn main() -> ExitCode {
    let _ = env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn"))
        .format_timestamp(None)
        .try_init();
    let matches = <Cli as clap::CommandFactory>::command().get_matches();
    let mut cli = match <Cli as clap::FromArgMatches>::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    // The demo checks its options against the scene, so it needs to know which were given (not only
    // their values, which defaults fill in).
    if let (Command::Demo(a), Some(("demo", sub))) = (&mut cli.command, matches.subcommand()) {
        a.given = sub
            .ids()
            .filter(|id| {
                sub.value_source(id.as_str()) == Some(clap::parser::ValueSource::CommandLine)
            })
            .map(|id| id.as_str().to_string())
            .collect();
    }
    if !matches!(cli.command, Command::Batch(_)) {
        // SIGINT, SIGTERM, SIGHUP: remove the temporary file of a write in progress, then exit as a signal
        // would (128 + 2). `gregvox batch` has its own handler (stop after the models in flight).
        let _ = ctrlc::set_handler(|| {
            eprintln!("gregvox: interrupted");
            crate::io::exit_removing_temporaries(130);
        });
    }
    let result = match cli.command {
        Command::Info(a) => info::run(&a),
        Command::Mesh(a) => mesh::run_mesh(&a),
        Command::Subdivide(a) => mesh::run_subdivide(&a),
        Command::Demo(a) => crate::demo::run(&a),
        Command::Voxelize(a) => voxelize::run(&a),
        Command::Query(a) => query::run(&a),
        Command::Evaluate(a) => evaluate::run(&a),
        Command::Simplify(a) => simplify::run(&a),
        Command::Batch(a) => batch::run(&a),
        Command::Tessellate(a) => tessellate::run(&a),
        Command::Bench(a) => bench::run(&a),
    };
    // Resource hygiene: every context of the run has been destroyed by now (each command owns its own). A
    // leaked allocation or any validation message (the layer reports undestroyed Vulkan objects when the
    // device is destroyed) turns the run into a failure, even when the command itself succeeded.
    let leaked = crate::gpu::context::allocations_leaked_at_destruction();
    let messages = crate::gpu::context::validation_messages_at_destruction();
    let result = result.and_then(|()| {
        if leaked > 0 {
            anyhow::bail!("internal error: {leaked} GPU allocation(s) were still alive at exit (see the log above)");
        }
        if messages > 0 {
            anyhow::bail!("internal error: {messages} Vulkan validation message(s) during the run (see above)");
        }
        Ok(())
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gregvox: error: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, each cause added only when the text so far does not already say
/// it (our I/O errors print their source, which anyhow would otherwise repeat: "x: No such file: No such
/// file").
pub fn one_line(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !text.contains(&c) {
            text.push_str(": ");
            text.push_str(&c);
        }
    }
    text.replace('\n', " ")
}
