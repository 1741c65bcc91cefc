//! The antumbra daemon: a long-lived process that Blender (through the Python client) talks to
//! over a local socket with the protocol of `antumbra-protocol`, and that renders batch jobs
//! dropped into a spool folder.
//!
//! - [`Daemon::bind`] opens the Unix socket (and an optional loopback TCP port guarded by a
//!   token), [`Daemon::run`] accepts connections until stopped: each connection is a session on
//!   its own thread, serving one `antumbra_session` session (its own renderer, BVH reuse across
//!   frames), sharing one mesh cache (`antumbra_session::MeshCache`) and a bound on concurrent
//!   renders ([`slots`]).
//! - [`spool`] renders jobs from a folder, writing each frame's results atomically, so a killed
//!   daemon resumes without losing or duplicating frames.
//! - The client of the protocol is `antumbra_protocol::client` (the Python binding, tests,
//!   tools).
//!
//! See `docs/daemon.md` for the behaviour, the spool layout and the operational details.

#![cfg(unix)]

pub mod config;
pub mod error;
mod gate;
pub mod listen;
pub mod logging;
pub mod memory;
mod server;
mod session;
mod shared;
pub mod slots;
pub mod spool;
mod throttle;

use std::sync::{Mutex, MutexGuard};

pub use config::DaemonConfig;
pub use error::DaemonError;
pub use listen::default_socket_path;
pub use logging::{init_logging, LogFormat};
pub use server::{Daemon, DaemonHandle};

/// Locks a mutex, recovering the data if a thread panicked while holding it: every structure the
/// daemon locks stays consistent between statements, and one failed request must not take the
/// daemon down with a poisoned lock.
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}
