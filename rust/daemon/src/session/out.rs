//! The replies' side of a session's connection: one locked writer, a whole frame at a time, shared
//! by the connection's thread and the render worker.

use std::io::{BufWriter, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

use antumbra_protocol::{encode_message_within, Limits, Reply};
use antumbra_session::error_reply;

use crate::listen::Conn;
use crate::lock;

/// The replies' side of the connection.
pub(super) struct Out {
    pub(super) w: Mutex<BufWriter<Conn>>,
    pub(super) broken: AtomicBool,
    pub(super) limits: Limits,
}

impl Out {
    /// Sends one encoded frame; false once the connection is broken.
    pub(super) fn send_frame(&self, bytes: &[u8]) -> bool {
        if self.broken.load(Ordering::Relaxed) {
            return false;
        }
        let mut w = lock(&self.w);
        let ok = w.write_all(bytes).and_then(|()| w.flush());
        if let Err(e) = ok {
            if !self.broken.swap(true, Ordering::Relaxed) {
                tracing::debug!(error = %e, "cannot write to the client");
            }
            return false;
        }
        true
    }

    pub(super) fn send(&self, reply: &Reply) -> bool {
        match encode_message_within(reply, &self.limits) {
            Ok(bytes) => self.send_frame(&bytes),
            Err(e) => {
                tracing::warn!(reply = reply.kind(), error = %e, "cannot encode a reply");
                let request_id = match reply {
                    Reply::FrameResult(r) => Some(r.request_id),
                    _ => None,
                };
                self.send(&error_reply(e.code(), e.to_string(), true, request_id))
            }
        }
    }
}
