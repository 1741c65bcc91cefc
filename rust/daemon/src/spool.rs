//! The spool: batch jobs as folders, rendered frame by frame with results that appear atomically.
//!
//! ```text
//! DIR/incoming/<tmp>/            a client writes a job here ...
//! DIR/jobs/<job-id>/             ... then renames it here (atomic): job.json + scene.antrec
//! DIR/results/<job-id>/frame_NNNN/   one folder per finished frame (renamed into place whole)
//! DIR/results/<job-id>/manifest.json the finished frames and their files (rewritten atomically)
//! DIR/results/<job-id>/DONE          written once every frame is finished
//! DIR/results/<job-id>/ERROR         written instead if the job cannot be rendered
//! ```
//!
//! A frame's folder is written under a temporary name and renamed into place, so a folder named
//! `frame_NNNN` is always complete; a restarted daemon skips those frames, removes leftover
//! temporary folders and finishes the rest. The manifest is rebuilt from the frame folders
//! that exist, so it lists each finished frame exactly once whatever happened before.
//! `docs/daemon.md` documents `job.json`.

use std::collections::HashSet;
use std::fs::{self, File};
use std::os::fd::AsRawFd;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant};

use antumbra_core::atomic_file::write_bytes_atomic;
use antumbra_core::cancel::CancelToken;
use antumbra_core::render::Renderer;
use antumbra_core::scene::Animation;
use antumbra_protocol::{
    check_limits, frame_update_from_scene, render_settings, NamedSettings, RecordedAnimation,
    Request,
};
use notify::Watcher;
use serde::{Deserialize, Serialize};

use crate::error::DaemonError;
use crate::shared::{bump, Shared};
use crate::slots::Acquired;
use antumbra_core::output::{frame_stem, write_frame_files, Outputs};

pub const JOB_FILE: &str = "job.json";
pub const SCENE_FILE: &str = "scene.antrec";
pub const MANIFEST_FILE: &str = "manifest.json";
pub const DONE_FILE: &str = "DONE";
pub const ERROR_FILE: &str = "ERROR";
/// Prefix of the temporary folder a frame is written into before it is renamed into place.
const TEMP_PREFIX: &str = ".tmp-";
/// Suffix of antumbra-core's temporary files (atomic writes).
const CORE_TEMP_SUFFIX: &str = ".antumbra-tmp";

/// `job.json`: what to render from the job's recording. Every field may be omitted.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct JobSpec {
    /// Format version of this file: 1.
    pub version: u32,
    /// The label of the statistics rows (`scene` column); default: the job id.
    pub name: Option<String>,
    /// The frames to render, in this order; default: every frame in the recording.
    pub frames: Option<Vec<i32>>,
    /// Render settings as in the protocol's `Render` request.
    pub settings: NamedSettings,
    /// Which files each frame gets.
    pub outputs: Outputs,
}

/// One finished frame in `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifestFrame {
    pub frame: i32,
    /// The frame's folder, relative to the job's result folder.
    pub dir: String,
    /// The files in it.
    pub files: Vec<String>,
}

/// `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub job: String,
    /// Frames the job asks for.
    pub frames_total: usize,
    /// Finished frames in the job's frame order, each once.
    pub frames: Vec<ManifestFrame>,
    /// True once every frame is finished (and `DONE` is, or is about to be, written).
    pub done: bool,
}

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

