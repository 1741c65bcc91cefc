//! Reading a session's connection: the handshake (version, and the token on TCP) and the request
//! loop with its per-request panic guard.

use std::io::{self, BufReader, ErrorKind, Read};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

use antumbra_protocol::{
    check_hello, decode_body, read_frame, welcome, ErrorCode, FrameError, Reply, Request,
};

use super::{End, Flow, Next, Session};
use crate::gate::{self, Admission};
use crate::listen::{constant_time_eq, Conn};
use antumbra_session::error_reply;

/// Reads under one deadline for all the reads (none: no limit), by narrowing the socket's read
/// timeout to what is left of it before each read.
struct Deadline<'a> {
    reader: &'a mut BufReader<Conn>,
    deadline: Option<Instant>,
}

impl Read for Deadline<'_> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if let Some(deadline) = self.deadline {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(ErrorKind::TimedOut.into());
            }
            self.reader.get_ref().set_read_timeout(Some(left))?;
        }
        self.reader.read(buf)
    }
}

impl Session<'_> {
    pub(super) fn serve(&mut self, reader: &mut BufReader<Conn>) -> End {
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
            let upload = self.record(&request);
            let kind = request.kind();
            let flow = catch_unwind(AssertUnwindSafe(|| self.handle(request)));
            // An upload is recorded once stored, from what the daemon holds.
            if let Some(upload) = upload {
                self.record_upload(upload);
            }
            match flow {
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
        let frame = read_frame(reader, self.state.limits());
        self.interpret(frame)
    }

    /// Decodes a frame read, or says how its error ends the session.
    fn interpret(&mut self, frame: Result<Vec<u8>, FrameError>) -> Next {
        match frame {
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

    /// Waits for `Hello`: the version must match and, on TCP, the token too. Until then a frame
    /// may be only `handshake_max_frame_bytes`, and a TCP client has `handshake_timeout` from its
    /// connection for all its reads (a local client may idle). Returns why the session ends if
    /// it does.
    fn handshake(&mut self, reader: &mut BufReader<Conn>) -> Option<End> {
        let config = &self.shared.config;
        let mut limits = self.state.limits().clone();
        limits.max_frame_bytes = limits.frame_limit().min(config.handshake_max_frame_bytes);
        let deadline = match &self.admission {
            Admission::Pending(p) => Some(p.accepted + config.handshake_timeout),
            Admission::Session(_) => None,
        };
        loop {
            let frame = read_frame(&mut Deadline { reader, deadline }, &limits);
            let request = match frame {
                Err(FrameError::TooLarge { len, max }) => return Some(self.refuse_frame(len, max)),
                Err(FrameError::Io(e))
                    if deadline.is_some()
                        && matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) =>
                {
                    return Some(self.too_late())
                }
                // On TCP anything but a Hello is a failed attempt, answered once.
                Err(FrameError::Decode(_) | FrameError::Truncated { .. }) if self.tcp => {
                    return Some(self.refuse("the first message is not Hello"))
                }
                frame => match self.interpret(frame) {
                    Next::Request(r) => *r,
                    Next::Skip => continue,
                    Next::End(end) => return Some(end),
                },
            };
            self.requests += 1;
            if self.tcp {
                if !self.token_ok(&request) {
                    return Some(self.refuse(match &request {
                        Request::Hello { token: None, .. } => "Hello carries no token",
                        Request::Hello { .. } => "wrong token",
                        _ => "the first message is not Hello",
                    }));
                }
                if let Admission::Pending(p) = &self.admission {
                    self.shared.throttle.succeeded(p.ip, Instant::now());
                }
            }
            match check_hello(&request) {
                Ok(()) => {
                    if let Some(end) = self.take_session_slot() {
                        return Some(end);
                    }
                    if let Request::Hello { client, .. } = &request {
                        self.client = client.clone();
                    }
                    self.start_recording();
                    self.record(&request);
                    tracing::info!(client = %self.client, "hello");
                    self.out.send(&welcome(
                        &self.shared.config.server_name,
                        self.state.limits(),
                    ));
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

    /// A TCP connection that said a valid Hello trades its place among the handshakes for a
    /// session slot; with none free it is answered `Busy` (and the session ends).
    fn take_session_slot(&mut self) -> Option<End> {
        if let Admission::Session(_) = self.admission {
            return None;
        }
        match gate::admit_session(self.shared) {
            Some(slot) => {
                self.admission = Admission::Session(slot);
                None
            }
            None => {
                let max = self.shared.config.max_sessions;
                tracing::warn!(max, "too many sessions; refusing");
                self.out.send(&error_reply(
                    ErrorCode::Busy,
                    format!("the daemon already serves {max} sessions"),
                    false,
                    None,
                ));
                Some(End::Refused)
            }
        }
    }

    /// Counts a failed TCP handshake against its address (logged once per burst); on the Unix
    /// socket it is just logged.
    fn failed(&self, why: &str) {
        match &self.admission {
            Admission::Pending(p) => self.shared.throttle.failed(p.ip, why, Instant::now()),
            Admission::Session(_) => tracing::warn!(reason = why, "handshake refused"),
        }
    }

    /// A first frame above `handshake_max_frame_bytes`, refused from its length prefix.
    fn refuse_frame(&self, len: u64, max: u64) -> End {
        self.failed("first frame too large");
        self.out.send(&error_reply(
            ErrorCode::TooLarge,
            format!(
                "a frame of {len} bytes before the handshake: until Hello is accepted a frame may \
                 be at most {max} bytes (handshake_max_frame_bytes); the connection is closed"
            ),
            false,
            None,
        ));
        End::BadFrame
    }

    /// The TCP handshake's deadline passed before a whole Hello arrived.
    fn too_late(&self) -> End {
        let limit = self.shared.config.handshake_timeout.as_secs_f64();
        self.failed("handshake deadline passed");
        self.out.send(&error_reply(
            ErrorCode::InvalidInput,
            format!(
                "the handshake did not finish within {limit} s of connecting (handshake_timeout): \
                 a TCP client must send Hello with the token at once; the connection is closed"
            ),
            false,
            None,
        ));
        End::Refused
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
        self.failed(why);
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
}
