//! `antumbra serve`: the long-lived daemon Blender talks to (see `docs/daemon.md`).

use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

use antumbra_daemon::listen::{parse_tcp_addr, read_token_file};
use antumbra_daemon::{default_socket_path, init_logging, Daemon, DaemonConfig, LogFormat};
use anyhow::{bail, Result};
use clap::{Args, ValueEnum};

use crate::admission_args::AdmissionArgs;

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum LogFormatArg {
    Text,
    Json,
}

#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Unix socket to listen on [default: $XDG_RUNTIME_DIR/antumbra/daemon.sock, or
    /// /tmp/antumbra-$UID/daemon.sock].
    #[arg(long)]
    pub socket: Option<PathBuf>,
    /// Also listen on TCP at this loopback address (127.0.0.1:PORT, [::1]:PORT, localhost:PORT;
    /// port 0 picks a free one). Needs --token-file.
    #[arg(long, requires = "token_file")]
    pub tcp: Option<String>,
    /// File holding the secret TCP clients must send in Hello (surrounding whitespace trimmed).
    #[arg(long, requires = "tcp")]
    pub token_file: Option<PathBuf>,
    /// Spool folder for batch jobs (DIR/jobs/<id>/ in, DIR/results/<id>/ out).
    #[arg(long)]
    pub spool: Option<PathBuf>,
    /// Record every session's requests to DIR/session-<time>-<pid>-<n>.antrec (replay them with
    /// `antumbra render --scene FILE.antrec`).
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// Renders that run at once (over all sessions and the spool); more wait in a queue.
    #[arg(long, default_value_t = 2)]
    pub max_renders: usize,
    /// Seconds a render may wait for a render slot; past it the request is answered Busy with
    /// its place in the queue.
    #[arg(long, default_value_t = 300.0)]
    pub queue_wait_s: f64,
    /// Memory budget of the shared mesh cache in MiB (meshes no session uses are evicted).
    #[arg(long, default_value_t = 4096)]
    pub memory_budget_mb: u64,
    #[command(flatten)]
    pub admission: AdmissionArgs,
    /// Log format on stderr (level from RUST_LOG, default info).
    #[arg(long, value_enum, default_value = "text")]
    pub log_format: LogFormatArg,
    /// Seconds a stopping daemon waits for sessions to finish their current request.
    #[arg(long, default_value_t = 10.0)]
    pub shutdown_grace_s: f64,
    /// Seconds between rescans of the spool folder (file-system events wake it earlier).
    #[arg(long, default_value_t = 2.0)]
    pub spool_rescan_s: f64,
    /// Sessions served at once (Unix connections, and TCP ones after their Hello); more are
    /// answered Busy.
    #[arg(long, default_value_t = 256)]
    pub max_sessions: u64,
    /// Seconds a TCP client has from connecting to a valid Hello, for all its reads.
    #[arg(long, default_value_t = 30.0)]
    pub handshake_timeout_s: f64,
    /// TCP connections that may be in their handshake at once; more are closed at once. They
    /// never take a session slot.
    #[arg(long, default_value_t = 16)]
    pub max_pending_handshakes: usize,
    /// Starts of a spool frame that never finished (the daemon died rendering it: out of
    /// memory, a crash, or killed from outside, which it cannot tell apart) after which its job
    /// ends in ERROR and the spool goes on; `antumbra spool resume` continues such a job.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    pub spool_max_attempts: u32,
    /// Seconds before the first retry of a spool result that cannot be written (read-only
    /// folder, full disk); the wait doubles each retry.
    #[arg(long, default_value_t = 1.0)]
    pub spool_retry_min_s: f64,
    /// Longest wait between retries of a spool result that cannot be written.
    #[arg(long, default_value_t = 60.0)]
    pub spool_retry_max_s: f64,
}

/// Runs the daemon; `release_memory` gives the process allocator's free memory back to the
/// system when sessions end.
pub fn run(args: ServeArgs, release_memory: fn()) -> Result<()> {
    init_logging(match args.log_format {
        LogFormatArg::Text => LogFormat::Text,
        LogFormatArg::Json => LogFormat::Json,
    });
    for (name, v) in [
        ("--shutdown-grace-s", args.shutdown_grace_s),
        ("--spool-rescan-s", args.spool_rescan_s),
        ("--handshake-timeout-s", args.handshake_timeout_s),
        ("--spool-retry-min-s", args.spool_retry_min_s),
        ("--spool-retry-max-s", args.spool_retry_max_s),
        ("--queue-wait-s", args.queue_wait_s),
    ] {
        if !(v.is_finite() && v > 0.0 && v < 1e6) {
            bail!("{name}: must be a positive number of seconds, got {v}");
        }
    }
    if args.spool_retry_min_s > args.spool_retry_max_s {
        bail!(
            "--spool-retry-min-s ({}) must not exceed --spool-retry-max-s ({})",
            args.spool_retry_min_s,
            args.spool_retry_max_s
        );
    }
    let mut config = DaemonConfig::new(args.socket.unwrap_or_else(default_socket_path));
    if let Some(tcp) = &args.tcp {
        config.tcp = Some(parse_tcp_addr(tcp)?);
    }
    if let Some(path) = &args.token_file {
        config.token = Some(read_token_file(path)?);
    }
    config.spool = args.spool;
    config.record = args.record;
    config.max_renders = args.max_renders;
    config.queue_wait = Duration::from_secs_f64(args.queue_wait_s);
    config.memory_budget = args.memory_budget_mb.saturating_mul(1 << 20);
    config.limits = args.admission.limits();
    config.release_memory = release_memory;
    config.shutdown_grace = Duration::from_secs_f64(args.shutdown_grace_s);
    config.spool_rescan = Duration::from_secs_f64(args.spool_rescan_s);
    config.max_sessions = args.max_sessions;
    config.handshake_timeout = Duration::from_secs_f64(args.handshake_timeout_s);
    config.max_pending_handshakes = args.max_pending_handshakes;
    config.spool_max_attempts = args.spool_max_attempts;
    config.spool_retry_min = Duration::from_secs_f64(args.spool_retry_min_s);
    config.spool_retry_max = Duration::from_secs_f64(args.spool_retry_max_s);
    let daemon = Daemon::bind(config)?;
    daemon.stop_on_signals()?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "{}", daemon.ready_line())?;
    out.flush()?;
    drop(out);
    daemon.run()?;
    Ok(())
}
