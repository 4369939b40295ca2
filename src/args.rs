//! Argument groups shared by the command line, the demo and the bench (feature `cli`): the profiling flags of
//! every command that runs GPU passes. Below all three, so none of them imports upward.
use crate::gpu::Profiler;
use clap::Args;
use std::path::PathBuf;

/// `--profile`, `--profile-json FILE`, `--trace FILE`.
#[derive(Debug, Args, Clone, Default)]
pub struct ProfileArgs {
    /// Print the per-pass GPU time table (timestamp queries) at exit.
    #[arg(long)]
    pub profile: bool,
    /// Write the per-pass profile as JSON: {"device", "passes": [{"name", "calls", "gpu_ms": {min, median, max}}]}.
    #[arg(long, value_name = "FILE")]
    pub profile_json: Option<PathBuf>,
    /// Write every timed pass as a chrome://tracing trace file.
    #[arg(long, value_name = "FILE")]
    pub trace: Option<PathBuf>,
}

impl ProfileArgs {
    /// Whether any profile output was asked for.
    pub fn wanted(&self) -> bool {
        self.profile || self.profile_json.is_some() || self.trace.is_some()
    }

    /// Checks, before any work, that the profile outputs asked for can be written
    /// ([`crate::io::check_output`]).
    pub fn check_outputs(&self) -> crate::Result<()> {
        for path in self.profile_json.iter().chain(&self.trace) {
            crate::io::check_output(path)?;
        }
        Ok(())
    }

    /// Prints and writes what was asked for.
    pub fn emit(&self, profiler: &Profiler) -> anyhow::Result<()> {
        if self.profile {
            eprint!("{}", profiler.table());
        }
        if let Some(path) = &self.profile_json {
            write_json_atomically(path, &profiler.json())?;
        }
        if let Some(path) = &self.trace {
            write_json_atomically(path, &profiler.chrome_trace())?;
        }
        Ok(())
    }
}

/// Writes pretty JSON to `path` through [`crate::io::write_atomic`].
pub fn write_json_atomically(
    path: &std::path::Path,
    value: &serde_json::Value,
) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    crate::io::write_atomic(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}
