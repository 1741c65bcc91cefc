//! Who gets a session: the cap on sessions, and a separate cap on TCP connections still in their
//! handshake, which therefore never hold a session slot.

use std::io::Write;
use std::net::IpAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use antumbra_protocol::{encode_message, ErrorCode, Reply};

use crate::listen::Conn;
use crate::lock;
use crate::shared::{bump, Shared};
use crate::throttle::{Burst, LOG_WINDOW};

/// The counters of the TCP connections in their handshake.
#[derive(Default)]
pub(crate) struct Gate {
    pending: AtomicU64,
    /// Connections closed because the pending cap was reached, to log once per burst.
    refused: Mutex<Burst>,
}

/// What a connection holds: a session slot, or a place among the TCP handshakes under way.
pub(crate) enum Admission {
    /// Held for its `Drop`, which frees the slot.
    Session(#[allow(dead_code)] SessionSlot),
    Pending(PendingSlot),
}

/// A session slot (counted in `sessions_live`), freed on drop.
pub(crate) struct SessionSlot {
    shared: Arc<Shared>,
}

/// A TCP connection that has not yet said a valid `Hello`, freed from the cap on drop.
pub(crate) struct PendingSlot {
    shared: Arc<Shared>,
    pub ip: IpAddr,
    pub accepted: Instant,
}

impl Drop for SessionSlot {
    fn drop(&mut self) {
        let live = &self.shared.counters.sessions_live;
        live.fetch_sub(1, Ordering::Relaxed);
    }
}

impl Drop for PendingSlot {
    fn drop(&mut self) {
        self.shared.gate.pending.fetch_sub(1, Ordering::Relaxed);
    }
}

/// Adds one to `counter` unless it has reached `max`.
fn take(counter: &AtomicU64, max: u64) -> bool {
    counter
        .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |n| {
            (n < max).then_some(n + 1)
        })
        .is_ok()
}

/// A session slot, or `None` when `max_sessions` are served already.
pub(crate) fn admit_session(shared: &Arc<Shared>) -> Option<SessionSlot> {
    if !take(&shared.counters.sessions_live, shared.config.max_sessions) {
        return None;
    }
    bump(&shared.counters.sessions_total);
    Some(SessionSlot {
        shared: shared.clone(),
    })
}

/// A place for a TCP handshake from `ip`, or `None` when `max_pending_handshakes` are under way.
pub(crate) fn admit_pending(shared: &Arc<Shared>, ip: IpAddr, now: Instant) -> Option<PendingSlot> {
    let max = shared.config.max_pending_handshakes as u64;
    if !take(&shared.gate.pending, max) {
        return None;
    }
    Some(PendingSlot {
        shared: shared.clone(),
        ip,
        accepted: now,
    })
}

/// Answers a connection the daemon will not serve, without waiting on the peer, and closes it.
pub(crate) fn turn_away(mut conn: Conn, code: ErrorCode, message: String) {
    let reply = Reply::Error {
        code,
        message,
        session_usable: false,
        request_id: None,
    };
    // A few hundred bytes fit any fresh socket's buffer; a peer that cannot take them is dropped.
    let _ = conn.set_nonblocking(true);
    if let Ok(bytes) = encode_message(&reply) {
        let _ = conn.write_all(&bytes);
    }
}

impl Gate {
    /// Logs a connection closed at the pending cap: the first of a burst at once, the rest
    /// summed up by [`Gate::flush`].
    pub fn refused_pending(&self, ip: IpAddr, max: usize, now: Instant) {
        if lock(&self.refused).record(now) {
            tracing::warn!(
                peer = %ip,
                max,
                "tcp connection refused: {max} connections are already in their handshake \
                 (--max-pending-handshakes); further refusals are summed up every {} s",
                LOG_WINDOW.as_secs()
            );
        }
    }

    /// Logs the sum of the refusals once their window is over (or now with `force`).
    pub fn flush(&self, now: Instant, force: bool) {
        if let Some((n, span)) = lock(&self.refused).due(now, force, false) {
            tracing::warn!(
                refused = n,
                "{n} more tcp connections refused in the last {:.0} s: too many connections \
                 in their handshake (--max-pending-handshakes)",
                span.as_secs_f64()
            );
        }
    }
}
