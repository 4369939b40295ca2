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
use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

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
    let proc = Path::new("/proc");
    if !proc.join("self").exists() || !dir.is_dir() {
        return Ok(0);
    }
    let mut removed = 0;
    for entry in walkdir::WalkDir::new(dir)
        .into_iter()
        .filter_map(|e| e.ok())
    {
        let name = entry.file_name().to_string_lossy();
        let Some(rest) = name.strip_prefix('.').and_then(|n| n.strip_suffix(".tmp")) else {
            continue;
        };
        let Some(pid) = rest.rsplit('.').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        if entry.file_type().is_file()
            && pid != std::process::id()
            && !proc.join(pid.to_string()).exists()
        {
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
        let file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)?;
        let mut w = std::io::BufWriter::new(file);
        write(&mut w)?;
        w.flush()?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}
