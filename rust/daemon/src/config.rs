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
    /// Starts of one spool frame without it finishing (the daemon died rendering it) after
    /// which its job ends in ERROR, so a frame that kills the daemon cannot crash-loop it.
    pub spool_max_attempts: u32,
    /// First wait before retrying a failed write of spool results; doubles each retry ...
    pub spool_retry_min: Duration,
    /// ... up to this.
    pub spool_retry_max: Duration,
    /// A write to a client that blocks longer than this ends the session.
    pub write_timeout: Duration,
    /// The name sent in `Welcome`.
    pub server_name: String,
    /// Sessions served at once: Unix connections, and TCP connections once their `Hello` is
    /// accepted; more are answered `Busy` and closed.
    pub max_sessions: u64,
    /// The largest frame read before a `Hello` is accepted (a `Hello` is a few hundred bytes);
    /// a larger one is refused from its length prefix and the connection closed.
    pub handshake_max_frame_bytes: u64,
    /// How long a TCP client has, from its connection to a valid `Hello`, for all its reads.
    pub handshake_timeout: Duration,
    /// TCP connections that may be in their handshake at once; more are closed at once. They
    /// never hold a session slot, so they cannot keep Unix clients out.
    pub max_pending_handshakes: usize,
    /// Failed TCP handshakes (wrong or missing token, ...) one IP address may make before it
    /// has to wait.
    pub auth_failures_allowed: u32,
    /// The first wait after `auth_failures_allowed` failures; each further failure doubles it.
    pub auth_backoff: Duration,
    /// The longest wait; an address with no failure for this long starts afresh.
    pub auth_backoff_max: Duration,
    /// Gives the allocator's free memory back to the system; called when sessions have ended.
    /// Default [`crate::memory::trim_system_allocator`] (glibc); `antumbra serve` sets mimalloc's.
    pub release_memory: fn(),
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
            spool_max_attempts: 3,
            spool_retry_min: Duration::from_secs(1),
            spool_retry_max: Duration::from_secs(60),
            write_timeout: Duration::from_secs(120),
            server_name: format!("antumbra-daemon {}", env!("CARGO_PKG_VERSION")),
            max_sessions: 256,
            handshake_max_frame_bytes: 64 << 10,
            handshake_timeout: Duration::from_secs(30),
            max_pending_handshakes: 16,
            auth_failures_allowed: 10,
            auth_backoff: Duration::from_secs(1),
            auth_backoff_max: Duration::from_secs(60),
            release_memory: crate::memory::trim_system_allocator,
        }
    }
}
