//! Spool helpers: submitting a job of scenes, waiting for a result file.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use antumbra_core::scene::Scene;
use antumbra_daemon::spool::{submit_job, JobSpec, Manifest, MANIFEST_FILE};
use antumbra_protocol::RecordingWriter;

use super::TIMEOUT;

/// Submits `scenes` as job `id` the way a client must (written aside, renamed into `jobs/`).
pub fn submit(root: &Path, id: &str, scenes: &[Scene], spec: &JobSpec) -> PathBuf {
    submit_job(root, id, spec, |path| write_recording(path, scenes)).unwrap()
}

/// Writes `scenes` as a recording at `path`.
pub fn write_recording(path: &Path, scenes: &[Scene]) -> Result<(), String> {
    let mut w = RecordingWriter::create(path).map_err(|e| e.to_string())?;
    for s in scenes {
        w.append_scene(s).map_err(|e| e.to_string())?;
    }
    w.finish().map_err(|e| e.to_string())?;
    Ok(())
}

/// Waits until `path` exists (not following a final symbolic link).
pub fn wait_for_file(path: &Path) {
    wait_until(&format!("{}", path.display()), || {
        path.symlink_metadata().is_ok()
    });
}

/// Waits until `done` holds, with the tests' generous deadline.
pub fn wait_until(what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + TIMEOUT;
    while !done() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

pub fn manifest(results: &Path) -> Manifest {
    serde_json::from_slice(&std::fs::read(results.join(MANIFEST_FILE)).unwrap()).unwrap()
}
