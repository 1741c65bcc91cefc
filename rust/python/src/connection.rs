//! The socket session: one connection to `antumbra serve`, speaking the protocol crate's framing.
//!
//! Every blocking step (encoding, writing, reading, decoding) runs without the GIL, in slices of
//! at most [`POLL`] so that Ctrl-C and progress callbacks are handled while a render runs. All
//! writes go through one writer lock, so `cancel()` can be sent from another thread while the
//! render's thread reads.

use std::collections::HashSet;
use std::io::{ErrorKind, Read, Write};
use std::os::unix::net::UnixStream;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard, TryLockError};
use std::time::{Duration, Instant};

use antumbra_protocol::{
    encode_message, FrameDecoder, FrameError, Limits, Reply, Request, PROTOCOL_VERSION,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::mesh_from_arrays;
use crate::error::{ClientError, ClientResult, IntoPyResult};
use crate::recording::Recorder;
use crate::result::{daemon_stats, frame_result_to_py, limits as limits_dict};
use crate::scene;
use crate::settings::RenderSettings;
use antumbra_protocol::{upload_from_mesh, RenderRequest};

/// Longest time spent without the GIL before checking for signals.
const POLL: Duration = Duration::from_millis(100);
/// How long to wait for a cancelled render to end after Ctrl-C or a callback error.
const CANCEL_DRAIN: Duration = Duration::from_secs(30);
const READ_CHUNK: usize = 1 << 20;

struct Conn {
    reader: UnixStream,
    decoder: FrameDecoder,
    buf: Vec<u8>,
    /// Why the session cannot go on, once it cannot.
    broken: Option<String>,
    /// Meshes the daemon confirmed it holds (MeshStored, or absent from a missing list).
    known: HashSet<u64>,
    recorder: Option<Recorder>,
}

enum Poll {
    Reply(Reply),
    Pending,
}

impl Conn {
    /// Reads until a whole reply is buffered or `slice` has passed; runs without the GIL.
    fn poll(&mut self, slice: Duration) -> Result<Poll, ReadError> {
        let until = Instant::now() + slice;
        loop {
            match self.decoder.next_message::<Reply>() {
                Ok(Some(r)) => return Ok(Poll::Reply(r)),
                Ok(None) => {}
                Err(e) => return Err(ReadError::Frame(e)),
            }
            let now = Instant::now();
            if now >= until {
                return Ok(Poll::Pending);
            }
            self.reader
                .set_read_timeout(Some((until - now).max(Duration::from_millis(1))))
                .map_err(ReadError::Io)?;
            match self.reader.read(&mut self.buf) {
                Ok(0) => return Err(ReadError::Frame(self.decoder.finish())),
                Ok(n) => self.decoder.push(&self.buf[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                    ) => {}
                Err(e) => return Err(ReadError::Io(e)),
            }
        }
    }
}

enum ReadError {
    Frame(FrameError),
    Io(std::io::Error),
}

impl ReadError {
    fn into_client(self, waiting_for: &str) -> ClientError {
        match self {
            ReadError::Frame(FrameError::Closed) => ClientError::Lost(format!(
                "the daemon closed the connection while this client waited for {waiting_for}"
            )),
            ReadError::Frame(FrameError::Decode(e)) => ClientError::Mismatch(format!(
                "cannot read the daemon's reply to {waiting_for}: {e} (is the daemon the same \
                 antumbra version as this client?)"
            )),
            ReadError::Frame(e) => ClientError::Lost(format!(
                "connection to the daemon broken while waiting for {waiting_for}: {e}"
            )),
            ReadError::Io(e) => ClientError::Lost(format!(
                "connection to the daemon broken while waiting for {waiting_for}: {e}"
            )),
        }
    }
}

/// A connection to the antumbra daemon (`antumbra._native.Connection`); use `antumbra.Client`.
#[pyclass(frozen, module = "antumbra._native")]
pub struct Connection {
    socket_path: String,
    server: String,
    version: u32,
    limits: Limits,
    timeout: Option<Duration>,
    state: Mutex<Option<Conn>>,
    writer: Mutex<Option<UnixStream>>,
    /// The request id of the render in progress (0: none).
    active_render: AtomicU64,
    /// `Ack`s still to come for cancels sent while a render ran.
    stray_acks: AtomicU32,
    next_id: AtomicU64,
}

fn duration(seconds: Option<f64>, what: &str) -> ClientResult<Option<Duration>> {
    match seconds {
        None => Ok(None),
        Some(s) if s.is_finite() && s > 0.0 => Ok(Some(Duration::from_secs_f64(s))),
        Some(s) => Err(ClientError::invalid(format!(
            "{what}: expected a positive number of seconds or None, got {s}"
        ))),
    }
}

fn unavailable(path: &str, e: &std::io::Error) -> ClientError {
    let how = format!(
        "start one with `antumbra serve --socket {path}`, or let antumbra.Client.spawn() start \
         one for this session"
    );
    match e.kind() {
        ErrorKind::NotFound | ErrorKind::ConnectionRefused => ClientError::Unavailable(format!(
            "no antumbra daemon is listening at {path} ({e}); {how}"
        )),
        ErrorKind::PermissionDenied => ClientError::Unavailable(format!(
            "cannot connect to the antumbra daemon at {path}: permission denied (the socket \
             belongs to another user?)"
        )),
        _ => ClientError::Unavailable(format!(
            "cannot connect to the antumbra daemon at {path}: {e}; {how}"
        )),
    }
}

type Guard<'a> = MutexGuard<'a, Option<Conn>>;

impl Connection {
    fn lock(&self) -> ClientResult<Guard<'_>> {
        match self.state.try_lock() {
            Ok(g) => Ok(g),
            Err(TryLockError::WouldBlock) => Err(ClientError::Busy(
                "another thread is using this client (a render in progress?); one request at \
                 a time per client, except cancel()"
                    .into(),
            )),
            Err(TryLockError::Poisoned(p)) => Ok(p.into_inner()),
        }
    }

    /// The open, usable connection in `guard`.
    fn conn<'g>(guard: &'g mut Guard<'_>) -> ClientResult<&'g mut Conn> {
        let conn = guard
            .as_mut()
            .ok_or_else(|| ClientError::Lost("the client is closed".into()))?;
        if let Some(why) = &conn.broken {
            return Err(ClientError::Lost(format!(
                "this session can no longer be used ({why}); connect again"
            )));
        }
        Ok(conn)
    }

    /// Writes one framed message; the encoding and the write run without the GIL.
    fn send(&self, py: Python<'_>, conn: &mut Conn, request: &Request) -> ClientResult<()> {
        let kind = request.kind();
        let result = py.detach(|| -> ClientResult<()> {
            let bytes = encode_message(request)
                .map_err(|e| ClientError::invalid(format!("{kind}: {e}")))?;
            let mut writer = self.writer.lock().unwrap_or_else(|p| p.into_inner());
            let w = writer
                .as_mut()
                .ok_or_else(|| ClientError::Lost("the client is closed".into()))?;
            w.set_write_timeout(self.timeout)
                .and_then(|_| w.write_all(&bytes))
                .and_then(|_| w.flush())
                .map_err(|e| match e.kind() {
                    ErrorKind::WouldBlock | ErrorKind::TimedOut => ClientError::Timeout(format!(
                        "the daemon did not take the {kind} request within {:?}",
                        self.timeout.unwrap_or_default()
                    )),
                    _ => ClientError::Lost(format!(
                        "connection to the daemon broken while sending {kind}: {e}"
                    )),
                })
        });
        if let Err(e) = &result {
            if !matches!(e, ClientError::Invalid(_)) {
                conn.broken = Some(format!("sending {kind} failed"));
            }
        }
        result
    }

    /// The next reply, skipping the `Ack`s of cancels; `Err` with the GIL's pending exception on
    /// Ctrl-C. `deadline` None waits for ever.
    fn recv(
        &self,
        py: Python<'_>,
        conn: &mut Conn,
        waiting_for: &str,
        deadline: Option<Instant>,
    ) -> ClientResult<Reply> {
        let started = Instant::now();
        loop {
            let slice = match deadline {
                Some(d) => {
                    let left = d.saturating_duration_since(Instant::now());
                    if left.is_zero() {
                        conn.broken = Some(format!("no reply to {waiting_for} in time"));
                        return Err(ClientError::Timeout(format!(
                            "the daemon did not answer {waiting_for} within {:.1} s",
                            started.elapsed().as_secs_f64()
                        )));
                    }
                    left.min(POLL)
                }
                None => POLL,
            };
            match py.detach(|| conn.poll(slice)) {
                Ok(Poll::Reply(Reply::Ack)) if self.take_stray_ack() => continue,
                Ok(Poll::Reply(r)) => return Ok(r),
                Ok(Poll::Pending) => {}
                Err(e) => {
                    let e = e.into_client(waiting_for);
                    conn.broken = Some(match &e {
                        ClientError::Mismatch(m) | ClientError::Lost(m) => m.clone(),
                        _ => "read failed".into(),
                    });
                    return Err(e);
                }
            }
            if let Err(e) = py.check_signals() {
                conn.broken = Some(format!("interrupted while waiting for {waiting_for}"));
                return Err(e.into());
            }
        }
    }

    fn take_stray_ack(&self) -> bool {
        self.stray_acks
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| n.checked_sub(1))
            .is_ok()
    }

    fn deadline(&self) -> Option<Instant> {
        self.timeout.map(|t| Instant::now() + t)
    }

    /// Sends a request and reads its reply; an `Error` reply becomes `DaemonError` (and ends the
    /// session if the daemon says so).
    fn request(&self, py: Python<'_>, conn: &mut Conn, request: &Request) -> ClientResult<Reply> {
        self.send(py, conn, request)?;
        let kind = request.kind();
        let reply = self.recv(py, conn, &format!("the reply to {kind}"), self.deadline())?;
        error_of(conn, reply)
    }

    fn unexpected(conn: &mut Conn, request: &str, reply: &Reply) -> ClientError {
        let m = format!(
            "the daemon answered {request} with {}, which this client does not expect",
            reply.kind()
        );
        conn.broken = Some(m.clone());
        ClientError::Mismatch(m)
    }

    fn close_inner(&self, py: Python<'_>, request: Option<Request>) -> ClientResult<()> {
        let mut guard = self.lock()?;
        let mut result = Ok(());
        if let Some(conn) = guard.as_mut() {
            if conn.broken.is_none() {
                if let Some(request) = request {
                    let kind = request.kind();
                    result = self.request(py, conn, &request).and_then(|r| match r {
                        Reply::Ack => Ok(()),
                        other => Err(Self::unexpected(conn, kind, &other)),
                    });
                }
            }
        }
        if let Some(mut conn) = guard.take() {
            if let Some(rec) = conn.recorder.take() {
                result = result.and(rec.finish().map(|_| ()));
            }
            let _ = conn.reader.shutdown(std::net::Shutdown::Both);
        }
        *self.writer.lock().unwrap_or_else(|p| p.into_inner()) = None;
        result
    }
}

