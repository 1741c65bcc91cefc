//! One pass over `jobs/`: every unfinished job in id order, and where its failure is written.

use std::collections::HashSet;
use std::fs;

use super::name::JobName;
use super::results::{is_file, refusal_path, write_refusal};
use super::retry::{until_written, Status};
use super::{job, JobError, SpoolDirs, DONE_FILE, ERROR_FILE};
use crate::shared::Shared;

/// What the spool keeps between passes.
pub(super) struct Scanner {
    pub status: Status,
    /// Jobs whose end could be written nowhere (their `<id>.ERROR` is a name the file system
    /// refuses): skipped until the daemon restarts, rather than tried again at every pass.
    unrecorded: HashSet<String>,
}

impl Scanner {
    pub fn new(status: Status) -> Scanner {
        Scanner {
            status,
            unrecorded: HashSet::new(),
        }
    }
}

/// Renders every unfinished job, oldest id first.
pub(super) fn scan(shared: &Shared, dirs: &SpoolDirs, scanner: &mut Scanner) {
    // Real folders and symbolic links (refused with an ERROR); `file_type` does not follow
    // links. Other files in `jobs/` are not jobs.
    let mut names: Vec<JobName> = match fs::read_dir(&dirs.jobs) {
        Ok(entries) => entries
            .flatten()
            .filter(|e| e.file_type().is_ok_and(|t| t.is_dir() || t.is_symlink()))
            .map(|e| JobName::new(e.file_name()))
            .filter(|n| !n.id.starts_with('.'))
            .collect(),
        Err(e) => {
            tracing::warn!(error = %e, "cannot list the spool's jobs");
            return;
        }
    };
    names.sort_by(|a, b| a.id.cmp(&b.id));
    let status = &mut scanner.status;
    for name in names {
        if shared.stopping() {
            return;
        }
        let id = name.id.as_str();
        if finished(dirs, id) || scanner.unrecorded.contains(id) {
            continue;
        }
        match job::run_job(shared, dirs, status, &name) {
            Ok(()) | Err(JobError::Stopped) | Err(JobError::Failed(_)) => {}
            Err(JobError::Refused(message)) => {
                tracing::error!(job = %id, error = %message, "job refused");
                let path = refusal_path(&dirs.results, id);
                let written = until_written(shared, status, id, None, || {
                    write_refusal(&dirs.results, id, &message)
                });
                if let Err(JobError::Failed(e)) = written {
                    tracing::error!(job = %id, path = %path.display(), error = %e,
                        "cannot refuse the job; it is skipped until the daemon restarts");
                    scanner.unrecorded.insert(id.to_string());
                }
            }
        }
        if shared.stopping() {
            return;
        }
    }
    status.idle();
}

/// Whether a job has its end: `DONE` or `ERROR` in its results folder (as regular files in a
/// real folder), or `results/<job>.ERROR`.
fn finished(dirs: &SpoolDirs, id: &str) -> bool {
    if is_file(&refusal_path(&dirs.results, id)) {
        return true;
    }
    let results = dirs.results.join(id);
    results.symlink_metadata().is_ok_and(|m| m.is_dir())
        && (is_file(&results.join(DONE_FILE)) || is_file(&results.join(ERROR_FILE)))
}
