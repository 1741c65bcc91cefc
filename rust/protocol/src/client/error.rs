//! What can go wrong in a client call; the messages are the ones the Python binding raises.

use std::io;
use std::time::Duration;

use thiserror::Error;

use crate::{ErrorCode, FrameError, ProtocolError, Reply, PROTOCOL_VERSION};

#[derive(Debug, Error)]
pub enum ClientError {
    /// The request cannot be encoded (too large, say); nothing was sent.
    #[error("{kind}: {error}")]
    Encode {
        kind: &'static str,
        error: FrameError,
    },
    #[error("the daemon did not take the {kind} request within {waited:?}")]
    SendTimeout {
        kind: &'static str,
        waited: Duration,
    },
    #[error("connection to the daemon broken while sending {kind}: {error}")]
    Send {
        kind: &'static str,
        error: io::Error,
    },
    /// The stream ended or broke, or a reply did not decode.
    #[error("{}", read_message(waiting_for, error))]
    Read {
        waiting_for: String,
        error: FrameError,
    },
    #[error("the daemon did not answer {waiting_for} within {:.1} s", waited.as_secs_f64())]
    Timeout {
        waiting_for: String,
        waited: Duration,
    },
    /// The caller's [`Wait`](super::Wait) or progress callback stopped the wait (Ctrl-C, an
    /// exception); the caller holds the reason.
    #[error("interrupted while waiting for {waiting_for}")]
    Interrupted { waiting_for: String },
    /// The daemon answered with an `Error`.
    #[error("daemon replied {code:?}: {message}")]
    Daemon {
        code: ErrorCode,
        message: String,
        session_usable: bool,
        request_id: Option<u64>,
    },
    #[error("the daemon answered {request} with {reply}, which this client does not expect")]
    Unexpected { request: String, reply: String },
    #[error(
        "the daemon speaks protocol version {daemon}, this client version {PROTOCOL_VERSION}; use \
         matching versions of antumbra and the antumbra Python package"
    )]
    Version { daemon: u32 },
    /// The daemon's answer contradicts the request (another mesh hash, meshes still missing).
    #[error("{0}")]
    Mismatch(String),
    /// An earlier failure left the stream out of step.
    #[error("this session can no longer be used ({0}); connect again")]
    Broken(String),
    #[error("the client is closed")]
    Closed,
    #[error(transparent)]
    Protocol(#[from] ProtocolError),
    #[error(transparent)]
    Io(#[from] io::Error),
}

fn read_message(waiting_for: &str, error: &FrameError) -> String {
    match error {
        FrameError::Closed => {
            format!("the daemon closed the connection while this client waited for {waiting_for}")
        }
        FrameError::Decode(e) => format!(
            "cannot read the daemon's reply to {waiting_for}: {e} (is the daemon the same \
             antumbra version as this client?)"
        ),
        FrameError::Io(e) => {
            format!("connection to the daemon broken while waiting for {waiting_for}: {e}")
        }
        e => format!("connection to the daemon broken while waiting for {waiting_for}: {e}"),
    }
}

impl ClientError {
    /// An `Error` reply as [`ClientError::Daemon`]; any other reply as unexpected for `request`.
    pub fn from_reply(request: &str, reply: Reply) -> Self {
        match reply {
            Reply::Error {
                code,
                message,
                session_usable,
                request_id,
            } => ClientError::Daemon {
                code,
                message,
                session_usable,
                request_id,
            },
            other => ClientError::Unexpected {
                request: request.into(),
                reply: other.kind().into(),
            },
        }
    }

    /// The error code when the daemon answered with an error.
    pub fn code(&self) -> Option<ErrorCode> {
        match self {
            ClientError::Daemon { code, .. } => Some(*code),
            _ => None,
        }
    }
}
