//! `antumbra spool resume`: a job that ended in `ERROR` goes on from its first missing frame.
//! The daemon cannot tell a `kill -9` from a frame that kills it, so a job killed from outside
//! during one frame `--spool-max-attempts` times ends like a crash loop; this undoes that.

use std::fs;
use std::path::{Path, PathBuf};

use super::attempts::Attempts;
use super::name::check_job_id;
use super::results::{is_file, refusal_path, sync_dir, JobResults};
use super::{SpoolDirs, DONE_FILE, ERROR_FILE};

/// What [`resume_job`] did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Resumed {
    /// Frame folders already finished (kept, not rendered again).
    pub frames_done: usize,
    /// The end markers removed (`results/<id>/ERROR`, `results/<id>.ERROR`).
    pub removed: Vec<PathBuf>,
}

/// Resumes job `id` of the spool at `root`: its frame starts so far are forgiven (a `resume`
/// line in `attempts.log`, so the log keeps its history), then its `ERROR` is removed, in that
/// order so a daemon never sees the job unended with its old count. A daemon watching the spool
/// renders the missing frames at once; finished frames stay as they are.
pub fn resume_job(root: &Path, id: &str) -> Result<Resumed, String> {
    check_job_id(id)?;
    let dirs = SpoolDirs::new(root);
    let job = dirs.jobs.join(id);
    if job.symlink_metadata().is_err() {
        return Err(format!("{}: no such job", job.display()));
    }
    let dir = dirs.results.join(id);
    let error = dir.join(ERROR_FILE);
    let refusal = refusal_path(&dirs.results, id);
    if is_file(&dir.join(DONE_FILE)) {
        return Err(format!(
            "{}: the job is done; nothing to resume",
            dir.join(DONE_FILE).display()
        ));
    }
    let real_dir = dir.symlink_metadata().is_ok_and(|m| m.is_dir());
    let has_error = real_dir && is_file(&error);
    if !has_error && !is_file(&refusal) {
        return Err(format!(
            "job {id} has no {} nor {}: it is waiting or being rendered; nothing to resume",
            error.display(),
            refusal.display()
        ));
    }
    let mut removed = Vec::new();
    if has_error {
        let results = JobResults::open(&dir).map_err(|e| e.into_message())?;
        Attempts::record_resume(&results).map_err(|e| e.into_message())?;
        remove(&error, &dir, &mut removed)?;
    }
    if is_file(&refusal) {
        remove(&refusal, &dirs.results, &mut removed)?;
    }
    wake(&dirs.jobs);
    Ok(Resumed {
        frames_done: frame_folders(&dir),
        removed,
    })
}

fn remove(path: &Path, dir: &Path, removed: &mut Vec<PathBuf>) -> Result<(), String> {
    fs::remove_file(path).map_err(|e| format!("cannot remove {}: {e}", path.display()))?;
    sync_dir(dir);
    removed.push(path.to_path_buf());
    Ok(())
}

/// The finished frames: real folders named `frame_*` (temporaries start with `.`).
fn frame_folders(dir: &Path) -> usize {
    fs::read_dir(dir).map_or(0, |entries| {
        entries
            .flatten()
            .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
            .filter(|e| e.file_name().to_string_lossy().starts_with("frame_"))
            .count()
    })
}

/// Wakes a daemon watching `jobs/` (it watches only that folder) with a hidden file it ignores;
/// without it the job would wait for the next periodic rescan. Best effort.
fn wake(jobs: &Path) {
    let probe = jobs.join(format!(".resume-{}", std::process::id()));
    if fs::write(&probe, b"").is_ok() {
        let _ = fs::remove_file(&probe);
    }
}
