//! The one client of the protocol, used by the Python binding, the tests and tools: connect, say
//! Hello, send requests and read their replies, scenes (uploading only missing meshes), renders.

mod conn;
mod error;
mod requests;

use std::cell::Cell;
use std::io::{self, ErrorKind, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpStream};
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

pub use conn::Conn;
pub use error::ClientError;
pub use requests::{Missing, Rendered, SceneSent};

use crate::{
    encode_message, FrameDecoder, FrameError, FrameUpdate, Limits, Reply, Request, PROTOCOL_VERSION,
};

const READ_CHUNK: usize = 1 << 20;

/// How a caller waits for the daemon. Replies are read through a [`FrameDecoder`] in slices the
/// caller chooses, so it can release a lock (Python's GIL) while it waits and handle Ctrl-C
/// between slices without losing its place in the stream.
pub trait Wait {
    /// The longest read before [`Wait::between`] is asked; None reads until a reply or the
    /// deadline.
    fn slice(&self) -> Option<Duration>;
    /// Runs one blocking step (a write, or a read of at most a slice): the Python binding
    /// releases the GIL here.
    fn block<T: Send>(&mut self, step: impl FnOnce() -> T + Send) -> T;
    /// Called after a slice without a reply; [`Interrupt`] (Ctrl-C) ends the wait.
    fn between(&mut self) -> Result<(), Interrupt>;
}

/// The caller stopped a wait; it keeps the reason itself (a Python exception, say).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Interrupt;

/// Waits in one blocking read, up to the client's timeout (tests, tools).
pub struct Blocking;

impl Wait for Blocking {
    fn slice(&self) -> Option<Duration> {
        None
    }

    fn block<T: Send>(&mut self, step: impl FnOnce() -> T + Send) -> T {
        step()
    }

    fn between(&mut self) -> Result<(), Interrupt> {
        Ok(())
    }
}

/// The writing side of a client: every write takes its lock, so another thread can send `Cancel`
/// while a render's replies are read.
#[derive(Clone)]
pub struct Sender(Arc<SendSide>);

struct SendSide {
    /// None once the client is closed.
    conn: Mutex<Option<Conn>>,
    bytes: AtomicU64,
    /// `Ack`s still to come for cancels sent while a render ran; the reader skips them.
    stray_acks: AtomicU32,
}

impl Sender {
    fn lock(&self) -> MutexGuard<'_, Option<Conn>> {
        self.0.conn.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Writes bytes as they are; `NotConnected` once the client is closed.
    fn write(&self, bytes: &[u8]) -> io::Result<()> {
        let mut conn = self.lock();
        let w = conn
            .as_mut()
            .ok_or_else(|| io::Error::new(ErrorKind::NotConnected, "the client is closed"))?;
        w.write_all(bytes).and_then(|()| w.flush())?;
        self.0
            .bytes
            .fetch_add(bytes.len() as u64, Ordering::Relaxed);
        Ok(())
    }

    /// Sends `Cancel` for a render in progress. Its `Ack` is skipped by the reader, which is
    /// busy with the render's replies.
    pub fn cancel(&self, request_id: u64) -> Result<(), ClientError> {
        // Counted before the write so that the reader skips the Ack however fast it comes.
        self.0.stray_acks.fetch_add(1, Ordering::SeqCst);
        let bytes = encode_message(&Request::Cancel { request_id }).map_err(|error| {
            ClientError::Encode {
                kind: "Cancel",
                error,
            }
        })?;
        self.write(&bytes).map_err(|error| match error.kind() {
            ErrorKind::NotConnected => ClientError::Closed,
            _ => ClientError::Send {
                kind: "Cancel",
                error,
            },
        })
    }

    fn take_stray_ack(&self) -> bool {
        self.0
            .stray_acks
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| n.checked_sub(1))
            .is_ok()
    }
}

/// A session with the daemon.
pub struct Client {
    reader: Conn,
    decoder: FrameDecoder,
    buf: Vec<u8>,
    sender: Sender,
    limits: Limits,
    server: String,
    /// How long a request waits for its reply, and a write for the socket (None: for ever).
    timeout: Cell<Option<Duration>>,
    /// Why the session cannot go on, once it cannot.
    broken: Option<String>,
    /// The instance arrays of the last frame the daemon accepted: arrays equal to them travel
    /// as `unchanged`.
    accepted: Option<FrameUpdate>,
}

impl Client {
    pub fn new(conn: Conn) -> io::Result<Self> {
        let writer = conn.try_clone()?;
        Ok(Client {
            reader: conn,
            decoder: FrameDecoder::new(&Limits::default()),
            buf: vec![0; READ_CHUNK],
            sender: Sender(Arc::new(SendSide {
                conn: Mutex::new(Some(writer)),
                bytes: AtomicU64::new(0),
                stray_acks: AtomicU32::new(0),
            })),
            limits: Limits::default(),
            server: String::new(),
            timeout: Cell::new(None),
            broken: None,
            accepted: None,
        })
    }

