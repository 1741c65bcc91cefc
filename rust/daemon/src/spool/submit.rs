//! Submitting a job as a client should: written aside, renamed into `jobs/` whole.

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use antumbra_core::atomic_file::write_bytes_atomic;

use super::name::check_job_id;
use super::{JobSpec, SpoolDirs, JOB_FILE, SCENE_FILE};

/// Submits a job the way a client should: writes `job.json` and the recording into
/// `DIR/incoming/<unique>/`, then renames that folder to `DIR/jobs/<id>/`. Fails if a job with
/// this id exists, or if the id is not a plain folder name of at most [`MAX_JOB_ID_BYTES`].
///
/// [`MAX_JOB_ID_BYTES`]: super::MAX_JOB_ID_BYTES
pub fn submit_job(
    root: &Path,
    id: &str,
    spec: &JobSpec,
    write_scene: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<PathBuf, String> {
    let dirs = SpoolDirs::new(root);
    check_job_id(id)?;
    for d in [&dirs.incoming, &dirs.jobs] {
        fs::create_dir_all(d).map_err(|e| format!("{}: {e}", d.display()))?;
    }
    // The id's beginning only: with the suffix a long id would pass the 255 bytes of a name.
    let temp = dirs.incoming.join(format!(
        "{}-{}-{}",
        beginning(id, 64),
        std::process::id(),
        unique()
    ));
    fs::create_dir(&temp).map_err(|e| format!("{}: {e}", temp.display()))?;
    let text = serde_json::to_string_pretty(spec).map_err(|e| e.to_string())?;
    write_bytes_atomic(&temp.join(JOB_FILE), text.as_bytes()).map_err(|e| e.to_string())?;
    write_scene(&temp.join(SCENE_FILE))?;
    let target = dirs.jobs.join(id);
    if target.symlink_metadata().is_ok() {
        let _ = fs::remove_dir_all(&temp);
        return Err(format!("job '{id}' exists already"));
    }
    fs::rename(&temp, &target).map_err(|e| format!("{}: {e}", target.display()))?;
    Ok(target)
}

/// At most `max` bytes of `text`, cut between characters.
fn beginning(text: &str, max: usize) -> &str {
    let mut end = max.min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    &text[..end]
}

fn unique() -> u64 {
    static N: AtomicU64 = AtomicU64::new(0);
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64);
    t ^ N.fetch_add(1, Ordering::Relaxed).rotate_left(48)
}
