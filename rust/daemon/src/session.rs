//! One client connection: the handshake, then requests until the client closes, a frame error
//! ends the connection, or the daemon stops.
//!
//! The connection's thread reads and answers requests; renders go to a second thread of the
//! session (its render worker, which owns the session's [`Renderer`]) so that `Cancel`, `Stats`
//! and frame updates are answered while a render runs. Replies from both threads go through one
//! locked writer, a whole frame at a time.

use std::collections::{HashMap, HashSet, VecDeque};
use std::fs::File;
use std::io::{BufReader, BufWriter, Write};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, OnceLock};
use std::thread::JoinHandle;
use std::time::Instant;

use antumbra_core::render::{RenderSettings, Renderer};
use antumbra_core::scene::{Mesh, Scene};
use antumbra_protocol::{
    check_hello, check_limits, decode_body, encode_message_within, frame_result_reply,
    mesh_from_upload, read_frame, render_settings, scene_from_frame, welcome, CameraState,
    ErrorCode, FrameError, FrameUpdate, Limits, Passes, ProtocolError, RecordingWriter, Reply,
    Request, UploadMesh,
};

use crate::listen::{constant_time_eq, Conn};
use crate::lock;
use crate::server::{bump, recording_path, Shared};

/// Frame descriptions a session keeps for `Render` (the most recently updated ones).
const FRAMES_KEPT: usize = 8;
/// Renders one session may have waiting; more get `Busy`.
const RENDER_QUEUE: usize = 32;
/// How long a TCP client has to send its Hello.
const HANDSHAKE_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(30);
/// Progress stages of a render after the optional `queued`: `render`, then `encode`.
const STAGES: u32 = 2;

/// The replies' side of the connection.
struct Out {
    w: Mutex<BufWriter<Conn>>,
    broken: AtomicBool,
    limits: Limits,
}

