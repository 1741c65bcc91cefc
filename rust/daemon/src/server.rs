//! The daemon's front door: binding the sockets, the accept loop that starts a session per
//! connection, and the orderly stop.

use std::net::{IpAddr, Shutdown, SocketAddr, TcpListener};
use std::os::fd::AsRawFd;
use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use antumbra_protocol::{DaemonStats, ErrorCode};

use crate::config::DaemonConfig;
use crate::error::DaemonError;
use crate::gate::{self, Admission};
use crate::listen::{bind_tcp, bind_unix, BoundUnix, Conn};
use crate::shared::Shared;
use crate::{lock, session, spool};

/// A daemon whose sockets are bound; [`run`](Daemon::run) serves until it is stopped.
pub struct Daemon {
    shared: Arc<Shared>,
    unix: BoundUnix,
    tcp: Option<(TcpListener, SocketAddr)>,
    /// Held for the daemon's life: one daemon per spool folder.
    spool_lock: Option<spool::SpoolLock>,
}

/// Stops a running daemon and reads its statistics from another thread.
#[derive(Clone)]
pub struct DaemonHandle {
    shared: Arc<Shared>,
}

impl DaemonHandle {
    /// Asks the daemon to stop: it stops accepting, lets sessions finish their current request
    /// (up to the configured grace period) and returns from [`Daemon::run`].
    pub fn stop(&self) {
        self.shared.request_stop();
    }

    pub fn stats(&self) -> DaemonStats {
        self.shared.daemon_stats()
    }
}

impl Daemon {
    /// Binds the sockets (see [`crate::listen::bind_unix`]) and prepares the spool folder; any
    /// problem is reported here, before the daemon says it is listening.
    pub fn bind(config: DaemonConfig) -> Result<Daemon, DaemonError> {
        let has_token = matches!(config.token.as_deref(), Some(t) if !t.is_empty());
        if config.tcp.is_some() && !has_token {
            return Err(DaemonError::MissingToken);
        }
        if config.max_renders == 0 {
            return Err(DaemonError::Config(
                "--max-renders must be at least 1".into(),
            ));
        }
        if config.max_sessions == 0 || config.max_pending_handshakes == 0 {
            return Err(DaemonError::Config(
                "--max-sessions and --max-pending-handshakes must be at least 1".into(),
            ));
        }
        if config.handshake_timeout.is_zero() {
            return Err(DaemonError::Config(
                "--handshake-timeout-s must be more than 0".into(),
            ));
        }
        // A Hello carries the token, the client's name and a few field names.
        let token_len = config.token.as_ref().map_or(0, |t| t.len() as u64);
        if token_len + 1024 > config.handshake_max_frame_bytes {
            return Err(DaemonError::Config(format!(
                "handshake_max_frame_bytes ({}) leaves no room for a Hello with the {token_len}-byte \
                 token; use a shorter token or a larger limit",
                config.handshake_max_frame_bytes
            )));
        }
        if let Some(dir) = &config.record {
            std::fs::create_dir_all(dir)
                .map_err(|e| DaemonError::path(dir, format!("cannot create: {e}")))?;
        }
        let spool_lock = config.spool.as_deref().map(spool::prepare).transpose()?;
        // TCP first: an address error then leaves no socket file behind.
        let tcp = match config.tcp {
            Some(addr) => {
                let l = bind_tcp(addr)?;
                let local = l
                    .local_addr()
                    .map_err(|e| DaemonError::io("tcp socket", e))?;
                Some((l, local))
            }
            None => None,
        };
        let unix = bind_unix(&config.socket)?;
        let shared = Arc::new(Shared::new(config));
        Ok(Daemon {
            shared,
            unix,
            tcp,
            spool_lock,
        })
    }

    pub fn socket_path(&self) -> &Path {
        &self.unix.path
    }

    /// The TCP address actually bound (with the port the system chose for port 0).
    pub fn tcp_addr(&self) -> Option<SocketAddr> {
        self.tcp.as_ref().map(|(_, a)| *a)
    }

    /// What the daemon listens on: `unix:PATH` and, with TCP, `tcp:ADDR`.
    pub fn endpoints(&self) -> Vec<String> {
        let mut v = vec![format!("unix:{}", self.unix.path.display())];
        if let Some(a) = self.tcp_addr() {
            v.push(format!("tcp:{a}"));
        }
        v
    }

    /// The line `antumbra serve` prints on stdout when it is ready.
    pub fn ready_line(&self) -> String {
        format!("antumbra: listening on {}", self.endpoints().join(" "))
    }

