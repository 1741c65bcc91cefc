//! Reading a session's connection: the handshake (version, and the token on TCP), the request
//! loop with its per-request panic guard, and the session's recording.

use std::io::BufReader;
use std::panic::{catch_unwind, AssertUnwindSafe};

use antumbra_protocol::{
    check_hello, decode_body, read_frame, welcome, ErrorCode, FrameError, RecordingWriter, Reply,
    Request,
};

use super::out::error_reply;
use super::{recording_path, End, Flow, Next, Session};
use crate::listen::{constant_time_eq, Conn};

impl Session<'_> {
    pub(super) fn serve(&mut self, reader: &mut BufReader<Conn>) -> End {
        // A TCP peer must authenticate promptly; a local client may idle before Hello.
        if self.tcp {
            let _ = reader.get_ref().set_read_timeout(Some(self.shared.config.handshake_timeout));
        }
        if let Some(end) = self.handshake(reader) {
            return end;
        }
        let _ = reader.get_ref().set_read_timeout(None);
        loop {
            let request = match self.next(reader) {
                Next::Request(r) => *r,
                Next::Skip => continue,
                Next::End(end) => return end,
            };
            self.requests += 1;
            self.record(&request);
            let kind = request.kind();
            match catch_unwind(AssertUnwindSafe(|| self.handle(request))) {
                Ok(Flow::Continue) => {}
                Ok(Flow::End(end)) => return end,
                Err(_) => {
                    tracing::error!(request = kind, "request handler panicked");
                    self.out.send(&error_reply(
                        ErrorCode::Internal,
                        format!("internal error while handling {kind}; the session is closed"),
                        false,
                        None,
                    ));
                    return End::Internal;
                }
            }
        }
    }

    /// Reads the next request. Frame errors are answered here; those that leave the stream
    /// misaligned (truncated, too large) end the session.
    fn next(&mut self, reader: &mut BufReader<Conn>) -> Next {
        match read_frame(reader, &self.limits) {
            Ok(body) => match decode_body::<Request>(&body) {
                Ok(r) => Next::Request(Box::new(r)),
                Err(e) => {
                    tracing::warn!(error = %e, bytes = body.len(), "undecodable request");
                    self.out.send(&e.to_reply());
                    Next::Skip
                }
            },
            Err(FrameError::Closed) if self.shared.stopping() => Next::End(End::Stopped),
            Err(FrameError::Closed) => Next::End(End::Gone),
            Err(FrameError::Io(e)) => {
                tracing::debug!(error = %e, "read failed");
                Next::End(if self.shared.stopping() {
                    End::Stopped
                } else {
                    End::Gone
                })
            }
            Err(e) => {
                if self.shared.stopping() {
                    return Next::End(End::Stopped);
                }
                tracing::warn!(error = %e, "bad frame; closing the connection");
                self.out.send(&e.to_reply());
                Next::End(End::BadFrame)
            }
        }
    }

    /// Waits for `Hello`: the version must match and, on TCP, the token too. Returns why the
    /// session ends if it does.
    fn handshake(&mut self, reader: &mut BufReader<Conn>) -> Option<End> {
        loop {
            let request = match self.next(reader) {
                Next::Request(r) => *r,
                Next::Skip if self.tcp => {
                    return Some(self.refuse("the first message is not Hello"))
                }
                Next::Skip => continue,
                Next::End(end) => return Some(end),
            };
            self.requests += 1;
            if self.tcp && !self.token_ok(&request) {
                return Some(self.refuse(match &request {
                    Request::Hello { token: None, .. } => "Hello carries no token",
                    Request::Hello { .. } => "wrong token",
                    _ => "the first message is not Hello",
                }));
            }
            match check_hello(&request) {
                Ok(()) => {
                    if let Request::Hello { client, .. } = &request {
                        self.client = client.clone();
                    }
                    self.start_recording();
                    self.record(&request);
                    tracing::info!(client = %self.client, "hello");
                    self.out
                        .send(&welcome(&self.shared.config.server_name, &self.limits));
                    return None;
                }
                Err(e) => {
                    let reply = e.to_reply();
                    tracing::warn!(error = %e, request = request.kind(), "handshake refused");
                    self.out.send(&reply);
                    if let Reply::Error {
                        session_usable: false,
                        ..
                    } = reply
                    {
                        return Some(End::Refused);
                    }
                }
            }
        }
    }

    fn token_ok(&self, request: &Request) -> bool {
        let expected = self.shared.config.token.as_deref().unwrap_or_default();
        match request {
            Request::Hello {
                token: Some(token), ..
            } => !expected.is_empty() && constant_time_eq(token.as_bytes(), expected.as_bytes()),
            _ => false,
        }
    }

    fn refuse(&self, why: &str) -> End {
        tracing::warn!(reason = why, "tcp client refused: authentication failed");
        self.out.send(&error_reply(
            ErrorCode::InvalidInput,
            format!(
                "authentication failed: {why}; a TCP client's first message must be Hello with \
                 the daemon's token"
            ),
            false,
            None,
        ));
        End::Refused
    }

    fn start_recording(&mut self) {
        let Some(dir) = &self.shared.config.record else {
            return;
        };
        let path = recording_path(dir, self.id);
        match RecordingWriter::create(&path) {
            Ok(w) => {
                tracing::info!(path = %path.display(), "recording the session");
                self.recorder = Some(w);
            }
            Err(e) => tracing::warn!(error = %e, "cannot record the session"),
        }
    }

    /// Appends a request to the recording (a Hello without its token).
    fn record(&mut self, request: &Request) {
        let Some(w) = &mut self.recorder else {
            return;
        };
        let result = match request {
            Request::Hello {
                version, client, ..
            } => w.append(&Request::Hello {
                version: *version,
                client: client.clone(),
                token: None,
            }),
            other => w.append(other),
        };
        if let Err(e) = result
            .map_err(|e| e.to_string())
            .and_then(|()| w.flush().map_err(|e| e.to_string()))
        {
            tracing::warn!(error = %e, "recording failed; stopping it");
            self.recorder = None;
        }
    }
}
