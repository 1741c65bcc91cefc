//! Errors of the client, and their Python exceptions (defined in `antumbra/errors.py`, so the
//! Python package owns the hierarchy and both sessions raise the same classes).

use antumbra_protocol::{ErrorCode, Reply};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Everything that can go wrong in a client call.
#[derive(Debug)]
pub enum ClientError {
    /// An argument the client refuses before anything is sent: wrong type, shape, dtype or value.
    Invalid(String),
    /// A request refused (or a render failed) with an error code: from the daemon (`daemon`),
    /// or from the in-process session, which applies the daemon's checks.
    Request {
        code: ErrorCode,
        message: String,
        session_usable: bool,
        request_id: Option<u64>,
        daemon: bool,
    },
    /// No daemon accepts connections at the path.
    Unavailable(String),
    /// The connection broke (closed by the daemon, i/o error) or was closed by this client.
    Lost(String),
    /// The daemon did not answer in time.
    Timeout(String),
    /// The daemon speaks another protocol version, or sent something this client cannot read.
    Mismatch(String),
    /// Another thread is using this session.
    Busy(String),
    /// A Python exception to pass through (KeyboardInterrupt, a progress callback's error).
    Py(PyErr),
}

pub type ClientResult<T> = Result<T, ClientError>;

impl From<PyErr> for ClientError {
    fn from(e: PyErr) -> Self {
        ClientError::Py(e)
    }
}

/// The wire name of an error code (`"InvalidInput"`, `"UnknownMesh"`, ...).
pub fn code_name(code: ErrorCode) -> String {
    format!("{code:?}")
}

impl ClientError {
    pub fn invalid(message: impl Into<String>) -> Self {
        ClientError::Invalid(message.into())
    }

    /// The error reply of the in-process session: the daemon's error, raised as a
    /// `RequestError` that is no `DaemonError`.
    pub fn local(reply: Reply) -> Self {
        match reply {
            Reply::Error {
                code,
                message,
                session_usable,
                request_id,
            } => ClientError::Request {
                code,
                message,
                session_usable,
                request_id,
                daemon: false,
            },
            other => ClientError::Request {
                code: ErrorCode::Internal,
                message: format!("the session answered {}", other.kind()),
                session_usable: true,
                request_id: None,
                daemon: false,
            },
        }
    }

    pub fn into_py(self, py: Python<'_>) -> PyErr {
        let (class, message, extra) = match self {
            ClientError::Py(e) => return e,
            ClientError::Invalid(m) => ("InvalidInput", m, None),
            ClientError::Unavailable(m) => ("DaemonUnavailable", m, None),
            ClientError::Lost(m) => ("ConnectionLost", m, None),
            ClientError::Timeout(m) => ("DaemonTimeout", m, None),
            ClientError::Mismatch(m) => ("ProtocolMismatch", m, None),
            ClientError::Busy(m) => ("SessionBusy", m, None),
            ClientError::Request {
                code,
                message,
                session_usable,
                request_id,
                daemon,
            } => (
                if daemon {
                    "DaemonError"
                } else {
                    "RequestError"
                },
                message,
                Some((code_name(code), session_usable, request_id)),
            ),
        };
        match raise(py, class, &message, extra) {
            Ok(e) | Err(e) => e,
        }
    }
}

/// The package this module was imported into (`antumbra`, or the alias the Blender add-on
/// loads it under), recorded when the module initialises; its `errors` module has the classes.
static PACKAGE: std::sync::OnceLock<String> = std::sync::OnceLock::new();

pub fn set_package(module_name: &str) {
    let package = module_name
        .rsplit_once('.')
        .map_or("antumbra", |(package, _)| package);
    let _ = PACKAGE.set(package.to_string());
}

fn raise(
    py: Python<'_>,
    class: &str,
    message: &str,
    extra: Option<(String, bool, Option<u64>)>,
) -> PyResult<PyErr> {
    let package = PACKAGE.get().map_or("antumbra", String::as_str);
    let module = py.import(format!("{package}.errors")).map_err(|e| {
        PyRuntimeError::new_err(format!(
            "antumbra._native cannot import {package}.errors ({e}); original error: {message}"
        ))
    })?;
    let cls = module.getattr(class)?;
    let value = match extra {
        None => cls.call1((message,))?,
        Some((code, session_usable, request_id)) => {
            let kwargs = PyDict::new(py);
            kwargs.set_item("code", code)?;
            kwargs.set_item("session_usable", session_usable)?;
            kwargs.set_item("request_id", request_id)?;
            cls.call((message,), Some(&kwargs))?
        }
    };
    Ok(PyErr::from_value(value))
}

/// Converts a client result into a Python result.
pub trait IntoPyResult<T> {
    fn py_result(self, py: Python<'_>) -> PyResult<T>;
}

impl<T> IntoPyResult<T> for ClientResult<T> {
    fn py_result(self, py: Python<'_>) -> PyResult<T> {
        self.map_err(|e| e.into_py(py))
    }
}
