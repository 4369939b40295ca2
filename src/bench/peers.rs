//! The peer programs, run as subprocesses in the same run as gregvox's measurements.
//!
//! Invariants: a peer that is not installed yields [`Peer::Missing`] with the one command that installs it
//! (never an error and never a number); a peer that runs but fails yields [`Peer::Failed`] with its stderr
//! tail. Peers are installed by `bash bench/peers/install.sh` (pip requirements + the OpenSubdiv program).
use serde_json::Value;
use std::path::Path;
use std::process::Command;

/// The install command every "peer not installed" row names.
pub const INSTALL: &str = "bash bench/peers/install.sh";

/// A peer's outcome.
#[derive(Clone, Debug)]
pub enum Peer {
    /// Parsed JSON lines of stdout.
    Ran(Vec<Value>),
    /// Not installed: what is missing.
    Missing(String),
    /// Ran and failed.
    Failed(String),
    /// Deliberately not run in this configuration (why).
    Skipped(String),
}

impl Peer {
    /// The text for a table cell when there is no number.
    pub fn status(&self) -> String {
        match self {
            Peer::Ran(_) => "ran".into(),
            Peer::Missing(what) => format!("peer not installed ({what}): run `{INSTALL}`"),
            Peer::Failed(e) => format!("peer failed: {e}"),
            Peer::Skipped(why) => format!("peer not run: {why}"),
        }
    }
}

/// Runs `program args…` and parses every stdout line that is a JSON value.
pub fn run(program: &Path, args: &[String]) -> Peer {
    run_within(program, args, None)
}

/// As [`run`], killing the peer once it has run `limit` (then [`Peer::Failed`] says so): for the inputs
/// that attack a peer as well as gregvox, where it may run for hours.
pub fn run_within(program: &Path, args: &[String], limit: Option<std::time::Duration>) -> Peer {
    let output = match limit {
        None => Command::new(program).args(args).output(),
        Some(limit) => Command::new(program)
            .args(args)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .and_then(|mut child| {
                let start = std::time::Instant::now();
                loop {
                    if child.try_wait()?.is_some() {
                        return child.wait_with_output();
                    }
                    if start.elapsed() >= limit {
                        child.kill()?;
                        child.wait()?;
                        return Err(std::io::Error::new(
                            std::io::ErrorKind::TimedOut,
                            format!("killed after {} s", limit.as_secs()),
                        ));
                    }
                    std::thread::sleep(std::time::Duration::from_millis(50));
                }
            }),
    };
    let out = match output {
        Ok(o) => o,
        Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {
            return Peer::Failed(format!("did not finish: {e}"))
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Peer::Missing(format!("{} not found", program.display()))
        }
        Err(e) => return Peer::Failed(format!("{}: {e}", program.display())),
    };
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = err.lines().rev().take(3).collect();
        let tail: Vec<&str> = tail.into_iter().rev().collect();
        // A Python peer whose module is absent is "not installed", not "failed".
        if let Some(line) = tail.iter().find(|l| l.contains("ModuleNotFoundError")) {
            return Peer::Missing(line.trim().to_string());
        }
        return Peer::Failed(format!("{} ({})", tail.join(" / "), out.status));
    }
    let values = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l.trim()).ok())
        .filter(|v| v.is_object() || v.is_array())
        .collect();
    Peer::Ran(values)
}

/// Runs a Python peer script with `python3`.
pub fn python(script: &Path, args: &[String]) -> Peer {
    python_within(script, args, None)
}

/// As [`python`], killed after `limit` ([`run_within`]).
pub fn python_within(script: &Path, args: &[String], limit: Option<std::time::Duration>) -> Peer {
    if !script.is_file() {
        return Peer::Missing(format!("{} not found", script.display()));
    }
    let mut all = vec![script.display().to_string()];
    all.extend_from_slice(args);
    run_within(Path::new("python3"), &all, limit)
}
