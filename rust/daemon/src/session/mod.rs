//! One client connection, from the handshake until the client closes, a frame error ends it or
//! the daemon stops; the session's state, its start and its end.

// The connection's thread reads requests (`connection`) and answers them through the session's
// `SessionState` (`dispatch`); its jobs run on a second thread (`worker`, with the session's
// `SessionRenderer`) so that `Cancel` and `Stats` are answered meanwhile; both reply through
// `out`, a whole frame at a time.
mod connection;
mod dispatch;
mod in_flight;
mod out;
mod recording;
mod worker;

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use antumbra_protocol::{RecordingWriter, Request};
use antumbra_session::SessionState;

use crate::gate::Admission;
use crate::listen::Conn;
use crate::lock;
use crate::shared::Shared;
use out::Out;
use worker::{Controls, Worker};

/// Why a session ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum End {
    /// Close, or Shutdown from this client.
    Closed,
    /// The client went away (end of stream, i/o error).
    Gone,
    /// A frame error left the stream unusable.
    BadFrame,
    /// Failed handshake.
    Refused,
    /// The daemon is stopping.
    Stopped,
    /// A request handler panicked.
    Internal,
}

enum Next {
    Request(Box<Request>),
    /// A body that did not decode was answered; read on.
    Skip,
    End(End),
}

enum Flow {
    Continue,
    End(End),
}

struct Session<'a> {
    shared: &'a Arc<Shared>,
    id: u64,
    tcp: bool,
    out: Arc<Out>,
    client: String,
    /// The meshes and frames the client sent, and the admission of its renders.
    state: SessionState,
    controls: Controls,
    worker: Option<Worker>,
    recorder: Option<RecordingWriter<BufWriter<File>>>,
    requests: u64,
    /// A session slot, or (a TCP connection before its `Hello`) a place among the handshakes.
    admission: Admission,
}

/// Serves one connection to its end; gives back what admitted it, to be freed by the caller.
pub(crate) fn run(shared: &Arc<Shared>, conn: Conn, id: u64, admission: Admission) -> Admission {
    let peer = conn.peer();
    let span = tracing::info_span!("session", id, peer = %peer);
    let _enter = span.enter();
    let (read_half, write_half) = match conn.try_clone() {
        Ok(w) => (conn, w),
        Err(e) => {
            tracing::warn!(error = %e, "cannot clone the connection");
            return admission;
        }
    };
    let tcp = read_half.is_tcp();
    let limits = shared.config.limits.clone();
    let mut reader = BufReader::with_capacity(256 * 1024, read_half);
    let mut session = Session {
        shared,
        id,
        tcp,
        out: Arc::new(Out {
            w: Mutex::new(BufWriter::with_capacity(256 * 1024, write_half)),
            broken: AtomicBool::new(false),
            limits: limits.clone(),
        }),
        client: String::new(),
        state: SessionState::new(shared.cache.clone(), limits),
        controls: Arc::default(),
        worker: None,
        recorder: None,
        requests: 0,
        admission,
    };
    // TCP connections that fail their handshake are logged by the throttle, once per burst.
    if tcp {
        tracing::debug!("connected");
    } else {
        tracing::info!("connected");
    }
    let started = Instant::now();
    let end = session.serve(&mut reader);
    session.finish(end);
    let seconds = started.elapsed().as_secs_f64();
    if matches!(session.admission, Admission::Session(_)) {
        tracing::info!(reason = ?end, client = %session.client, requests = session.requests,
            seconds, "session ended");
    } else {
        tracing::debug!(reason = ?end, requests = session.requests, seconds, "session ended");
    }
    session.admission
}

impl Session<'_> {
    /// The session's render worker, started on first use.
    fn worker(&mut self) -> &Worker {
        self.worker.get_or_insert_with(|| {
            let label = if self.client.is_empty() {
                format!("session-{}", self.id)
            } else {
                self.client.clone()
            };
            Worker::spawn(
                self.id,
                self.shared.clone(),
                self.out.clone(),
                self.controls.clone(),
                label,
            )
        })
    }

    /// Waits until every render asked for so far has replied.
    fn drain(&mut self) {
        if let Some(w) = self.worker.take() {
            w.finish();
        }
    }

    fn finish(&mut self, end: End) {
        match end {
            // The client is gone or the stream is unusable: nobody reads the results.
            End::Gone | End::BadFrame | End::Refused | End::Internal => {
                self.controls.cancel_all(false);
            }
            // The daemon stops: the render under way finishes, the queued ones are cancelled.
            End::Stopped => {
                self.controls.cancel_all(true);
            }
            End::Closed => {}
        }
        self.drain();
        if let Some(w) = self.recorder.take() {
            let _ = w.close();
        }
        let _ = lock(&self.out.w)
            .get_ref()
            .shutdown(std::net::Shutdown::Both);
    }
}

/// Where `--record` puts a session's recording.
fn recording_path(dir: &Path, session: u64) -> PathBuf {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    // The pid keeps two daemons recording into one folder from overwriting each other.
    let pid = std::process::id();
    dir.join(format!("session-{secs}-{pid}-{session}.antrec"))
}
