//! Opening a socket session: connect, Hello, and the errors that say how to start a daemon.

use std::collections::HashSet;
use std::io::ErrorKind;
use std::path::Path;
use std::sync::atomic::AtomicU64;
use std::sync::Mutex;
use std::time::Duration;

use antumbra_protocol::client::{self, Client};
use antumbra_protocol::{ErrorCode, PROTOCOL_VERSION};
use pyo3::prelude::*;

use super::wait::PyWait;
use super::{Connection, State};
use crate::error::{ClientError, ClientResult};

pub(super) fn duration(seconds: Option<f64>, what: &str) -> ClientResult<Option<Duration>> {
    match seconds {
        None => Ok(None),
        Some(s) if s.is_finite() && s > 0.0 => Ok(Some(Duration::from_secs_f64(s))),
        Some(s) => Err(ClientError::invalid(format!(
            "{what}: expected a positive number of seconds or None, got {s}"
        ))),
    }
}

fn unavailable(path: &str, e: &std::io::Error) -> ClientError {
    let how = format!(
        "start one with `antumbra serve --socket {path}`, or let antumbra.Client.spawn() start \
         one for this session"
    );
    match e.kind() {
        ErrorKind::NotFound | ErrorKind::ConnectionRefused => ClientError::Unavailable(format!(
            "no antumbra daemon is listening at {path} ({e}); {how}"
        )),
        ErrorKind::PermissionDenied => ClientError::Unavailable(format!(
            "cannot connect to the antumbra daemon at {path}: permission denied (the socket \
             belongs to another user?)"
        )),
        _ => ClientError::Unavailable(format!(
            "cannot connect to the antumbra daemon at {path}: {e}; {how}"
        )),
    }
}

impl Connection {
    pub(super) fn connect(
        py: Python<'_>,
        socket_path: String,
        timeout: Option<f64>,
        client_name: String,
        token: Option<String>,
    ) -> ClientResult<Self> {
        let timeout = duration(timeout, "timeout")?;
        let mut client = py
            .detach(|| Client::connect_unix(Path::new(&socket_path)))
            .map_err(|e| unavailable(&socket_path, &e))?;
        client
            .set_timeout(timeout)
            .map_err(|e| ClientError::Lost(format!("cannot use the socket: {e}")))?;
        let mut wait = PyWait::new(py);
        let hello = client.handshake(&mut wait, &client_name, token.as_deref());
        hello.map_err(|e| match e {
            client::ClientError::Version { daemon } => ClientError::Mismatch(format!(
                "the daemon at {socket_path} speaks protocol version {daemon}, this client \
                 version {PROTOCOL_VERSION}; use matching versions of antumbra and the antumbra \
                 Python package"
            )),
            client::ClientError::Daemon {
                code: ErrorCode::VersionMismatch,
                message,
                ..
            } => ClientError::Mismatch(message),
            client::ClientError::Unexpected { reply, .. } => ClientError::Mismatch(format!(
                "the daemon at {socket_path} answered Hello with {reply} instead of Welcome (is \
                 it an antumbra daemon?)"
            )),
            e => wait.error(e),
        })?;
        Ok(Connection {
            server: client.server().to_string(),
            limits: client.limits().clone(),
            sender: client.sender(),
            socket_path,
            timeout,
            state: Mutex::new(Some(State {
                client,
                known: HashSet::new(),
                known_images: HashSet::new(),
                recorder: None,
            })),
            active_render: AtomicU64::new(0),
            next_id: AtomicU64::new(1),
        })
    }
}