/// An `Error` reply as a `DaemonError`; other replies pass through.
fn error_of(conn: &mut Conn, reply: Reply) -> ClientResult<Reply> {
    match reply {
        Reply::Error {
            code,
            message,
            session_usable,
            request_id,
        } => {
            if !session_usable {
                conn.broken = Some(format!("the daemon ended the session: {message}"));
            }
            Err(ClientError::Request {
                code,
                message,
                session_usable,
                request_id,
                daemon: true,
            })
        }
        other => Ok(other),
    }
}

#[pymethods]
impl Connection {
    /// Connects to the daemon at `socket_path` and says Hello.
    #[new]
    #[pyo3(signature = (socket_path, timeout = Some(10.0), client_name = "antumbra-python".to_string(), token = None))]
    fn new(
        py: Python<'_>,
        socket_path: String,
        timeout: Option<f64>,
        client_name: String,
        token: Option<String>,
    ) -> PyResult<Self> {
        Self::connect(py, socket_path, timeout, client_name, token).py_result(py)
    }

    /// The socket path this client is connected to.
    #[getter]
    fn socket_path(&self) -> &str {
        &self.socket_path
    }

    /// The daemon's name and version, from its Welcome.
    #[getter]
    fn server(&self) -> &str {
        &self.server
    }