    pub fn connect_unix(path: &Path) -> io::Result<Self> {
        Client::new(Conn::Unix(UnixStream::connect(path)?))
    }

    pub fn connect_tcp(addr: SocketAddr) -> io::Result<Self> {
        let s = TcpStream::connect(addr)?;
        s.set_nodelay(true)?;
        Client::new(Conn::Tcp(s))
    }

    /// How long a request waits for its reply and a write for the socket (none by default).
    pub fn set_timeout(&self, t: Option<Duration>) -> io::Result<()> {
        self.timeout.set(t);
        match self.sender.lock().as_ref() {
            Some(w) => w.set_write_timeout(t),
            None => Ok(()),
        }
    }

    pub fn timeout(&self) -> Option<Duration> {
        self.timeout.get()
    }

    /// The daemon's limits (from `Welcome`; the defaults until then).
    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// The daemon's name and version (from `Welcome`).
    pub fn server(&self) -> &str {
        &self.server
    }

    /// All bytes sent so far.
    pub fn bytes_sent(&self) -> u64 {
        self.sender.0.bytes.load(Ordering::Relaxed)
    }

    /// A handle that sends `Cancel` from another thread.
    pub fn sender(&self) -> Sender {
        self.sender.clone()
    }

    /// Ok while the session can be used; else why not.
    pub fn usable(&self) -> Result<(), ClientError> {
        match &self.broken {
            Some(why) => Err(ClientError::Broken(why.clone())),
            None => Ok(()),
        }
    }

    fn deadline(&self) -> Option<Instant> {
        self.timeout.get().map(|t| Instant::now() + t)
    }

    pub fn send(&mut self, request: &Request) -> Result<(), ClientError> {
        self.send_with(&mut Blocking, request)
    }

    /// Writes one framed request; the encoding and the write run in [`Wait::block`].
    pub fn send_with(
        &mut self,
        wait: &mut impl Wait,
        request: &Request,
    ) -> Result<(), ClientError> {
        let kind = request.kind();
        let sender = &self.sender;
        let waited = self.timeout.get().unwrap_or_default();
        let result = wait.block(|| {
            let bytes =
                encode_message(request).map_err(|error| ClientError::Encode { kind, error })?;
            sender.write(&bytes).map_err(|error| match error.kind() {
                ErrorKind::NotConnected => ClientError::Closed,
                ErrorKind::WouldBlock | ErrorKind::TimedOut => {
                    ClientError::SendTimeout { kind, waited }
                }
                _ => ClientError::Send { kind, error },
            })
        });
        if let Err(e) = &result {
            if !matches!(e, ClientError::Encode { .. }) {
                self.broken = Some(format!("sending {kind} failed"));
            }
        }
        result
    }

    /// Sends bytes as they are (malformed input in tests).
    pub fn send_raw(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.sender.write(bytes)
    }

    /// Closes the sending side (the daemon sees the end of the stream).
    pub fn shutdown_write(&mut self) -> io::Result<()> {
        match self.sender.lock().as_ref() {
            Some(w) => w.shutdown(Shutdown::Write),
            None => Ok(()),
        }
    }

    /// Closes the connection without a word; later sends fail with [`ClientError::Closed`].
    pub fn disconnect(&mut self) {
        let _ = self.reader.shutdown(Shutdown::Both);
        *self.sender.lock() = None;
        self.broken = Some("the client is closed".into());
    }

