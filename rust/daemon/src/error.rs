//! Errors that stop a daemon from starting (errors of one request are protocol replies).

use std::path::{Path, PathBuf};

use thiserror::Error;

#[derive(Debug, Error)]
pub enum DaemonError {
    #[error("another antumbra daemon is already listening on {}", path.display())]
    AlreadyRunning { path: PathBuf },
    #[error("{} exists and is not a socket; refusing to replace it", path.display())]
    NotASocket { path: PathBuf },
    #[error("{}: {message}", path.display())]
    Path { path: PathBuf, message: String },
    #[error("refusing to listen on {addr}: only loopback addresses (127.0.0.0/8, ::1) are allowed for TCP")]
    NotLoopback { addr: String },
    #[error("--tcp needs a token: pass --token-file with a non-empty secret")]
    MissingToken,
    #[error("{0}")]
    Config(String),
    #[error("{context}: {source}")]
    Io {
        context: String,
        source: std::io::Error,
    },
}

impl DaemonError {
    pub(crate) fn io(context: impl Into<String>, source: std::io::Error) -> Self {
        DaemonError::Io {
            context: context.into(),
            source,
        }
    }

    pub(crate) fn path(path: &Path, message: impl Into<String>) -> Self {
        DaemonError::Path {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
}