    #[getter]
    fn protocol_version(&self) -> u32 {
        self.version
    }

    /// The daemon's limits, from its Welcome.
    #[getter]
    fn limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        limits_dict(py, &self.limits)
    }

    #[getter]
    fn timeout(&self) -> Option<f64> {
        self.timeout.map(|t| t.as_secs_f64())
    }

    #[getter]
    fn closed(&self) -> bool {
        match self.state.try_lock() {
            Ok(g) => g.is_none(),
            Err(_) => false,
        }
    }

    /// The request id of the render in progress, or None.
    #[getter]
    fn active_request(&self) -> Option<u64> {
        match self.active_render.load(Ordering::SeqCst) {
            0 => None,
            id => Some(id),
        }
    }

    /// Which of these mesh hashes the daemon lacks.
    fn missing_meshes(&self, py: Python<'_>, hashes: &Bound<'_, PyAny>) -> PyResult<Vec<u64>> {
        (|| {
            let hashes = scene::hashes(hashes)?;
            let mut guard = self.lock()?;
            let conn = Self::conn(&mut guard)?;
            let request = Request::MissingMeshes {
                hashes: hashes.clone(),
            };
            match self.request(py, conn, &request)? {
                Reply::Missing { hashes: missing } => {
                    let m: HashSet<u64> = missing.iter().copied().collect();
                    conn.known.extend(hashes.iter().filter(|h| !m.contains(h)));
                    for h in &missing {
                        conn.known.remove(h);
                    }
                    // While recording, meshes the file lacks count as missing too.
                    let mut out = missing;
                    if let Some(rec) = &conn.recorder {
                        let mut seen = m;
                        for h in hashes {
                            if !rec.has_mesh(h) && seen.insert(h) {
                                out.push(h);
                            }
                        }
                    }
                    Ok(out)
                }
                other => Err(Self::unexpected(conn, "MissingMeshes", &other)),
            }
        })()
        .py_result(py)
    }

    /// Hashes, checks and uploads a mesh; returns its content hash.
    fn upload_mesh(
        &self,
        py: Python<'_>,
        name: &Bound<'_, PyAny>,
        positions: &Bound<'_, PyAny>,
        triangles: &Bound<'_, PyAny>,
    ) -> PyResult<u64> {
        (|| {
            let name = crate::mesh_name(name)?;
            let (mesh, hash) = mesh_from_arrays(py, &name, positions, triangles, true)?;
            let upload = py.detach(|| upload_from_mesh(&mesh));
            drop(mesh);
            let request = Request::UploadMesh(upload);
            antumbra_protocol::check_limits(&request, &self.limits)
                .map_err(|e| ClientError::invalid(e.to_string()))?;
            let mut guard = self.lock()?;
            let conn = Self::conn(&mut guard)?;
            // While recording, a mesh the daemon already holds goes to the file only.
            if !(conn.recorder.is_some() && conn.known.contains(&hash)) {
                match self.request(py, conn, &request)? {
                    Reply::MeshStored { hash: stored, .. } if stored == hash => {
                        conn.known.insert(hash);
                    }
                    Reply::MeshStored { hash: stored, .. } => {
                        return Err(ClientError::Mismatch(format!(
                            "mesh '{name}': the daemon stored hash {stored:#018x}, this client \
                             computed {hash:#018x} (different mesh hash functions?)"
                        )))
                    }
                    other => return Err(Self::unexpected(conn, "UploadMesh", &other)),
                }
            }
            if let (Some(rec), Request::UploadMesh(upload)) = (conn.recorder.as_mut(), &request) {
                rec.mesh(upload)?;
            }
            Ok(hash)
        })()
        .py_result(py)
    }

    /// Sends a frame's scene state; returns the hashes of the meshes it uses that the daemon
    /// lacks (upload them before rendering).
    fn frame_update(
        &self,
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
        objects: &Bound<'_, PyAny>,
        camera: &Bound<'_, PyAny>,
        lights: &Bound<'_, PyAny>,
        resolution: &Bound<'_, PyAny>,
    ) -> PyResult<Vec<u64>> {
        (|| {
            let update = scene::frame_update(frame, objects, camera, lights, resolution)?;
            scene::check_frame(&update, &self.limits)?;
            let mut guard = self.lock()?;
            let conn = Self::conn(&mut guard)?;
            let request = Request::FrameUpdate(update);
            let reply = self.request(py, conn, &request)?;
            let Request::FrameUpdate(update) = request else {
                unreachable!()
            };
            match reply {
                Reply::FrameAccepted {
                    meshes_missing,
                    frame,
                } if frame == update.frame => {
                    let m: HashSet<u64> = meshes_missing.iter().copied().collect();
                    for o in &update.objects {
                        if m.contains(&o.mesh_hash) {
                            conn.known.remove(&o.mesh_hash);
                        } else {
                            conn.known.insert(o.mesh_hash);
                        }
                    }
                    let mut out = meshes_missing;
                    if let Some(rec) = conn.recorder.as_mut() {
                        let mut seen = m;
                        out.extend(rec.missing(&update).into_iter().filter(|h| seen.insert(*h)));
                        rec.frame(&update)?;
                    }
                    Ok(out)
                }
                other => Err(Self::unexpected(conn, "FrameUpdate", &other)),
            }
        })()
        .py_result(py)
    }

    /// Sends the camera of every frame up front: pairs (frame, camera dict).
    fn camera_path(&self, py: Python<'_>, frames: &Bound<'_, PyAny>) -> PyResult<()> {
        (|| {
            let frames = scene::camera_path(frames)?;
            let mut guard = self.lock()?;
            let conn = Self::conn(&mut guard)?;
            let request = Request::CameraPath { frames };
            match self.request(py, conn, &request)? {
                Reply::Ack => {
                    if let Some(rec) = conn.recorder.as_mut() {
                        rec.camera_path(&request)?;
                    }
                    Ok(())
                }
                other => Err(Self::unexpected(conn, "CameraPath", &other)),
            }
        })()
        .py_result(py)
    }

    /// Renders a frame sent with frame_update; returns a dict that `antumbra.Result` wraps.
    #[pyo3(signature = (frame, settings, passes, progress = None, timeout = None))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        frame: &Bound<'py, PyAny>,
        settings: &RenderSettings,
        passes: &Bound<'py, PyAny>,
        progress: Option<Bound<'py, PyAny>>,
        timeout: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        (|| {
            let frame = scene::frame_number(frame, "frame")?;
            let settings = settings.state.clone();
            antumbra_protocol::check_limits(
                &Request::Render(RenderRequest {
                    frame,
                    settings: settings.clone(),
                    passes: Default::default(),
                    request_id: 0,
                }),
                &self.limits,
            )
            .map_err(|e| ClientError::invalid(e.to_string()))?;
            let passes = scene::passes(passes)?;
            let between_replies = duration(timeout, "timeout")?;
            if let Some(p) = &progress {
                if !p.is_callable() {
                    return Err(ClientError::invalid(
                        "progress: expected a callable progress(stage, done, total) or None",
                    ));
                }
            }
            let mut guard = self.lock()?;
            let conn = Self::conn(&mut guard)?;
            let request_id = self.next_id.fetch_add(1, Ordering::SeqCst);
            let request = Request::Render(RenderRequest {
                frame,
                settings,
                passes,
                request_id,
            });
            self.send(py, conn, &request)?;
            self.active_render.store(request_id, Ordering::SeqCst);
            let result =
                self.render_replies(py, conn, request_id, frame, progress, between_replies);
            self.active_render.store(0, Ordering::SeqCst);
            result
        })()
        .py_result(py)
    }

    /// Cancels the render in progress (from another thread, or a progress callback); returns
    /// whether a Cancel was sent. `request_id` None cancels whatever render runs.
    #[pyo3(signature = (request_id = None))]
    fn cancel(&self, py: Python<'_>, request_id: Option<u64>) -> PyResult<bool> {
        let active = self.active_render.load(Ordering::SeqCst);
        if active == 0 || request_id.is_some_and(|id| id != active) {
            return Ok(false);
        }
        self.send_cancel(py, active).py_result(py)?;
        Ok(true)
    }

    /// The daemon's statistics.
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        (|| {
            let mut guard = self.lock()?;
            let conn = Self::conn(&mut guard)?;
            match self.request(py, conn, &Request::Stats)? {
                Reply::DaemonStats(s) => Ok(daemon_stats(py, &s)?),
                other => Err(Self::unexpected(conn, "Stats", &other)),
            }
        })()
        .py_result(py)
    }

    /// Starts writing the session's uploads and frames to a recording (`.antrec`). While
    /// recording, meshes the file lacks are reported as missing so that the caller uploads them
    /// (a mesh the daemon already holds then goes to the file only).
    fn start_recording(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        (|| {
            let mut guard = self.lock()?;
            let conn = Self::conn(&mut guard)?;
            if conn.recorder.is_some() {
                return Err(ClientError::invalid(
                    "start_recording: a recording is already running; stop_recording() first",
                ));
            }
            conn.recorder = Some(Recorder::create(&path.to_string_lossy())?);
            Ok(())
        })()
        .py_result(py)
    }

    /// Stops the recording; returns (frames written, frames left out because their meshes were
    /// never uploaded).
    fn stop_recording(&self, py: Python<'_>) -> PyResult<(usize, usize)> {
        (|| {
            let mut guard = self.lock()?;
            let conn = guard
                .as_mut()
                .ok_or_else(|| ClientError::Lost("the client is closed".into()))?;
            match conn.recorder.take() {
                Some(r) => r.finish(),
                None => Err(ClientError::invalid(
                    "stop_recording: no recording is running",
                )),
            }
        })()
        .py_result(py)
    }

    /// Ends the session (Close; the daemon keeps its mesh cache) and closes the socket. Closing
    /// twice is allowed.
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        self.close_inner(py, Some(Request::Close)).py_result(py)
    }

    /// Stops the daemon (Shutdown), then closes the socket.
    fn shutdown(&self, py: Python<'_>) -> PyResult<()> {
        {
            let guard = self.lock().py_result(py)?;
            if guard.is_none() {
                return Err(ClientError::Lost("the client is closed".into()).into_py(py));
            }
        }
        self.close_inner(py, Some(Request::Shutdown)).py_result(py)
    }

    fn __repr__(&self) -> String {
        format!(
            "<antumbra._native.Connection {} server={:?}{}>",
            self.socket_path,
            self.server,
            if self.closed() { " closed" } else { "" }
        )
    }
}