/// Removes temporary frame folders and temporary files in every job's result folder.
fn clean_temporaries(dirs: &SpoolDirs) {
    let Ok(jobs) = fs::read_dir(&dirs.results) else {
        return;
    };
    for job in jobs.flatten() {
        let Ok(entries) = fs::read_dir(job.path()) else {
            continue;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let path = e.path();
            let removed = if name.starts_with(TEMP_PREFIX) {
                fs::remove_dir_all(&path)
            } else if name.ends_with(CORE_TEMP_SUFFIX) {
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
    let mut failed: HashSet<String> = HashSet::new();
    while !shared.stopping() {
        // Drain pending events first: the scan below sees everything they announced.
        while rx.try_recv().is_ok() {}
        scan(&shared, &dirs, &mut failed);
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

/// Renders every unfinished job, oldest id first.
fn scan(shared: &Shared, dirs: &SpoolDirs, failed: &mut HashSet<String>) {
    let mut ids: Vec<String> = match fs::read_dir(&dirs.jobs) {
        Ok(entries) => entries
            .flatten()
            .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| !n.starts_with('.'))
            .collect(),
        Err(e) => {
            tracing::warn!(error = %e, "cannot list the spool's jobs");
            return;
        }
    };
    ids.sort();
    for id in ids {
        if shared.stopping() {
            return;
        }
        let results = dirs.results.join(&id);
        if results.join(DONE_FILE).exists() || results.join(ERROR_FILE).exists() {
            continue;
        }
        if failed.contains(&id) {
            continue;
        }
        match run_job(shared, dirs, &id) {
            Ok(()) => {}
            Err(JobError::Stopped) => return,
            Err(JobError::Failed(message)) => {
                tracing::error!(job = %id, error = %message, "job failed");
                let text = format!("{message}\n");
                if let Err(e) = write_bytes_atomic(&results.join(ERROR_FILE), text.as_bytes()) {
                    tracing::error!(job = %id, error = %e, "cannot write the job's ERROR file");
                    failed.insert(id);
                }
            }
        }
    }
}

enum JobError {
    Stopped,
    Failed(String),
}

fn failed(e: impl std::fmt::Display) -> JobError {
    JobError::Failed(e.to_string())
}

/// Reads and checks a job's spec.
pub fn read_job_spec(path: &Path) -> Result<JobSpec, String> {
    let mut text = String::new();
    antumbra_protocol::recording::open_regular(path)
        .and_then(|mut f| std::io::Read::read_to_string(&mut f, &mut text))
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let spec: JobSpec =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    if spec.version > 1 {
        return Err(format!(
            "{}: version {} is newer than this daemon understands (1)",
            path.display(),
            spec.version
        ));
    }
    Ok(spec)
}

fn run_job(shared: &Shared, dirs: &SpoolDirs, id: &str) -> Result<(), JobError> {
    let job_dir = dirs.jobs.join(id);
    let results = dirs.results.join(id);
    fs::create_dir_all(&results).map_err(|e| failed(format!("{}: {e}", results.display())))?;
    let spec = read_job_spec(&job_dir.join(JOB_FILE)).map_err(JobError::Failed)?;
    let settings =
        render_settings(&spec.settings).map_err(|e| failed(format!("job.json settings: {e}")))?;
    let anim = RecordedAnimation::open(job_dir.join(SCENE_FILE)).map_err(failed)?;
    let mut seen = HashSet::new();
    let frames: Vec<i32> = spec
        .frames
        .clone()
        .unwrap_or_else(|| anim.recorded_frames().collect())
        .into_iter()
        .filter(|f| seen.insert(*f))
        .collect();
    if frames.is_empty() {
        return Err(failed("job.json: no frames to render"));
    }
    let label = spec.name.clone().unwrap_or_else(|| id.to_string());
    let todo: Vec<i32> = frames
        .iter()
        .copied()
        .filter(|&f| !results.join(frame_stem(f)).exists())
        .collect();
    tracing::info!(job = %id, frames = frames.len(), todo = todo.len(), "job started");
    let t0 = Instant::now();
    let mut renderer = Renderer::new();
    for frame in todo {
        if shared.stopping() {
            return Err(JobError::Stopped);
        }
        let scene = anim.frame(frame);
        let update =
            frame_update_from_scene(&scene).map_err(|e| failed(format!("frame {frame}: {e}")))?;
        check_limits(&Request::FrameUpdate(update), &shared.config.limits).map_err(failed)?;
        let mut slot = match shared.slots.acquire(|| shared.stopping(), None, |_| {}) {
            Acquired::Slot(s, _) => s,
            _ => return Err(JobError::Stopped),
        };
        // A stopping daemon cancels the frame; it is rendered again on the next start.
        let stop = CancelToken::from_flag(shared.stop.clone());
        let result = catch_unwind(AssertUnwindSafe(|| {
            slot.install(|| renderer.render_cancellable(&label, &scene, &settings, &stop))
        }));
        drop(slot);
        let result = match result {
            Ok(Ok(r)) => r,
            Ok(Err(antumbra_core::Error::Cancelled)) => return Err(JobError::Stopped),
            Ok(Err(e)) => {
                bump(&shared.counters.renders_failed);
                return Err(failed(format!("frame {frame}: {e}")));
            }
            Err(_) => {
                bump(&shared.counters.renders_failed);
                return Err(failed(format!(
                    "frame {frame}: internal error in the renderer"
                )));
            }
        };
        write_frame_folder(&results, &result, &spec.outputs)
            .map_err(|e| failed(format!("frame {frame}: {e}")))?;
        bump(&shared.counters.renders_done);
        write_manifest(&results, id, &frames, false).map_err(failed)?;
        tracing::info!(job = %id, frame, "frame finished");
    }
    write_manifest(&results, id, &frames, true).map_err(failed)?;
    let done = serde_json::json!({ "job": id, "frames": frames.len() });
    write_bytes_atomic(&results.join(DONE_FILE), done.to_string().as_bytes()).map_err(failed)?;
    tracing::info!(job = %id, frames = frames.len(), seconds = t0.elapsed().as_secs_f64(), "job done");
    Ok(())
}

/// Writes a frame's files into a temporary folder, then renames the folder into place.
fn write_frame_folder(
    results: &Path,
    result: &antumbra_core::render::FrameResult,
    outputs: &Outputs,
) -> Result<(), String> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let stem = frame_stem(result.frame);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let temp = results.join(format!("{TEMP_PREFIX}{stem}-{}-{n}", std::process::id()));
    let fin = results.join(&stem);
    let write = || -> Result<(), String> {
        fs::create_dir(&temp).map_err(|e| format!("{}: {e}", temp.display()))?;
        write_frame_files(&temp, result, outputs).map_err(|e| e.to_string())?;
        sync_dir(&temp);
        fs::rename(&temp, &fin).map_err(|e| format!("{}: {e}", fin.display()))?;
        sync_dir(results);
        Ok(())
    };
    let r = write();
    if r.is_err() {
        let _ = fs::remove_dir_all(&temp);
    }
    r
}

fn sync_dir(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Rebuilds `manifest.json` from the frame folders that exist.
fn write_manifest(results: &Path, id: &str, frames: &[i32], done: bool) -> Result<(), String> {
    let mut listed = Vec::new();
    for &f in frames {
        let dir = frame_stem(f);
        let path = results.join(&dir);
        let Ok(entries) = fs::read_dir(&path) else {
            continue;
        };
        let mut files: Vec<String> = entries
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        files.sort();
        listed.push(ManifestFrame {
            frame: f,
            dir,
            files,
        });
    }
    let manifest = Manifest {
        job: id.to_string(),
        frames_total: frames.len(),
        done: done && listed.len() == frames.len(),
        frames: listed,
    };
    let text = serde_json::to_string_pretty(&manifest).map_err(|e| e.to_string())?;
    write_bytes_atomic(&results.join(MANIFEST_FILE), text.as_bytes()).map_err(|e| e.to_string())
}

/// Submits a job the way a client should: writes `job.json` and the recording into
/// `DIR/incoming/<unique>/`, then renames that folder to `DIR/jobs/<id>/`. Fails if a job with
/// this id exists.
pub fn submit_job(
    root: &Path,
    id: &str,
    spec: &JobSpec,
    write_scene: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<PathBuf, String> {
    let dirs = SpoolDirs::new(root);
    if id.is_empty() || id.starts_with('.') || id.contains(['/', '\\']) {
        return Err(format!("job id '{id}': must be a plain folder name"));
    }
    for d in [&dirs.incoming, &dirs.jobs] {
        fs::create_dir_all(d).map_err(|e| format!("{}: {e}", d.display()))?;
    }
    let temp = dirs
        .incoming
        .join(format!("{id}-{}-{}", std::process::id(), unique()));
    fs::create_dir(&temp).map_err(|e| format!("{}: {e}", temp.display()))?;
    let text = serde_json::to_string_pretty(spec).map_err(|e| e.to_string())?;
    write_bytes_atomic(&temp.join(JOB_FILE), text.as_bytes()).map_err(|e| e.to_string())?;
    write_scene(&temp.join(SCENE_FILE))?;
    let target = dirs.jobs.join(id);
    if target.exists() {
        let _ = fs::remove_dir_all(&temp);
        return Err(format!("job '{id}' exists already"));
    }
    fs::rename(&temp, &target).map_err(|e| format!("{}: {e}", target.display()))?;
    Ok(target)
}

fn unique() -> u64 {
    static N: AtomicU64 = AtomicU64::new(0);
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64);
    t ^ N.fetch_add(1, Ordering::Relaxed).rotate_left(48)
}
