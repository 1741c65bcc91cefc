//! Writes that wait: a failed write of a job's results (a read-only folder, a full disk) is
//! retried with a doubling delay until it works, and `DIR/status.json` and the log say so.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use antumbra_core::atomic_file::write_bytes_atomic;
use serde::Serialize;

use super::results::WriteError;
use super::JobError;
use crate::shared::Shared;

/// What the spool does now, rewritten atomically at each change; in the spool folder, so a
/// job whose results folder cannot be written still gets its state reported.
pub const STATUS_FILE: &str = "status.json";

#[derive(Clone, Debug, PartialEq, Serialize)]
struct StatusFile {
    /// `rendering`, `waiting` or `idle`.
    state: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    job: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    frame: Option<i32>,
    /// For `waiting`: the failed write, its retry count and the seconds to the next one.
    #[serde(skip_serializing_if = "Option::is_none")]
    message: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    retry: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    retry_in_s: Option<f64>,
    /// One line for people: `waiting: cannot write ...; retry 3 in 8 s`.
    text: String,
}

/// `DIR/status.json` and what was last written to it.
pub(crate) struct Status {
    path: PathBuf,
    last: Option<StatusFile>,
    /// The status file itself cannot be written (said once in the log).
    failing: bool,
}

impl Status {
    pub fn new(root: &Path) -> Status {
        Status {
            path: root.join(STATUS_FILE),
            last: None,
            failing: false,
        }
    }

    pub fn rendering(&mut self, job: &str, frame: i32) {
        self.set(StatusFile {
            state: "rendering",
            job: Some(job.into()),
            frame: Some(frame),
            message: None,
            retry: None,
            retry_in_s: None,
            text: format!("rendering job {job} frame {frame}"),
        });
    }

    pub fn idle(&mut self) {
        self.set(StatusFile {
            state: "idle",
            job: None,
            frame: None,
            message: None,
            retry: None,
            retry_in_s: None,
            text: "idle".into(),
        });
    }

    fn waiting(
        &mut self,
        job: &str,
        frame: Option<i32>,
        message: &str,
        retry: u32,
        wait: Duration,
    ) {
        let s = wait.as_secs_f64();
        self.set(StatusFile {
            state: "waiting",
            job: Some(job.into()),
            frame,
            message: Some(message.into()),
            retry: Some(retry),
            retry_in_s: Some(s),
            text: format!("waiting: {message}; retry {retry} in {s} s"),
        });
    }

    fn set(&mut self, status: StatusFile) {
        if self.last.as_ref() == Some(&status) {
            return;
        }
        let text = serde_json::to_string_pretty(&status).expect("status serialises");
        match write_bytes_atomic(&self.path, text.as_bytes()) {
            Ok(()) => {
                if self.failing {
                    tracing::info!(path = %self.path.display(), "the spool's status file is written again");
                }
                self.failing = false;
                self.last = Some(status);
            }
            Err(e) => {
                if !self.failing {
                    tracing::warn!(error = %e, "cannot write the spool's status file");
                }
                self.failing = true;
            }
        }
    }
}

/// Distinct failures of one wait said in the log; past them the status file alone tells.
const MAX_LOGGED_FAILURES: usize = 8;

/// Runs `write` until it works: a failed write is retried after `spool_retry_min`, doubling
/// up to `spool_retry_max`, with the state in the status file (each retry) and the log (each
/// change). An unsafe name, or one the file system can never take, fails the job at once; a
/// stopping daemon ends the wait.
pub(crate) fn until_written<T>(
    shared: &Shared,
    status: &mut Status,
    job: &str,
    frame: Option<i32>,
    mut write: impl FnMut() -> Result<T, WriteError>,
) -> Result<T, JobError> {
    let mut retry = 0u32;
    // The failures of this wait said in the log: each once, not once per retry (their text
    // holds no temporary name, so a repeated failure reads the same).
    let mut logged: Vec<String> = Vec::new();
    loop {
        match write() {
            Ok(v) => {
                if retry > 0 {
                    tracing::info!(job, retries = retry, "writing works again; the job goes on");
                    match frame {
                        Some(f) => status.rendering(job, f),
                        None => status.idle(),
                    }
                }
                return Ok(v);
            }
            Err(WriteError::Unsafe(message) | WriteError::Invalid(message)) => {
                return Err(JobError::Failed(message))
            }
            Err(WriteError::Io(message)) => {
                retry += 1;
                let wait = backoff(shared, retry);
                if !logged.contains(&message) && logged.len() < MAX_LOGGED_FAILURES {
                    tracing::warn!(job, error = %message, retry_in_s = wait.as_secs_f64(),
                        "cannot write the job's results; waiting and retrying");
                    logged.push(message.clone());
                }
                status.waiting(job, frame, &message, retry, wait);
                if !sleep_unless_stopping(shared, wait) {
                    return Err(JobError::Stopped);
                }
            }
        }
    }
}

/// The wait before retry `n` (1-based): the minimum, doubled each time, capped at the maximum.
fn backoff(shared: &Shared, n: u32) -> Duration {
    let c = &shared.config;
    let factor = 1u32 << (n - 1).min(20);
    c.spool_retry_min
        .saturating_mul(factor)
        .min(c.spool_retry_max)
}

/// Sleeps `wait`, waking early (false) if the daemon stops.
fn sleep_unless_stopping(shared: &Shared, wait: Duration) -> bool {
    let until = Instant::now() + wait;
    loop {
        if shared.stopping() {
            return false;
        }
        let left = until.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return true;
        }
        std::thread::sleep(left.min(Duration::from_millis(50)));
    }
}
