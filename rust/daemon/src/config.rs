//! What a daemon is started with.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use antumbra_protocol::Limits;

/// Everything `antumbra serve` can set; [`DaemonConfig::new`] gives the defaults for a socket.
#[derive(Clone, Debug)]
pub struct DaemonConfig {
    /// The Unix domain socket to listen on (see [`crate::listen::default_socket_path`]).
    pub socket: PathBuf,
    /// An optional TCP listener; only loopback addresses are accepted.
    pub tcp: Option<SocketAddr>,
    /// The secret a TCP client must send in `Hello.token` (required with `tcp`).
    pub token: Option<String>,
    /// A spool folder for batch jobs (see `docs/daemon.md`).
    pub spool: Option<PathBuf>,
    /// Record each session's requests to `<record>/<session>.antrec`.
    pub record: Option<PathBuf>,
    /// Renders that may run at once, over all sessions and the spool; more wait in a queue.
    pub max_renders: usize,
    /// How long a render may wait in the queue for a render slot; past it the request is
    /// answered `Busy` with its place in the queue and the time waited.
    pub queue_wait: Duration,
    /// Bytes of mesh data the shared cache keeps; meshes that no live session uses are evicted,
    /// least recently used first, to stay below it.
    pub memory_budget: u64,
    /// Sizes and counts one request may have; sent to clients in `Welcome`.
    pub limits: Limits,
    /// How long a stopping daemon waits for sessions to finish their current request.
    pub shutdown_grace: Duration,
    /// How often the spool folder is rescanned when no file-system event arrived.
    pub spool_rescan: Duration,
    /// A write to a client that blocks longer than this ends the session.
    pub write_timeout: Duration,
    /// The name sent in `Welcome`.
    pub server_name: String,
}

impl DaemonConfig {
    pub fn new(socket: impl Into<PathBuf>) -> Self {
        DaemonConfig {
            socket: socket.into(),
            tcp: None,
            token: None,
            spool: None,
            record: None,
            max_renders: 2,
            queue_wait: Duration::from_secs(300),
            memory_budget: 4096 << 20,
            limits: Limits::default(),
            shutdown_grace: Duration::from_secs(10),
            spool_rescan: Duration::from_secs(2),
            write_timeout: Duration::from_secs(120),
            server_name: format!("antumbra-daemon {}", env!("CARGO_PKG_VERSION")),
        }
    }
}
