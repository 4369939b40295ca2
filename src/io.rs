//! Output safety: the one way gregvox writes an output file.
//!
//! Invariants of [`write_atomic`]:
//! - A regular target (or a new one) is written to a temporary file in the same directory (so the rename
//!   stays on one file system and is atomic), flushed and synced, then renamed over the target. Readers see
//!   the old file or the complete new one, never a truncated one; on any error the temporary file is
//!   removed and a pre-existing target is left untouched.
//! - A target that exists and is not a regular file (`/dev/full`, `/dev/stdout`, a FIFO, a character
//!   device, or a symlink to one) is written directly. Why: a rename would replace the device node or the
//!   FIFO itself, and gregvox runs as root in CI, where nothing stops that (it happened: a rename onto
//!   `/dev/full` turned the device into a regular file).
//! - Every error names the target path (never the temporary one): users asked for the target.
//! - The path `-` is standard output ([`STDOUT`]), written directly.
//! - Every temporary file being written is listed in a process-wide registry (from its creation, under
//!   the registry's lock, until it is renamed or removed), so that a SIGINT or SIGTERM handler ([`exit_removing_temporaries`]) can remove it: an
//!   interrupted command leaves no `.NAME.PID.tmp` behind. SIGKILL cannot be caught: [`check_output`] (at
//!   the start of a command) and [`remove_stale_temporaries`] (at the start of a batch) remove what a killed
//!   process left.
use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The host memory this process may still take, in bytes: the smaller of the kernel's `MemAvailable` and
/// the address-space limit (`ulimit -v`, `prlimit --as`) less what the process already maps. `None` where
/// neither can be read (no `/proc`). Size guards compare their estimates with it before allocating.
pub fn host_memory_available() -> Option<u64> {
    let field = |text: &str, key: &str| -> Option<u64> {
        let line = text.lines().find(|l| l.starts_with(key))?;
        line[key.len()..].split_whitespace().next()?.parse().ok()
    };
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok();
    let available = meminfo
        .as_deref()
        .and_then(|m| field(m, "MemAvailable:"))
        .map(|kib| kib * 1024);
    let limits = std::fs::read_to_string("/proc/self/limits").ok();
    let address_limit = limits
        .as_deref()
        .and_then(|l| field(l, "Max address space"))
        .and_then(|limit| {
            let status = std::fs::read_to_string("/proc/self/status").ok()?;
            let mapped = field(&status, "VmSize:")? * 1024;
            Some(limit.saturating_sub(mapped))
        });
    match (available, address_limit) {
        (Some(a), Some(l)) => Some(a.min(l)),
        (a, l) => a.or(l),
    }
}

/// The output path that means standard output.
pub const STDOUT: &str = "-";

/// Whether `path` is [`STDOUT`].
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == STDOUT
}

/// Temporary files being written now (see the module invariants).
static IN_FLIGHT: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

fn in_flight() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes every temporary file this process is writing now and exits with `code`: for signal handlers
/// (the CLI's SIGINT/SIGTERM handler), whose process ends before those writes complete. The registry stays
/// locked until the exit, so no write can start a new temporary file after the clean-up (a write
/// registers its temporary before creating it).
pub fn exit_removing_temporaries(code: i32) -> ! {
    let list = in_flight();
    for tmp in list.iter() {
        let _ = std::fs::remove_file(tmp);
    }
    std::process::exit(code)
}

/// Checks, before any work, that `path` can be written as an output, with the error the write itself
/// would give (naming `path`): it names a file, its folder exists, and a file can be created there. The
/// creation is tried for real with the temporary file the write will use, removed at once, so
/// permissions, read-only file systems and root answer as they will at the end. Also removes the
/// temporaries of `path` that killed runs of gregvox left (their process gone). [`STDOUT`] and existing
/// non-regular targets (devices, FIFOs: written in place) pass.
///
/// ```
/// let dir = std::env::temp_dir().join(format!("gregvox-doc-check-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// assert!(gregvox::io::check_output(&dir.join("a.obj")).is_ok());
/// let err = gregvox::io::check_output(&dir.join("missing/a.obj")).unwrap_err().to_string();
/// assert!(err.contains("missing/a.obj") && err.contains("No such file"), "{err}");
/// assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "the probe is gone");
/// ```
pub fn check_output(path: &Path) -> Result<()> {
    if is_stdout(path) || std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
        return Ok(());
    }
    if path.is_dir() {
        return Err(Error::Invalid(format!(
            "{}: is a folder, not an output file",
            path.display()
        )));
    }
    let tmp = temp_path(path)?;
    remove_stale_temporaries_of(path);
    probe(&tmp, path)
}

/// Creates the file `probe` and removes it at once; errors name `target`, what the user asked to write.
/// Created and removed under the registry's lock, as a write's temporary is: a SIGINT between the two
/// would otherwise leave the probe behind (seen on a loaded machine, where the handler thread ran first).
fn probe(probe: &Path, target: &Path) -> Result<()> {
    let _registry = in_flight();
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(probe)
        .map_err(|e| Error::io(target, e))?;
    std::fs::remove_file(probe).map_err(|e| Error::io(target, e))
}