    /// Reads until a whole reply is buffered or `wait` has passed (None: until a reply).
    fn poll(&mut self, wait: Option<Duration>) -> Result<Option<Reply>, FrameError> {
        let until = wait.map(|w| Instant::now() + w);
        loop {
            if let Some(r) = self.decoder.next_message::<Reply>()? {
                return Ok(Some(r));
            }
            let timeout = match until {
                Some(until) => {
                    let now = Instant::now();
                    if now >= until {
                        return Ok(None);
                    }
                    Some((until - now).max(Duration::from_millis(1)))
                }
                None => None,
            };
            self.reader.set_read_timeout(timeout)?;
            match self.reader.read(&mut self.buf) {
                Ok(0) => return Err(self.decoder.finish()),
                Ok(n) => self.decoder.push(&self.buf[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                    ) => {}
                Err(e) => return Err(FrameError::Io(e)),
            }
        }
    }

    /// The next reply (an `Error` too), skipping the `Ack`s of cancels sent by a [`Sender`].
    /// `deadline` None waits for ever.
    pub fn recv_within(
        &mut self,
        wait: &mut impl Wait,
        waiting_for: &str,
        deadline: Option<Instant>,
    ) -> Result<Reply, ClientError> {
        let started = Instant::now();
        loop {
            let slice = match deadline {
                Some(d) => {
                    let left = d.saturating_duration_since(Instant::now());
                    if left.is_zero() {
                        self.broken = Some(format!("no reply to {waiting_for} in time"));
                        return Err(ClientError::Timeout {
                            waiting_for: waiting_for.into(),
                            waited: started.elapsed(),
                        });
                    }
                    Some(wait.slice().map_or(left, |s| s.min(left)))
                }
                None => wait.slice(),
            };
            match wait.block(|| self.poll(slice)) {
                Ok(Some(Reply::Ack)) if self.sender.take_stray_ack() => continue,
                Ok(Some(r)) => return Ok(r),
                Ok(None) => {}
                Err(error) => {
                    let e = ClientError::Read {
                        waiting_for: waiting_for.into(),
                        error,
                    };
                    self.broken = Some(e.to_string());
                    return Err(e);
                }
            }
            if wait.between().is_err() {
                self.broken = Some(format!("interrupted while waiting for {waiting_for}"));
                return Err(ClientError::Interrupted {
                    waiting_for: waiting_for.into(),
                });
            }
        }
    }

    /// The next reply, within the client's timeout.
    pub fn recv(&mut self) -> Result<Reply, ClientError> {
        let deadline = self.deadline();
        self.recv_within(&mut Blocking, "a reply", deadline)
    }

    /// Sends a request and reads one reply, whatever it is.
    pub fn call(&mut self, request: &Request) -> Result<Reply, ClientError> {
        self.send(request)?;
        self.recv()
    }

    /// Sends a request and reads its reply within the timeout; an `Error` reply becomes
    /// [`ClientError::Daemon`] (and ends the session if the daemon says so).
    pub fn request(
        &mut self,
        wait: &mut impl Wait,
        request: &Request,
    ) -> Result<Reply, ClientError> {
        self.send_with(wait, request)?;
        let waiting_for = format!("the reply to {}", request.kind());
        let deadline = self.deadline();
        let reply = self.recv_within(wait, &waiting_for, deadline)?;
        self.error_of(reply)
    }

    /// An `Error` reply as [`ClientError::Daemon`]; other replies pass through.
    fn error_of(&mut self, reply: Reply) -> Result<Reply, ClientError> {
        match reply {
            Reply::Error {
                session_usable,
                ref message,
                ..
            } => {
                if !session_usable {
                    self.broken = Some(format!("the daemon ended the session: {message}"));
                }
                Err(ClientError::from_reply("", reply))
            }
            other => Ok(other),
        }
    }

    /// A reply this client does not expect: the stream is out of step.
    fn unexpected(&mut self, request: &str, reply: &Reply) -> ClientError {
        let e = ClientError::Unexpected {
            request: request.into(),
            reply: reply.kind().into(),
        };
        self.broken = Some(e.to_string());
        e
    }

    /// Says `Hello` and reads the `Welcome`: the daemon's name and limits.
    pub fn handshake(
        &mut self,
        wait: &mut impl Wait,
        client: &str,
        token: Option<&str>,
    ) -> Result<(), ClientError> {
        let hello = Request::Hello {
            version: PROTOCOL_VERSION,
            client: client.into(),
            token: token.map(str::to_string),
        };
        self.send_with(wait, &hello)?;
        let deadline = self.deadline();
        match self.recv_within(wait, "the reply to Hello", deadline)? {
            Reply::Welcome {
                version,
                server,
                limits,
            } => {
                if version != PROTOCOL_VERSION {
                    return Err(ClientError::Version { daemon: version });
                }
                self.server = server;
                self.decoder = FrameDecoder::new(&limits);
                self.limits = *limits;
                Ok(())
            }
            other => Err(ClientError::from_reply("Hello", other)),
        }
    }

    /// `Hello`; returns the daemon's limits.
    pub fn hello(&mut self, client: &str, token: Option<&str>) -> Result<Limits, ClientError> {
        self.handshake(&mut Blocking, client, token)?;
        Ok(self.limits.clone())
    }

    /// Sends a request whose answer is `Ack` (`Close`, `Shutdown`).
    pub fn ack(&mut self, wait: &mut impl Wait, request: &Request) -> Result<(), ClientError> {
        match self.request(wait, request)? {
            Reply::Ack => Ok(()),
            other => Err(self.unexpected(request.kind(), &other)),
        }
    }

    /// `Close`, waiting for its `Ack`.
    pub fn close(mut self) -> Result<(), ClientError> {
        self.ack(&mut Blocking, &Request::Close)
    }
}