    pub fn handle(&self) -> DaemonHandle {
        DaemonHandle {
            shared: self.shared.clone(),
        }
    }

    /// SIGTERM and SIGINT stop the daemon as `Shutdown` does; a second one exits at once.
    pub fn stop_on_signals(&self) -> Result<(), DaemonError> {
        use signal_hook::consts::{SIGINT, SIGTERM};
        for sig in [SIGTERM, SIGINT] {
            signal_hook::flag::register_conditional_shutdown(sig, 1, self.shared.stop.clone())
                .map_err(|e| DaemonError::io("installing signal handlers", e))?;
            signal_hook::flag::register(sig, self.shared.stop.clone())
                .map_err(|e| DaemonError::io("installing signal handlers", e))?;
        }
        Ok(())
    }

    /// Serves until stopped, then lets sessions finish their current request (within the grace
    /// period), removes the socket file and returns.
    pub fn run(self) -> Result<(), DaemonError> {
        let shared = self.shared.clone();
        tracing::info!(
            endpoints = %self.endpoints().join(" "),
            max_renders = shared.config.max_renders,
            memory_budget_mb = shared.config.memory_budget >> 20,
            spool = shared.config.spool.as_ref().map(|p| p.display().to_string()),
            record = shared.config.record.as_ref().map(|p| p.display().to_string()),
            "daemon started"
        );
        let spool_thread = shared.config.spool.clone().map(|dir| {
            let shared = shared.clone();
            std::thread::Builder::new()
                .name("spool".into())
                .spawn(move || spool::run(shared, dir))
                .expect("spawning the spool thread")
        });
        let mut sessions: Vec<JoinHandle<()>> = Vec::new();
        let mut next_id = 1u64;
        let result = self.accept_loop(&mut sessions, &mut next_id);
        tracing::info!(
            live_sessions = shared.counters.sessions_live.load(Ordering::Relaxed),
            "stopping: no new connections"
        );
        shared.request_stop();
        self.unix.remove_file();
        let Daemon {
            unix,
            tcp,
            spool_lock,
            ..
        } = self;
        drop(unix);
        drop(tcp);
        // Wake every session's reader: each finishes the request it is on and ends.
        for conn in lock(&shared.sessions).values() {
            let _ = conn.shutdown(Shutdown::Read);
        }
        let deadline = Instant::now() + shared.config.shutdown_grace;
        let mut threads: Vec<JoinHandle<()>> = sessions;
        threads.extend(spool_thread);
        while Instant::now() < deadline && threads.iter().any(|t| !t.is_finished()) {
            std::thread::sleep(Duration::from_millis(20));
        }
        let (done, left): (Vec<_>, Vec<_>) = threads.into_iter().partition(|t| t.is_finished());
        for t in done {
            let _ = t.join();
        }
        if !left.is_empty() {
            tracing::warn!(
                threads = left.len(),
                grace_s = shared.config.shutdown_grace.as_secs_f64(),
                "sessions still busy after the grace period; leaving them"
            );
        }
        // What the burst logs still hold.
        let now = Instant::now();
        shared.gate.flush(now, true);
        shared.throttle.flush(now, true);
        drop(spool_lock);
        tracing::info!(stats = ?shared.daemon_stats(), "daemon stopped");
        result
    }

