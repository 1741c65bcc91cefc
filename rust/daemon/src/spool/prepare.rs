//! Taking the spool: its folders, its lock, and the temporaries a killed daemon left.

use std::fs::{self, File};
use std::os::fd::AsRawFd;
use std::path::Path;

use antumbra_core::atomic_file::TEMP_SUFFIX;

use super::SpoolDirs;
use crate::error::DaemonError;

/// Prefix of the temporary folder a frame is written into before it is renamed into place.
pub(super) const TEMP_PREFIX: &str = ".tmp-";

/// An exclusive lock on `DIR/daemon.lock` (flock): two daemons on one spool would fight over
/// temporary folders. The kernel releases it when the process dies, even by `kill -9`.
pub struct SpoolLock {
    _file: File,
}

/// Creates the spool folders, takes the spool lock and removes temporary leftovers of a daemon
/// that was killed.
pub fn prepare(root: &Path) -> Result<SpoolLock, DaemonError> {
    let dirs = SpoolDirs::new(root);
    for d in [&dirs.root, &dirs.incoming, &dirs.jobs, &dirs.results] {
        fs::create_dir_all(d).map_err(|e| DaemonError::path(d, format!("cannot create: {e}")))?;
    }
    let lock_path = root.join("daemon.lock");
    let file = fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&lock_path)
        .map_err(|e| DaemonError::path(&lock_path, e.to_string()))?;
    // SAFETY: flock on a descriptor we own; it is released when the file is closed.
    let rc = unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) };
    if rc != 0 {
        return Err(DaemonError::path(
            root,
            "another daemon is using this spool folder (daemon.lock is held)",
        ));
    }
    clean_temporaries(&dirs);
    Ok(SpoolLock { _file: file })
}

/// Removes temporary frame folders and temporary files in every job's result folder, in
/// `results/` and in the spool folder (`status.json`, `<job>.ERROR`). Job folders that are
/// symbolic links are not entered: their targets are not the spool's.
fn clean_temporaries(dirs: &SpoolDirs) {
    remove_temporaries(&dirs.root);
    remove_temporaries(&dirs.results);
    let Ok(jobs) = fs::read_dir(&dirs.results) else {
        return;
    };
    for job in jobs.flatten() {
        if job.file_type().is_ok_and(|t| t.is_dir()) {
            remove_temporaries(&job.path());
        }
    }
}

fn remove_temporaries(dir: &Path) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let path = e.path();
        let Ok(kind) = e.file_type() else {
            continue;
        };
        let removed = if name.starts_with(TEMP_PREFIX) && kind.is_dir() {
            fs::remove_dir_all(&path)
        } else if name.starts_with('.') && name.ends_with(TEMP_SUFFIX) && !kind.is_dir() {
            fs::remove_file(&path)
        } else {
            continue;
        };
        match removed {
            Ok(()) => tracing::info!(path = %path.display(), "removed a leftover temporary"),
            Err(e) => tracing::warn!(path = %path.display(), error = %e, "cannot remove"),
        }
    }
}