impl Connection {
    fn connect(
        py: Python<'_>,
        socket_path: String,
        timeout: Option<f64>,
        client_name: String,
        token: Option<String>,
    ) -> ClientResult<Self> {
        let timeout = duration(timeout, "timeout")?;
        let stream = py
            .detach(|| UnixStream::connect(&socket_path))
            .map_err(|e| unavailable(&socket_path, &e))?;
        let writer = stream
            .try_clone()
            .map_err(|e| ClientError::Lost(format!("cannot use the socket: {e}")))?;
        let mut this = Connection {
            socket_path,
            server: String::new(),
            version: PROTOCOL_VERSION,
            limits: Limits::default(),
            timeout,
            state: Mutex::new(Some(Conn {
                reader: stream,
                decoder: FrameDecoder::new(&Limits::default()),
                buf: vec![0; READ_CHUNK],
                broken: None,
                known: HashSet::new(),
                recorder: None,
            })),
            writer: Mutex::new(Some(writer)),
            active_render: AtomicU64::new(0),
            stray_acks: AtomicU32::new(0),
            next_id: AtomicU64::new(1),
        };
        let hello = Request::Hello {
            version: PROTOCOL_VERSION,
            client: client_name,
            token,
        };
        let welcome = {
            let mut guard = this.lock()?;
            let conn = Self::conn(&mut guard)?;
            this.send(py, conn, &hello)?;
            this.recv(py, conn, "the reply to Hello", this.deadline())?
        };
        match welcome {
            Reply::Welcome {
                version,
                server,
                limits,
            } => {
                if version != PROTOCOL_VERSION {
                    return Err(ClientError::Mismatch(format!(
                        "the daemon at {} speaks protocol version {version}, this client \
                         version {PROTOCOL_VERSION}; use matching versions of antumbra and the \
                         antumbra Python package",
                        this.socket_path
                    )));
                }
                this.server = server;
                let state = this.state.get_mut().unwrap_or_else(|p| p.into_inner());
                if let Some(conn) = state.as_mut() {
                    conn.decoder = FrameDecoder::new(&limits);
                }
                this.limits = limits;
                Ok(this)
            }
            Reply::Error {
                code: antumbra_protocol::ErrorCode::VersionMismatch,
                message,
                ..
            } => Err(ClientError::Mismatch(message)),
            Reply::Error {
                code,
                message,
                session_usable,
                request_id,
            } => Err(ClientError::Request {
                code,
                message,
                session_usable,
                request_id,
                daemon: true,
            }),
            other => Err(ClientError::Mismatch(format!(
                "the daemon at {} answered Hello with {} instead of Welcome (is it an antumbra \
                 daemon?)",
                this.socket_path,
                other.kind()
            ))),
        }
    }