/// Checks, before any work, that output folder `dir` exists as a folder or can be created: its nearest
/// existing ancestor is a folder in which a file can be created (tried with a probe file, removed at once).
/// The folder itself is not created here: a command refused later leaves nothing behind.
///
/// ```
/// let base = std::env::temp_dir().join(format!("gregvox-doc-folder-{}", std::process::id()));
/// std::fs::create_dir_all(&base).unwrap();
/// assert!(gregvox::io::check_output_folder(&base.join("new/deeper")).is_ok());
/// std::fs::write(base.join("file"), "x").unwrap();
/// let err = gregvox::io::check_output_folder(&base.join("file/sub")).unwrap_err().to_string();
/// assert!(err.contains("cannot create the output folder") && err.contains("not a folder"), "{err}");
/// ```
pub fn check_output_folder(dir: &Path) -> Result<()> {
    let mut existing = dir;
    while !existing.exists() {
        match existing.parent() {
            Some(p) if !p.as_os_str().is_empty() => existing = p,
            _ => {
                existing = Path::new(".");
                break;
            }
        }
    }
    if !existing.is_dir() {
        return Err(Error::Invalid(format!(
            "cannot create the output folder {}: {} is not a folder",
            dir.display(),
            existing.display()
        )));
    }
    probe(
        &existing.join(format!(".gregvox-probe.{}.tmp", std::process::id())),
        dir,
    )
}

/// The pid in a temporary file name `.NAME.PID.tmp` (None for other names).
fn temporary_pid(file_name: &str) -> Option<u32> {
    let rest = file_name.strip_prefix('.')?.strip_suffix(".tmp")?;
    rest.rsplit('.').next()?.parse().ok()
}

/// Whether process `pid` is gone (false where that cannot be told: no `/proc`).
fn process_gone(pid: u32) -> bool {
    let proc = Path::new("/proc");
    proc.join("self").exists() && pid != std::process::id() && !proc.join(pid.to_string()).exists()
}

/// Removes the temporaries `.NAME.PID.tmp` of target `path` whose process is gone (best effort: a
/// leftover that cannot be removed is no reason to refuse the command).
fn remove_stale_temporaries_of(path: &Path) {
    let (Some(name), Some(dir)) = (path.file_name(), path.parent()) else {
        return;
    };
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let prefix = format!(".{}.", name.to_string_lossy());
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let file_name = e.file_name().to_string_lossy().into_owned();
        if file_name.starts_with(&prefix)
            && temporary_pid(&file_name).is_some_and(process_gone)
            && file_name[prefix.len()..].matches('.').count() == 1
        {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// The temporary file beside `path`: hidden, and unique per process so concurrent runs do not collide.
fn temp_path(path: &Path) -> Result<PathBuf> {
    let name = path.file_name().ok_or_else(|| {
        Error::Invalid(format!(
            "{}: the output path does not name a file",
            path.display()
        ))
    })?;
    let mut tmp = std::ffi::OsString::from(".");
    tmp.push(name);
    tmp.push(format!(".{}.tmp", std::process::id()));
    Ok(path.with_file_name(tmp))
}

/// Removes, below `dir`, the temporary files [`write_atomic`] left behind in processes that no longer run
/// (killed mid-write: SIGKILL skips every clean-up), and returns how many. A temporary whose process is
/// alive, or whose liveness cannot be told (no `/proc`), is kept: a concurrent run may be writing it.
pub fn remove_stale_temporaries(dir: &Path) -> Result<usize> {
    if !Path::new("/proc/self").exists() || !dir.is_dir() {
        return Ok(0);
    }
    let mut removed = 0;
    for entry in walkdir::WalkDir::new(dir)
        .into_iter()
        .filter_map(|e| e.ok())
    {
        let name = entry.file_name().to_string_lossy();
        if entry.file_type().is_file() && temporary_pid(&name).is_some_and(process_gone) {
            std::fs::remove_file(entry.path()).map_err(|e| Error::io(entry.path(), e))?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// Writes an output file through `write` (see the module invariants).
///
/// ```
/// use std::io::Write;
/// let dir = std::env::temp_dir().join(format!("gregvox-doc-io-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("out.txt");
/// gregvox::io::write_atomic(&path, |w| w.write_all(b"first")).unwrap();
/// // A failing writer leaves the old contents in place and no temporary file behind.
/// let err = gregvox::io::write_atomic(&path, |w| {
///     w.write_all(b"partial")?;
///     Err(std::io::Error::other("injected"))
/// });
/// assert!(err.unwrap_err().to_string().contains("out.txt"));
/// assert_eq!(std::fs::read(&path).unwrap(), b"first");
/// assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
/// ```
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    if is_stdout(path) {
        let stdout = std::io::stdout();
        let mut w = std::io::BufWriter::new(stdout.lock());
        return write(&mut w)
            .and_then(|()| w.flush())
            .map_err(|e| Error::io("standard output", e));
    }
    // `metadata` follows symlinks: a link to /dev/full counts as the device it points to.
    let special = std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir());
    if special {
        let result = (|| {
            let file = std::fs::OpenOptions::new()
                .write(true)
                .truncate(true)
                .open(path)?;
            let mut w = std::io::BufWriter::new(file);
            write(&mut w)?;
            // Flush explicitly: BufWriter's drop would swallow the error (ENOSPC on /dev/full).
            w.flush()
        })();
        return result.map_err(|e| Error::io(path, e));
    }
    let tmp = temp_path(path)?;
    let result = (|| {
        // Created and registered under the registry's lock: a signal handler cleaning up either runs
        // before (and this write never starts: the handler keeps the lock until the exit) or sees it.
        let file = {
            let mut registry = in_flight();
            let file = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&tmp)?;
            registry.push(tmp.clone());
            file
        };
        let mut w = std::io::BufWriter::new(file);
        write(&mut w)?;
        w.flush()?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    in_flight().retain(|t| t != &tmp);
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}