impl Out {
    /// Sends one encoded frame; false once the connection is broken.
    fn send_frame(&self, bytes: &[u8]) -> bool {
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

    fn send(&self, reply: &Reply) -> bool {
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

fn error_reply(
    code: ErrorCode,
    message: impl Into<String>,
    session_usable: bool,
    request_id: Option<u64>,
) -> Reply {
    Reply::Error {
        code,
        message: message.into(),
        session_usable,
        request_id,
    }
}

fn protocol_error(e: &ProtocolError, request_id: Option<u64>) -> Reply {
    match e.to_reply() {
        Reply::Error {
            code,
            message,
            session_usable,
            ..
        } => error_reply(code, message, session_usable, request_id),
        other => other,
    }
}

/// A render's controls, shared by the reader (Cancel), the worker and the session's end.
struct RenderCtl {
    cancel: AtomicBool,
    started: AtomicBool,
}

struct Job {
    request_id: u64,
    scene: Scene,
    settings: RenderSettings,
    passes: Passes,
    ctl: Arc<RenderCtl>,
}

type Controls = Arc<Mutex<HashMap<u64, Arc<RenderCtl>>>>;

struct Worker {
    tx: SyncSender<Job>,
    thread: JoinHandle<()>,
}

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
    limits: Limits,
    /// Frame updates seen (the generation of the session's mesh working set).
    generation: u64,
    /// The session's working set: meshes it uploaded, asked about or used recently, with the
    /// generation in which it last touched them. Holding the `Arc` keeps them out of eviction.
    pins: HashMap<u64, (Arc<Mesh>, u64)>,
    frames: VecDeque<Arc<FrameUpdate>>,
    camera_path: Vec<(i32, CameraState)>,
    controls: Controls,
    worker: Option<Worker>,
    recorder: Option<RecordingWriter<BufWriter<File>>>,
    requests: u64,
}

/// Serves one connection to its end.
pub(crate) fn run(shared: &Arc<Shared>, conn: Conn, id: u64) {
    let peer = conn.peer();
    let span = tracing::info_span!("session", id, peer = %peer);
    let _enter = span.enter();
    let (read_half, write_half) = match conn.try_clone() {
        Ok(w) => (conn, w),
        Err(e) => {
            tracing::warn!(error = %e, "cannot clone the connection");
            return;
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
        limits,
        generation: 0,
        pins: HashMap::new(),
        frames: VecDeque::new(),
        camera_path: Vec::new(),
        controls: Arc::new(Mutex::new(HashMap::new())),
        worker: None,
        recorder: None,
        requests: 0,
    };
    tracing::info!("connected");
    let started = Instant::now();
    let end = session.serve(&mut reader);
    session.finish(end);
    tracing::info!(
        reason = ?end,
        client = %session.client,
        requests = session.requests,
        seconds = started.elapsed().as_secs_f64(),
        "session ended"
    );
}

impl Session<'_> {
    fn serve(&mut self, reader: &mut BufReader<Conn>) -> End {
        // A TCP peer must authenticate promptly; a local client may idle before Hello.
        if self.tcp {
            let _ = reader.get_ref().set_read_timeout(Some(HANDSHAKE_TIMEOUT));
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

    fn handle(&mut self, request: Request) -> Flow {
        if let Err(e) = check_limits(&request, &self.limits) {
            let request_id = match &request {
                Request::Render(r) => {
                    bump(&self.shared.counters.renders_failed);
                    Some(r.request_id)
                }
                _ => None,
            };
            tracing::warn!(request = request.kind(), error = %e, "request refused");
            self.out.send(&protocol_error(&e, request_id));
            return Flow::Continue;
        }
        match request {
            Request::Hello { .. } => {
                self.out.send(&error_reply(
                    ErrorCode::InvalidInput,
                    "Hello: this session has already said Hello",
                    true,
                    None,
                ));
            }
            Request::MissingMeshes { hashes } => {
                let mut seen = HashSet::new();
                let missing: Vec<u64> = hashes
                    .into_iter()
                    .filter(|&h| seen.insert(h) && self.resolve(h).is_none())
                    .collect();
                self.out.send(&Reply::Missing { hashes: missing });
            }
            Request::UploadMesh(upload) => self.upload(&upload),
            Request::FrameUpdate(update) => self.frame_update(update),
            Request::CameraPath { frames } => {
                self.camera_path = frames;
                tracing::debug!(frames = self.camera_path.len(), "camera path");
                self.out.send(&Reply::Ack);
            }
            Request::Render(r) => self.render(r),
            Request::Cancel { request_id } => {
                if let Some(ctl) = lock(&self.controls).get(&request_id) {
                    ctl.cancel.store(true, Ordering::Relaxed);
                    tracing::info!(request_id, "cancel requested");
                }
                self.out.send(&Reply::Ack);
            }
            Request::Stats => {
                self.out
                    .send(&Reply::DaemonStats(self.shared.daemon_stats()));
            }
            Request::Close => {
                // The replies of renders already asked for come first.
                self.drain();
                self.out.send(&Reply::Ack);
                return Flow::End(End::Closed);
            }
            Request::Shutdown => {
                tracing::info!(client = %self.client, "shutdown requested");
                self.out.send(&Reply::Ack);
                self.shared.request_stop();
                return Flow::End(End::Stopped);
            }
        }
        Flow::Continue
    }

    /// The mesh with this hash from the working set or the cache; adds it to the working set.
    fn resolve(&mut self, hash: u64) -> Option<Arc<Mesh>> {
        let generation = self.generation;
        if let Some((mesh, touched)) = self.pins.get_mut(&hash) {
            *touched = generation;
            return Some(mesh.clone());
        }
        let mesh = self.shared.cache.get(hash)?;
        self.pins.insert(hash, (mesh.clone(), generation));
        Some(mesh)
    }

    fn upload(&mut self, upload: &UploadMesh) {
        match mesh_from_upload(upload, &self.limits) {
            Ok(mesh) => {
                let triangles = mesh.triangles.len() as u32;
                let mesh = self.shared.cache.insert(upload.hash, mesh);
                self.pins.insert(upload.hash, (mesh, self.generation));
                tracing::debug!(mesh = %upload.name, triangles, "mesh stored");
                self.out.send(&Reply::MeshStored {
                    hash: upload.hash,
                    triangles,
                });
            }
            Err(e) => {
                tracing::warn!(mesh = %upload.name, error = %e, "mesh refused");
                self.out.send(&e.to_reply());
            }
        }
    }

    /// The meshes of a frame by hash, from the working set or the cache, and the hashes found
    /// in neither (in order of first use).
    fn frame_meshes(&mut self, update: &FrameUpdate) -> (HashMap<u64, Arc<Mesh>>, Vec<u64>) {
        let mut found = HashMap::new();
        let mut missing = Vec::new();
        for o in &update.objects {
            let h = o.mesh_hash;
            if found.contains_key(&h) || missing.contains(&h) {
                continue;
            }
            match self.resolve(h) {
                Some(m) => {
                    found.insert(h, m);
                }
                None => missing.push(h),
            }
        }
        (found, missing)
    }

    fn frame_update(&mut self, update: FrameUpdate) {
        self.generation += 1;
        let (mut meshes, missing) = self.frame_meshes(&update);
        // Check everything but the missing meshes now, so the client hears of a bad camera or
        // light at once rather than at Render.
        for &h in &missing {
            meshes.insert(h, placeholder_mesh());
        }
        if let Err(e) = scene_from_frame(&update, &meshes) {
            tracing::warn!(frame = update.frame, error = %e, "frame refused");
            self.out.send(&e.to_reply());
            return;
        }
        // Keep meshes touched in this generation or the one before (uploads that came before
        // this update), drop the rest from the working set.
        let keep_from = self.generation.saturating_sub(1);
        self.pins.retain(|_, (_, touched)| *touched >= keep_from);
        let frame = update.frame;
        self.frames.retain(|f| f.frame != frame);
        self.frames.push_back(Arc::new(update));
        while self.frames.len() > FRAMES_KEPT {
            self.frames.pop_front();
        }
        tracing::debug!(frame, missing = missing.len(), "frame accepted");
        self.out.send(&Reply::FrameAccepted {
            frame,
            meshes_missing: missing,
        });
    }

    fn render(&mut self, r: antumbra_protocol::RenderRequest) {
        let request_id = r.request_id;
        let fail = |this: &Self, reply: Reply| {
            bump(&this.shared.counters.renders_failed);
            this.out.send(&reply);
        };
        let Some(update) = self
            .frames
            .iter()
            .rev()
            .find(|f| f.frame == r.frame)
            .cloned()
        else {
            let message = format!(
                "Render frame {} (request {request_id}): no FrameUpdate for frame {} in this \
                 session (it keeps the last {FRAMES_KEPT} frames sent)",
                r.frame, r.frame
            );
            tracing::warn!(frame = r.frame, request_id, "render of an unknown frame");
            return fail(
                self,
                error_reply(ErrorCode::InvalidInput, message, true, Some(request_id)),
            );
        };
        let settings = match render_settings(&r.settings) {
            Ok(s) => s,
            Err(e) => {
                tracing::warn!(request_id, error = %e, "render settings refused");
                return fail(self, protocol_error(&e, Some(request_id)));
            }
        };
        let (meshes, _) = self.frame_meshes(&update);
        let scene = match scene_from_frame(&update, &meshes) {
            Ok(s) => s,
            Err(e) => {
                tracing::warn!(request_id, error = %e, "render refused");
                return fail(self, protocol_error(&e, Some(request_id)));
            }
        };
        let ctl = Arc::new(RenderCtl {
            cancel: AtomicBool::new(false),
            started: AtomicBool::new(false),
        });
        let job = Job {
            request_id,
            scene,
            settings,
            passes: r.passes,
            ctl: ctl.clone(),
        };
        let tx = self.worker().tx.clone();
        lock(&self.controls).insert(request_id, ctl);
        match tx.try_send(job) {
            Ok(()) => {}
            Err(TrySendError::Full(job)) => {
                lock(&self.controls).remove(&job.request_id);
                fail(
                    self,
                    error_reply(
                        ErrorCode::Busy,
                        format!(
                            "Render frame {} (request {request_id}): this session already has \
                             {RENDER_QUEUE} renders waiting",
                            r.frame
                        ),
                        true,
                        Some(request_id),
                    ),
                );
            }
            Err(TrySendError::Disconnected(job)) => {
                lock(&self.controls).remove(&job.request_id);
                fail(
                    self,
                    error_reply(
                        ErrorCode::Internal,
                        "the session's render worker has stopped",
                        true,
                        Some(request_id),
                    ),
                );
            }
        }
    }

    fn worker(&mut self) -> &Worker {
        self.worker.get_or_insert_with(|| {
            let (tx, rx) = sync_channel(RENDER_QUEUE);
            let ctx = WorkerCtx {
                shared: self.shared.clone(),
                out: self.out.clone(),
                controls: self.controls.clone(),
                label: if self.client.is_empty() {
                    format!("session-{}", self.id)
                } else {
                    self.client.clone()
                },
            };
            let span = tracing::Span::current();
            let thread = std::thread::Builder::new()
                .name(format!("render-{}", self.id))
                .spawn(move || {
                    let _enter = span.enter();
                    ctx.run(rx)
                })
                .expect("spawning a render worker");
            Worker { tx, thread }
        })
    }

    /// Waits until every render asked for so far has replied.
    fn drain(&mut self) {
        if let Some(w) = self.worker.take() {
            drop(w.tx);
            let _ = w.thread.join();
        }
    }

    fn finish(&mut self, end: End) {
        match end {
            // The client is gone or the stream is unusable: nobody reads the results.
            End::Gone | End::BadFrame | End::Refused | End::Internal => {
                for ctl in lock(&self.controls).values() {
                    ctl.cancel.store(true, Ordering::Relaxed);
                }
            }
            // The daemon stops: the render under way finishes, the queued ones are cancelled.
            End::Stopped => {
                for ctl in lock(&self.controls).values() {
                    if !ctl.started.load(Ordering::Relaxed) {
                        ctl.cancel.store(true, Ordering::Relaxed);
                    }
                }
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

/// A one-triangle mesh standing in for missing meshes while a frame is checked.
fn placeholder_mesh() -> Arc<Mesh> {
    static MESH: OnceLock<Arc<Mesh>> = OnceLock::new();
    MESH.get_or_init(|| {
        Arc::new(Mesh::new(
            "placeholder",
            vec![
                [0.0, 0.0, 0.0].into(),
                [1.0, 0.0, 0.0].into(),
                [0.0, 1.0, 0.0].into(),
            ],
            vec![[0, 1, 2]],
        ))
    })
    .clone()
}

struct WorkerCtx {
    shared: Arc<Shared>,
    out: Arc<Out>,
    controls: Controls,
    label: String,
}

impl WorkerCtx {
    fn run(self, rx: Receiver<Job>) {
        let mut renderer = Renderer::new();
        for job in rx {
            self.render(&mut renderer, &job);
            let mut controls = lock(&self.controls);
            if controls
                .get(&job.request_id)
                .is_some_and(|c| Arc::ptr_eq(c, &job.ctl))
            {
                controls.remove(&job.request_id);
            }
        }
    }

    fn progress(&self, request_id: u64, stage: &str, done: u32, total: u32) {
        self.out.send(&Reply::Progress {
            request_id,
            stage: stage.into(),
            done,
            total,
        });
    }

    fn cancelled(&self, job: &Job, when: &str) {
        bump(&self.shared.counters.renders_cancelled);
        let why = if self.shared.stopping() {
            "the daemon is stopping"
        } else {
            "cancelled by the client"
        };
        tracing::info!(
            request_id = job.request_id,
            frame = job.scene.frame,
            when,
            "render cancelled"
        );
        self.out.send(&error_reply(
            ErrorCode::Cancelled,
            format!(
                "Render frame {} (request {}): {why}",
                job.scene.frame, job.request_id
            ),
            true,
            Some(job.request_id),
        ));
    }

    fn render(&self, renderer: &mut Renderer, job: &Job) {
        let id = job.request_id;
        let frame = job.scene.frame;
        if job.ctl.cancel.load(Ordering::Relaxed) {
            return self.cancelled(job, "before it started");
        }
        let acquired = self.shared.slots.acquire(&job.ctl.cancel, |position| {
            let total = position.try_into().unwrap_or(u32::MAX);
            self.progress(id, "queued", 0, total);
        });
        let slot = match acquired {
            crate::slots::Acquired::Slot(slot, _) => slot,
            crate::slots::Acquired::GaveUp => return self.cancelled(job, "while queued"),
        };
        job.ctl.started.store(true, Ordering::Relaxed);
        if job.ctl.cancel.load(Ordering::Relaxed) {
            return self.cancelled(job, "before it started");
        }
        self.progress(id, "render", 0, STAGES);
        let t0 = Instant::now();
        let result = catch_unwind(AssertUnwindSafe(|| {
            renderer.render(&self.label, &job.scene, &job.settings)
        }));
        drop(slot);
        let render_ms = t0.elapsed().as_secs_f64() * 1e3;
        let result = match result {
            Ok(Ok(r)) => r,
            Ok(Err(e)) => {
                bump(&self.shared.counters.renders_failed);
                let e = ProtocolError::InFrame { frame, error: e };
                tracing::warn!(request_id = id, error = %e, "render failed");
                self.out.send(&protocol_error(&e, Some(id)));
                return;
            }
            Err(_) => {
                // The renderer's cache may be half-updated: start afresh.
                *renderer = Renderer::new();
                bump(&self.shared.counters.renders_failed);
                tracing::error!(request_id = id, frame, "render panicked");
                self.out.send(&error_reply(
                    ErrorCode::Internal,
                    format!("Render frame {frame} (request {id}): internal error in the renderer"),
                    true,
                    Some(id),
                ));
                return;
            }
        };
        if job.ctl.cancel.load(Ordering::Relaxed) {
            return self.cancelled(job, "after rendering");
        }
        self.progress(id, "encode", 1, STAGES);
        let reply = Reply::FrameResult(frame_result_reply(&result, id, &job.passes));
        match encode_message_within(&reply, &self.out.limits) {
            Ok(bytes) => {
                drop(reply);
                if self.out.send_frame(&bytes) {
                    bump(&self.shared.counters.renders_done);
                    tracing::info!(
                        request_id = id,
                        frame,
                        width = result.width,
                        height = result.height,
                        render_ms,
                        bytes = bytes.len(),
                        "frame rendered"
                    );
                } else {
                    bump(&self.shared.counters.renders_cancelled);
                    tracing::info!(
                        request_id = id,
                        frame,
                        "frame rendered for a client that left"
                    );
                }
            }
            Err(e) => {
                bump(&self.shared.counters.renders_failed);
                tracing::warn!(request_id = id, error = %e, "result too large to send");
                self.out.send(&error_reply(
                    e.code(),
                    format!(
                        "Render frame {frame} (request {id}): the result is too large to send \
                         ({e}); ask for fewer passes or a smaller image"
                    ),
                    true,
                    Some(id),
                ));
            }
        }
    }
}
