//! Waiting for the daemon without the GIL: [`PyWait`] (Ctrl-C and progress callbacks between
//! slices, the client's errors as Python's) and the progress callback's checks.

use std::time::Duration;

use antumbra_protocol::client::{self, Interrupt, Wait};
use pyo3::prelude::*;
use pyo3::types::PyBool;

use crate::error::{ClientError, ClientResult};

/// Longest time spent without the GIL before checking for signals.
const POLL: Duration = Duration::from_millis(100);

/// Waiting with the GIL released, in slices of at most [`POLL`], checking for Ctrl-C (and so
/// running progress callbacks) between them.
pub(super) struct PyWait<'py> {
    py: Python<'py>,
    /// The first Python exception that stopped a wait (KeyboardInterrupt, a callback's error).
    pending: Option<PyErr>,
}

impl<'py> PyWait<'py> {
    pub(super) fn new(py: Python<'py>) -> Self {
        PyWait { py, pending: None }
    }

    fn keep(&mut self, e: PyErr) -> Interrupt {
        if self.pending.is_none() {
            self.pending = Some(e);
        }
        Interrupt
    }

    /// The client's error as the Python exception it raises.
    pub(super) fn error(&mut self, e: client::ClientError) -> ClientError {
        use client::ClientError as E;
        let message = e.to_string();
        match e {
            E::Interrupted { .. } => match self.pending.take() {
                Some(e) => ClientError::Py(e),
                None => ClientError::Lost(message),
            },
            E::Encode { .. } | E::Protocol(_) => ClientError::Invalid(message),
            E::SendTimeout { .. } | E::Timeout { .. } => ClientError::Timeout(message),
            E::Read {
                error: antumbra_protocol::FrameError::Decode(_),
                ..
            }
            | E::Unexpected { .. }
            | E::Version { .. }
            | E::Mismatch(_) => ClientError::Mismatch(message),
            E::Send { .. } | E::Read { .. } | E::Broken(_) | E::Closed | E::Io(_) => {
                ClientError::Lost(message)
            }
            E::Daemon {
                code,
                message,
                session_usable,
                request_id,
            } => ClientError::Request {
                code,
                message,
                session_usable,
                request_id,
                daemon: true,
            },
        }
    }
}

impl Wait for PyWait<'_> {
    fn slice(&self) -> Option<Duration> {
        Some(POLL)
    }

    fn block<T: Send>(&mut self, step: impl FnOnce() -> T + Send) -> T {
        self.py.detach(step)
    }

    fn between(&mut self) -> Result<(), Interrupt> {
        self.py.check_signals().map_err(|e| self.keep(e))
    }
}

/// A `progress` argument: a callable or None.
pub(crate) fn check_progress(progress: Option<&Bound<'_, PyAny>>) -> ClientResult<()> {
    match progress {
        Some(p) if !p.is_callable() => Err(ClientError::invalid(
            "progress: expected a callable progress(stage, done, total) or None",
        )),
        _ => Ok(()),
    }
}

/// Calls a render's or a comparison's progress callback: False from it cancels, an exception
/// cancels and is raised once the request has ended.
pub(super) fn call_progress(
    progress: Option<&Bound<'_, PyAny>>,
    wait: &mut PyWait<'_>,
    stage: &str,
    done: u32,
    total: u32,
) -> Result<bool, Interrupt> {
    let Some(cb) = progress else {
        return Ok(true);
    };
    let stop = cb
        .call1((stage, done, total))
        .and_then(|v| Ok(v.is_instance_of::<PyBool>() && !v.is_truthy()?));
    stop.map(|stop| !stop).map_err(|e| wait.keep(e))
}
