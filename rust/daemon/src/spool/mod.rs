//! The spool: batch jobs as folders, rendered frame by frame with results that appear atomically.
//!
//! ```text
//! DIR/incoming/<tmp>/            a client writes a job here ...
//! DIR/jobs/<job-id>/             ... then renames it here (atomic): job.json + scene.antrec
//! DIR/results/<job-id>/frame_NNNN/   one folder per finished frame (renamed into place whole)
//! DIR/results/<job-id>/manifest.json the finished frames and their files (rewritten atomically)
//! DIR/results/<job-id>/attempts.log  one line per frame start (synced before the render)
//! DIR/results/<job-id>/DONE          written once every frame is finished
//! DIR/results/<job-id>/ERROR         written instead if the job cannot be rendered
//! DIR/results/<job-id>.ERROR         a job refused because results/<job-id> is unsafe
//! DIR/status.json                    what the spool does now (rendering, waiting, idle)
//! ```
//!
//! A frame's folder is written under a temporary name and renamed into place, so a folder named
//! `frame_NNNN` is always complete; a restarted daemon skips those frames, removes leftover
//! temporary folders and finishes the rest. The manifest is rebuilt from the frame folders
//! that exist, so it lists each finished frame exactly once whatever happened before. A frame
//! started too often without finishing (it kills the daemon) ends its job in `ERROR`, which
//! `antumbra spool resume` ([`resume_job`]) undoes; a failed write waits and retries unless it
//! can never work; nothing is written or counted through a symbolic link.
//! `docs/daemon.md` documents the layout and the policies.

mod attempts;
mod job;
mod name;
mod prepare;
mod results;
mod resume;
mod retry;
mod scan;
mod spec;
mod submit;

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant};

use notify::Watcher;

use crate::shared::Shared;

pub use attempts::ATTEMPTS_FILE;
pub use name::MAX_JOB_ID_BYTES;
pub use prepare::{prepare, SpoolLock};
pub use resume::{resume_job, Resumed};
pub use retry::STATUS_FILE;
pub use spec::{read_job_spec, JobSpec, Manifest, ManifestFrame};
pub use submit::submit_job;

pub const JOB_FILE: &str = "job.json";
pub const SCENE_FILE: &str = "scene.antrec";
pub const MANIFEST_FILE: &str = "manifest.json";
pub const DONE_FILE: &str = "DONE";
pub const ERROR_FILE: &str = "ERROR";

/// The spool folder's layout.
#[derive(Clone, Debug)]
pub struct SpoolDirs {
    pub root: PathBuf,
    pub incoming: PathBuf,
    pub jobs: PathBuf,
    pub results: PathBuf,
}

impl SpoolDirs {
    pub fn new(root: &Path) -> Self {
        SpoolDirs {
            root: root.to_path_buf(),
            incoming: root.join("incoming"),
            jobs: root.join("jobs"),
            results: root.join("results"),
        }
    }
}

/// The spool thread: renders jobs until the daemon stops. Wakes on file-system events in
/// `jobs/` and rescans periodically anyway (events can be missed, e.g. on network folders).
pub(crate) fn run(shared: Arc<Shared>, root: PathBuf) {
    let dirs = SpoolDirs::new(&root);
    let (tx, rx) = mpsc::channel::<()>();
    let watcher = notify::recommended_watcher(move |_event: notify::Result<notify::Event>| {
        let _ = tx.send(());
    })
    .and_then(|mut w| {
        w.watch(&dirs.jobs, notify::RecursiveMode::NonRecursive)?;
        Ok(w)
    });
    let _watcher = match watcher {
        Ok(w) => Some(w),
        Err(e) => {
            tracing::warn!(error = %e, "cannot watch the spool folder; rescanning periodically");
            None
        }
    };
    tracing::info!(spool = %root.display(), "spool started");
    let mut scanner = scan::Scanner::new(retry::Status::new(&dirs.root));
    while !shared.stopping() {
        // Drain pending events first: the scan below sees everything they announced.
        while rx.try_recv().is_ok() {}
        scan::scan(&shared, &dirs, &mut scanner);
        let next_scan = Instant::now() + shared.config.spool_rescan;
        while !shared.stopping() {
            let left = next_scan.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            match rx.recv_timeout(left.min(Duration::from_millis(100))) {
                Ok(()) => break,
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    std::thread::sleep(left.min(Duration::from_millis(100)))
                }
            }
        }
    }
    tracing::info!("spool stopped");
}

/// Why a job did not finish.
pub(crate) enum JobError {
    /// The daemon is stopping; the job resumes at the next start.
    Stopped,
    /// The job cannot be rendered: the reason goes to `results/<job>/ERROR`.
    Failed(String),
    /// `results/<job>` is not safe to write into: the reason goes to `results/<job>.ERROR`.
    Refused(String),
}

pub(crate) fn failed(e: impl std::fmt::Display) -> JobError {
    JobError::Failed(e.to_string())
}