    fn send_cancel(&self, py: Python<'_>, request_id: u64) -> ClientResult<()> {
        // Counted before the write so that the reader skips the Ack however fast it comes.
        self.stray_acks.fetch_add(1, Ordering::SeqCst);
        let bytes = encode_message(&Request::Cancel { request_id })
            .map_err(|e| ClientError::invalid(format!("Cancel: {e}")))?;
        py.detach(|| {
            let mut writer = self.writer.lock().unwrap_or_else(|p| p.into_inner());
            match writer.as_mut() {
                Some(w) => w.write_all(&bytes).map_err(|e| {
                    ClientError::Lost(format!("cannot send Cancel to the daemon: {e}"))
                }),
                None => Err(ClientError::Lost("the client is closed".into())),
            }
        })
    }

    /// Reads a render's replies until its result or error. A progress callback that raises (or
    /// returns False) and Ctrl-C cancel the render, which the daemon then ends (it checks for a
    /// cancel before and after rendering): its last reply is read so the session stays in
    /// step, and the callback's exception (or KeyboardInterrupt) is raised. After Ctrl-C the
    /// wait is bounded by [`CANCEL_DRAIN`] and a second Ctrl-C gives up at once (the session
    /// then cannot be used).
    fn render_replies<'py>(
        &self,
        py: Python<'py>,
        conn: &mut Conn,
        request_id: u64,
        frame: i32,
        progress: Option<Bound<'py, PyAny>>,
        between_replies: Option<Duration>,
    ) -> ClientResult<Bound<'py, PyDict>> {
        let waiting_for = format!("the result of Render frame {frame}");
        let mut abort: Option<ClientError> = None;
        let mut drain_until: Option<Instant> = None;
        loop {
            let deadline = match (drain_until, between_replies) {
                (Some(d), _) => Some(d),
                (None, Some(t)) => Some(Instant::now() + t),
                (None, None) => None,
            };
            let reply = match self.recv(py, conn, &waiting_for, deadline) {
                Ok(r) => r,
                Err(ClientError::Py(e)) if abort.is_none() => {
                    // Ctrl-C: cancel, then wait for the render to end.
                    conn.broken = None;
                    self.send_cancel(py, request_id)?;
                    abort = Some(ClientError::Py(e));
                    drain_until = Some(Instant::now() + CANCEL_DRAIN);
                    continue;
                }
                Err(e) => return Err(abort.unwrap_or(e)),
            };
            match reply {
                Reply::Progress {
                    request_id: id,
                    stage,
                    done,
                    total,
                } if id == request_id => {
                    if abort.is_some() {
                        continue;
                    }
                    if let Some(cb) = &progress {
                        let outcome = cb.call1((stage, done, total));
                        let stop = match outcome {
                            Ok(v) => v.is_instance_of::<pyo3::types::PyBool>() && !v.is_truthy()?,
                            Err(e) => {
                                abort = Some(ClientError::Py(e));
                                true
                            }
                        };
                        if stop {
                            self.send_cancel(py, request_id)?;
                        }
                    }
                }
                Reply::FrameResult(r) if r.request_id == request_id => {
                    if let Some(e) = abort {
                        return Err(e);
                    }
                    return frame_result_to_py(py, r);
                }
                Reply::Error {
                    request_id: Some(id),
                    ..
                } if id != request_id => {
                    return Err(Self::unexpected(conn, "Render", &reply));
                }
                Reply::Error { .. } => {
                    let e = error_of(conn, reply).expect_err("an Error reply");
                    return Err(abort.unwrap_or(e));
                }
                other => return Err(Self::unexpected(conn, "Render", &other)),
            }
        }
    }
}