    fn accept_loop(
        &self,
        sessions: &mut Vec<JoinHandle<()>>,
        next_id: &mut u64,
    ) -> Result<(), DaemonError> {
        let shared = &self.shared;
        let mut fds = vec![libc::pollfd {
            fd: self.unix.listener.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        }];
        if let Some((l, _)) = &self.tcp {
            fds.push(libc::pollfd {
                fd: l.as_raw_fd(),
                events: libc::POLLIN,
                revents: 0,
            });
        }
        while !shared.stopping() {
            for p in fds.iter_mut() {
                p.revents = 0;
            }
            // SAFETY: `fds` is a valid array of pollfd for its whole length, and the listeners
            // whose descriptors it holds outlive the call.
            let n = unsafe { libc::poll(fds.as_mut_ptr(), fds.len() as libc::nfds_t, 100) };
            if n < 0 {
                let e = std::io::Error::last_os_error();
                if e.kind() == std::io::ErrorKind::Interrupted {
                    continue;
                }
                return Err(DaemonError::io("poll", e));
            }
            // Joined, an ended session's thread has also freed its thread-local memory: give
            // what it held back to the system.
            let (ended, live): (Vec<_>, Vec<_>) = sessions.drain(..).partition(|t| t.is_finished());
            *sessions = live;
            if !ended.is_empty() {
                for t in ended {
                    let _ = t.join();
                }
                (shared.config.release_memory)();
            }
            let now = Instant::now();
            shared.gate.flush(now, false);
            shared.throttle.flush(now, false);
            if n == 0 {
                continue;
            }
            loop {
                match self.unix.listener.accept() {
                    Ok((s, _)) => self.spawn_session(Conn::Unix(s), None, sessions, next_id),
                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
                    Err(e) => {
                        tracing::warn!(error = %e, "accept failed on the unix socket");
                        break;
                    }
                }
            }
            if let Some((l, _)) = &self.tcp {
                loop {
                    match l.accept() {
                        Ok((s, addr)) => {
                            let _ = s.set_nodelay(true);
                            self.spawn_session(Conn::Tcp(s), Some(addr.ip()), sessions, next_id)
                        }
                        Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
                        Err(e) => {
                            tracing::warn!(error = %e, "accept failed on the tcp socket");
                            break;
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// Admits a connection: a Unix one takes a session slot at once; a TCP one from `ip` is
    /// turned away while its address must wait after failed tokens, or when too many TCP
    /// connections are in their handshake, and takes a session slot only after its `Hello`.
    fn admit(&self, conn: Conn, ip: Option<IpAddr>) -> Option<(Conn, Admission)> {
        let shared = &self.shared;
        let Some(ip) = ip else {
            return match gate::admit_session(shared) {
                Some(slot) => Some((conn, Admission::Session(slot))),
                None => {
                    let max = shared.config.max_sessions;
                    tracing::warn!(max, peer = %conn.peer(), "too many sessions; refusing");
                    let why = format!("the daemon already serves {max} sessions");
                    gate::turn_away(conn, ErrorCode::Busy, why);
                    None
                }
            };
        };
        let now = Instant::now();
        if let Err(wait) = shared.throttle.check(ip, now) {
            let why = format!(
                "authentication failed: too many failed token attempts from {ip}; try again in \
                 {:.1} s",
                wait.as_secs_f64()
            );
            gate::turn_away(conn, ErrorCode::InvalidInput, why);
            return None;
        }
        match gate::admit_pending(shared, ip, now) {
            Some(pending) => Some((conn, Admission::Pending(pending))),
            None => {
                let max = shared.config.max_pending_handshakes;
                shared.gate.refused_pending(ip, max, now);
                let why = format!(
                    "the daemon already has {max} TCP connections in their handshake; try again \
                     later"
                );
                gate::turn_away(conn, ErrorCode::Busy, why);
                None
            }
        }
    }

    fn spawn_session(
        &self,
        conn: Conn,
        ip: Option<IpAddr>,
        sessions: &mut Vec<JoinHandle<()>>,
        next_id: &mut u64,
    ) {
        let Some((conn, admission)) = self.admit(conn, ip) else {
            return;
        };
        let shared = self.shared.clone();
        let id = *next_id;
        *next_id += 1;
        let setup = conn
            .set_nonblocking(false)
            .and_then(|()| conn.set_write_timeout(Some(shared.config.write_timeout)))
            .and_then(|()| conn.try_clone());
        let waker = match setup {
            Ok(w) => w,
            Err(e) => {
                tracing::warn!(error = %e, "cannot set up a connection; dropping it");
                return;
            }
        };
        lock(&shared.sessions).insert(id, waker);
        let spawned = std::thread::Builder::new()
            .name(format!("session-{id}"))
            .spawn({
                let shared = shared.clone();
                move || {
                    // session::run catches panics per request; this is the last line of defence
                    // so that the bookkeeping below always runs (the admission is freed when
                    // dropped, also while unwinding).
                    let run =
                        std::panic::AssertUnwindSafe(|| session::run(&shared, conn, id, admission));
                    let admission = std::panic::catch_unwind(run);
                    if admission.is_err() {
                        tracing::error!(session = id, "session thread panicked");
                    }
                    drop(admission);
                    // Meshes this session held may now be evictable.
                    shared.cache.trim();
                    (shared.config.release_memory)();
                    // Counted as ended only once what it held has been given back.
                    lock(&shared.sessions).remove(&id);
                }
            });
        match spawned {
            Ok(t) => sessions.push(t),
            Err(e) => {
                tracing::error!(error = %e, "cannot start a session thread");
                lock(&shared.sessions).remove(&id);
            }
        }
    }
}
