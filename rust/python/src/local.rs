//! The in-process session: the same methods as the socket session, answered by the daemon's
//! own session logic (`antumbra_session`: the same `SessionState` handler for meshes, frames
//! and admission, the same `SessionRenderer` for renders, comparisons and trades) run in this
//! process, so both sessions give the same replies. The client-side checks are the socket
//! client's; what this file adds is the Python face (progress callbacks, Ctrl-C, statistics).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, TryLockError};
use std::time::Instant;

use antumbra_core::cancel::CancelToken;
use antumbra_protocol::{
    check_limits, upload_from_image, upload_from_mesh, DaemonStats, ErrorCode, Limits,
    ProtocolError, RenderRequest, Reply, Request,
};
use antumbra_session::{
    Handled, Job, MeshCache, SessionRenderer, SessionState, ENCODE_STAGE, RENDER_STAGE,
    RENDER_STAGES,
};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};

use crate::arrays::{image_from_array, mesh_from_arrays, MeshAlphaArgs};
use crate::compare::{compare_reply_to_py, compare_request};
use crate::connection::check_progress;
use crate::error::{ClientError, ClientResult, IntoPyResult};
use crate::recording::Recorder;
use crate::result::{daemon_stats, frame_result_to_py, limits as limits_dict};
use crate::scene;
use crate::settings::RenderSettings;
use crate::trade::{trade_reply_to_py, trade_request};
use crate::uploads::{and_unrecorded, frame_missing, Kind, Upload};

/// Renders counted as the daemon counts them (`DaemonStats`).
#[derive(Default)]
struct Counts {
    done: u64,
    cancelled: u64,
    failed: u64,
}

struct LocalState {
    /// The session's meshes (a cache of its own that keeps every mesh: nothing else shares it).
    cache: Arc<MeshCache>,
    /// The daemon's session state over that cache: meshes, frames, admission.
    session: SessionState,
    /// The daemon's job runner: renderer, comparison and trade kept across requests.
    renderer: SessionRenderer,
    counts: Counts,
    recorder: Option<Recorder>,
    closed: bool,
}

impl LocalState {
    fn new(limits: &Limits) -> Self {
        let cache = Arc::new(MeshCache::new(u64::MAX));
        LocalState {
            session: SessionState::new(cache.clone(), limits.clone()),
            cache,
            renderer: SessionRenderer::new(),
            counts: Counts::default(),
            recorder: None,
            closed: false,
        }
    }

    /// Answers `request` with the daemon's session state; a job or a control is not expected
    /// here (callers send only what answers at once).
    fn answer(&mut self, request: Request) -> ClientResult<Reply> {
        match self.session.handle(request) {
            Handled::Reply(reply @ Reply::Error { .. }) => Err(ClientError::local(reply)),
            Handled::Reply(reply) => Ok(reply),
            Handled::Refused(_) | Handled::Job(_) | Handled::Control(_) => wrong_reply(),
        }
    }

    /// Stores an upload in the session (decoded and checked without the GIL) and writes it to
    /// the recording, if one is running.
    fn store(&mut self, py: Python<'_>, upload: Upload) -> ClientResult<()> {
        let recorded = self.recorder.is_some().then(|| upload.clone());
        let session = &mut self.session;
        match py.detach(|| session.handle(upload.into_request())) {
            Handled::Reply(Reply::MeshStored { .. } | Reply::ImageStored { .. }) => {}
            Handled::Reply(reply @ Reply::Error { .. }) => return Err(ClientError::local(reply)),
            _ => return wrong_reply(),
        }
        match (self.recorder.as_mut(), recorded) {
            (Some(rec), Some(upload)) => rec.upload(&upload),
            _ => Ok(()),
        }
    }

    /// Admits a `Render`, `Compare` or `Trade` as the daemon does; a refusal counts as a failed
    /// render.
    fn admit(&mut self, request: Request) -> ClientResult<Job> {
        match self.session.handle(request) {
            Handled::Job(job) => Ok(*job),
            Handled::Refused(reply) | Handled::Reply(reply) => {
                self.counts.failed += 1;
                Err(ClientError::local(reply))
            }
            Handled::Control(_) => wrong_reply(),
        }
    }
}

/// A reply of the wrong kind for its request (a bug, reported rather than panicking).
fn wrong_reply<T>() -> ClientResult<T> {
    Err(ClientError::Request {
        code: ErrorCode::Internal,
        message: "the session answered a request with the wrong kind of reply".into(),
        session_usable: true,
        request_id: None,
        daemon: false,
    })
}

/// Renders in this process with the daemon's code path (`antumbra._native.LocalSession`); use
/// `antumbra.LocalSession`.
#[pyclass(frozen, module = "antumbra._native")]
pub struct LocalSession {
    /// The `scene` column of the statistics (the daemon uses the client's name).
    label: String,
    limits: Limits,
    started: Instant,
    state: Mutex<LocalState>,
    next_id: AtomicU64,
}

fn request_error(code: ErrorCode, message: String, request_id: u64) -> ClientError {
    ClientError::Request {
        code,
        message,
        session_usable: true,
        request_id: Some(request_id),
        daemon: false,
    }
}

/// A protocol error that ends a render, as the daemon reports it.
fn render_error(e: &ProtocolError, request_id: u64) -> ClientError {
    request_error(e.code(), e.to_string(), request_id)
}

impl LocalSession {
    /// Runs a `Compare` or `Trade` admitted by the session, counted as the daemon counts it:
    /// `progress(stage, done, total)` and Ctrl-C are read between passes; returning False or
    /// raising cancels.
    fn measure(
        &self,
        py: Python<'_>,
        request: Request,
        progress: Option<Bound<'_, PyAny>>,
    ) -> ClientResult<Reply> {
        let mut state = self.lock()?;
        let state = &mut *state;
        let job = state.admit(request)?;
        let stage = job.stage();
        let callback = progress.map(Bound::unbind);
        let cancel = CancelToken::new();
        // The first exception of the callback or of Ctrl-C, raised once the frame ends.
        let mut raised: Option<PyErr> = None;
        let renderer = &mut state.renderer;
        let label = self.label.as_str();
        let result = py.detach(|| {
            renderer.run(&job, label, &cancel, &mut |done, total| {
                if cancel.is_cancelled() {
                    return;
                }
                Python::attach(|py| {
                    let go_on = py.check_signals().and_then(|()| match &callback {
                        None => Ok(true),
                        Some(cb) => {
                            let v = cb.bind(py).call1((stage, done, total))?;
                            Ok(!v.is_instance_of::<PyBool>() || v.is_truthy()?)
                        }
                    });
                    match go_on {
                        Ok(true) => {}
                        Ok(false) => cancel.cancel(),
                        Err(e) => {
                            raised = Some(e);
                            cancel.cancel();
                        }
                    }
                })
            })
        });
        let (what, frame, request_id) = (job.what(), job.frame(), job.request_id);
        match result {
            Ok(done) => {
                state.counts.done += 1;
                Ok(done.into_reply(&job))
            }
            Err(e) if e.code() == ErrorCode::Cancelled => {
                state.counts.cancelled += 1;
                Err(match raised {
                    Some(e) => ClientError::Py(e),
                    None => request_error(
                        ErrorCode::Cancelled,
                        format!(
                            "{what} frame {frame} (request {request_id}): cancelled by the client"
                        ),
                        request_id,
                    ),
                })
            }
            Err(e) => {
                state.counts.failed += 1;
                Err(render_error(&e, request_id))
            }
        }
    }

    /// Which of `hashes` the session lacks; while recording, those the file lacks too, as the
    /// socket session asks.
    fn missing(&self, py: Python<'_>, hashes: &Bound<'_, PyAny>, kind: Kind) -> PyResult<Vec<u64>> {
        (|| {
            let hashes = scene::hashes(hashes)?;
            let request = kind.missing_request(hashes.clone());
            check_limits(&request, &self.limits)
                .map_err(|e| ClientError::invalid(e.to_string()))?;
            let mut state = self.lock()?;
            let Reply::Missing { hashes: lacking } = state.answer(request)? else {
                return wrong_reply();
            };
            Ok(and_unrecorded(
                lacking,
                hashes,
                state.recorder.as_ref(),
                kind,
            ))
        })()
        .py_result(py)
    }

    fn lock(&self) -> ClientResult<MutexGuard<'_, LocalState>> {
        let guard = match self.state.try_lock() {
            Ok(g) => g,
            Err(TryLockError::WouldBlock) => {
                return Err(ClientError::Busy(
                    "another thread is using this session (a render in progress?)".into(),
                ))
            }
            Err(TryLockError::Poisoned(p)) => p.into_inner(),
        };
        if guard.closed {
            return Err(ClientError::Lost("the session is closed".into()));
        }
        Ok(guard)
    }
}

#[pymethods]
impl LocalSession {
    #[new]
    #[pyo3(signature = (client_name = "antumbra-python".to_string()))]
    fn new(client_name: String) -> Self {
        let limits = Limits::default();
        LocalSession {
            label: client_name,
            state: Mutex::new(LocalState::new(&limits)),
            limits,
            started: Instant::now(),
            next_id: AtomicU64::new(1),
        }
    }

    /// The limits the in-process session applies (the daemon's defaults).
    #[getter]
    fn limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        limits_dict(py, &self.limits)
    }

    #[getter]
    fn closed(&self) -> bool {
        match self.state.try_lock() {
            Ok(g) => g.closed,
            Err(_) => false,
        }
    }

    /// Always None: in-process renders cannot be cancelled.
    #[getter]
    fn active_request(&self) -> Option<u64> {
        None
    }

    fn missing_meshes(&self, py: Python<'_>, hashes: &Bound<'_, PyAny>) -> PyResult<Vec<u64>> {
        self.missing(py, hashes, Kind::Mesh)
    }

    fn missing_images(&self, py: Python<'_>, hashes: &Bound<'_, PyAny>) -> PyResult<Vec<u64>> {
        self.missing(py, hashes, Kind::Image)
    }

    /// As the socket session's: stores the image unless the session holds it already.
    fn upload_image(&self, py: Python<'_>, texels: &Bound<'_, PyAny>) -> PyResult<u64> {
        (|| {
            let (image, hash) = image_from_array(py, texels, self.limits.max_image_texels)?;
            let mut state = self.lock()?;
            let state = &mut *state;
            let recording = state
                .recorder
                .as_ref()
                .is_some_and(|r| !r.has(Kind::Image, hash));
            if state.cache.contains_image(hash) && !recording {
                return Ok(hash);
            }
            let upload = Upload::Image(py.detach(|| upload_from_image(&image)));
            drop(image);
            state.store(py, upload)?;
            Ok(hash)
        })()
        .py_result(py)
    }

    #[pyo3(signature = (name, positions, triangles, normals = None, material_slots = None, uv_maps = None))]
    #[allow(clippy::too_many_arguments)] // the Python method's arguments
    fn upload_mesh(
        &self,
        py: Python<'_>,
        name: &Bound<'_, PyAny>,
        positions: &Bound<'_, PyAny>,
        triangles: &Bound<'_, PyAny>,
        normals: Option<&Bound<'_, PyAny>>,
        material_slots: Option<&Bound<'_, PyAny>>,
        uv_maps: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<u64> {
        (|| {
            let name = crate::mesh_name(name)?;
            let alpha = MeshAlphaArgs {
                material_slots,
                uv_maps,
            };
            let (mesh, hash) =
                mesh_from_arrays(py, &name, positions, triangles, normals, alpha, true)?;
            let request = Request::UploadMesh(py.detach(|| upload_from_mesh(&mesh)));
            drop(mesh);
            check_limits(&request, &self.limits)
                .map_err(|e| ClientError::invalid(e.to_string()))?;
            let Request::UploadMesh(upload) = request else {
                unreachable!("built above")
            };
            self.lock()?.store(py, Upload::Mesh(upload))?;
            Ok(hash)
        })()
        .py_result(py)
    }

    #[pyo3(signature = (frame, objects, camera, lights, resolution, instances = None, alpha_materials = None))]
    #[allow(clippy::too_many_arguments)] // the Python method's arguments
    fn frame_update(
        &self,
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
        objects: &Bound<'_, PyAny>,
        camera: &Bound<'_, PyAny>,
        lights: &Bound<'_, PyAny>,
        resolution: &Bound<'_, PyAny>,
        instances: Option<&Bound<'_, PyAny>>,
        alpha_materials: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<(Vec<u64>, Vec<u64>)> {
        (|| {
            let update = scene::frame_update(
                frame,
                objects,
                camera,
                lights,
                resolution,
                instances,
                alpha_materials,
                &self.limits,
            )?;
            scene::check_frame(&update, &self.limits)?;
            let mut state = self.lock()?;
            let Reply::FrameAccepted {
                meshes_missing: missing,
                images_missing: images,
                ..
            } = state.answer(Request::FrameUpdate(update.clone()))?
            else {
                return wrong_reply();
            };
            frame_missing(state.recorder.as_mut(), &update, missing, images)
        })()
        .py_result(py)
    }

    /// Renders a frame sent with frame_update. `progress` is called as the daemon reports:
    /// ("render", 0, 2) before rendering, ("encode", 1, 2) after; returning False from the
    /// first call cancels.
    #[pyo3(signature = (frame, settings, passes, progress = None, timeout = None, warm_up = false))]
    #[allow(clippy::too_many_arguments)] // the Python method's keyword arguments
    fn render<'py>(
        &self,
        py: Python<'py>,
        frame: &Bound<'py, PyAny>,
        settings: &RenderSettings,
        passes: &Bound<'py, PyAny>,
        progress: Option<Bound<'py, PyAny>>,
        timeout: Option<f64>,
        warm_up: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let _ = timeout;
        (|| {
            let frame = scene::frame_number(frame, "frame")?;
            let settings_state = settings.state.clone();
            let passes = scene::passes(passes)?;
            if let Some(p) = &progress {
                if !p.is_callable() {
                    return Err(ClientError::invalid(
                        "progress: expected a callable progress(stage, done, total) or None",
                    ));
                }
            }
            let request_id = self.next_id.fetch_add(1, Ordering::SeqCst);
            let mut state = self.lock()?;
            let state = &mut *state;
            let job = state.admit(Request::Render(RenderRequest {
                frame,
                settings: settings_state,
                passes,
                request_id,
                warm_up,
            }))?;
            let stop = |v: Bound<'py, PyAny>| -> bool {
                v.is_instance_of::<PyBool>() && !v.is_truthy().unwrap_or(true)
            };
            if let Some(cb) = &progress {
                if stop(cb.call1((RENDER_STAGE, 0u32, RENDER_STAGES))?) {
                    state.counts.cancelled += 1;
                    return Err(request_error(
                        ErrorCode::Cancelled,
                        format!(
                            "Render frame {frame} (request {request_id}): cancelled by the client"
                        ),
                        request_id,
                    ));
                }
            }
            let renderer = &mut state.renderer;
            let label = self.label.as_str();
            let done = py
                .detach(|| renderer.run(&job, label, &CancelToken::new(), &mut |_, _| {}))
                .map_err(|e| {
                    state.counts.failed += 1;
                    render_error(&e, request_id)
                })?;
            if let Some(cb) = &progress {
                cb.call1((ENCODE_STAGE, 1u32, RENDER_STAGES))?;
            }
            state.counts.done += 1;
            let Reply::FrameResult(reply) = done.into_reply(&job) else {
                return wrong_reply();
            };
            frame_result_to_py(py, reply)
        })()
        .py_result(py)
    }

    /// Renders a frame sent with frame_update with every method through the daemon's
    /// `CompareState`; returns what `Connection.compare` does (each method's heat plane when
    /// `images`). `progress(stage, done, total)` is called as the daemon reports; returning
    /// False or raising cancels between method passes, as does Ctrl-C. `timeout` is accepted
    /// and unused, as in `render`.
    #[pyo3(signature = (frame, methods = None, baseline = None, repeat = None, settings = None, timeout = None, images = false, progress = None, warm_up = false))]
    #[allow(clippy::too_many_arguments)] // the Python method's keyword arguments
    fn compare<'py>(
        &self,
        py: Python<'py>,
        frame: &Bound<'py, PyAny>,
        methods: Option<&Bound<'py, PyAny>>,
        baseline: Option<String>,
        repeat: Option<&Bound<'py, PyAny>>,
        settings: Option<&Bound<'py, PyDict>>,
        timeout: Option<f64>,
        images: bool,
        progress: Option<Bound<'py, PyAny>>,
        warm_up: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let _ = timeout;
        (|| {
            let frame = scene::frame_number(frame, "frame")?;
            check_progress(progress.as_ref())?;
            let (mut request, baseline) = compare_request(
                frame,
                methods,
                baseline,
                scene::repeat_count(repeat)?,
                settings,
                images,
            )?;
            request.warm_up = warm_up;
            let asked = request.clone();
            check_limits(&Request::Compare(request.clone()), &self.limits)
                .map_err(|e| ClientError::invalid(e.to_string()))?;
            let request_id = self.next_id.fetch_add(1, Ordering::SeqCst);
            request.request_id = request_id;
            let Reply::CompareResult(reply) =
                self.measure(py, Request::Compare(request), progress)?
            else {
                return wrong_reply();
            };
            compare_reply_to_py(py, &asked, baseline, reply)
        })()
        .py_result(py)
    }

    /// Sweeps a frame sent with frame_update over every knob (see `trade::trade_request` for
    /// `knobs`) through the daemon's `TradeState`; returns what `Connection.trade` does.
    /// `progress` and `timeout` act as in `compare`.
    #[pyo3(signature = (frame, knobs = None, repeat = None, settings = None, timeout = None, progress = None))]
    #[allow(clippy::too_many_arguments)] // the Python method's keyword arguments
    fn trade<'py>(
        &self,
        py: Python<'py>,
        frame: &Bound<'py, PyAny>,
        knobs: Option<&Bound<'py, PyAny>>,
        repeat: Option<&Bound<'py, PyAny>>,
        settings: Option<&Bound<'py, PyDict>>,
        timeout: Option<f64>,
        progress: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let _ = timeout;
        (|| {
            let frame = scene::frame_number(frame, "frame")?;
            check_progress(progress.as_ref())?;
            let mut request = trade_request(frame, knobs, scene::repeat_count(repeat)?, settings)?;
            check_limits(&Request::Trade(request.clone()), &self.limits)
                .map_err(|e| ClientError::invalid(e.to_string()))?;
            let request_id = self.next_id.fetch_add(1, Ordering::SeqCst);
            request.request_id = request_id;
            let Reply::TradeResult(reply) =
                self.measure(py, Request::Trade(request.clone()), progress)?
            else {
                return wrong_reply();
            };
            trade_reply_to_py(py, &request, reply)
        })()
        .py_result(py)
    }

    /// In-process renders cannot be cancelled mid-way; always False.
    #[pyo3(signature = (request_id = None))]
    fn cancel(&self, request_id: Option<u64>) -> bool {
        let _ = request_id;
        false
    }

    /// Statistics in the daemon's form.
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        (|| {
            let state = self.lock()?;
            let cache = state.cache.stats();
            let s = DaemonStats {
                sessions: 1,
                sessions_total: 1,
                meshes_cached: cache.meshes,
                bytes_cached: cache.bytes,
                renders_done: state.counts.done,
                renders_cancelled: state.counts.cancelled,
                renders_failed: state.counts.failed,
                uptime_s: self.started.elapsed().as_secs_f64(),
                meshes_evicted: cache.evicted,
                images_cached: cache.images,
                images_evicted: cache.images_evicted,
            };
            Ok(daemon_stats(py, &s)?)
        })()
        .py_result(py)
    }

    fn start_recording(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        (|| {
            let mut state = self.lock()?;
            if state.recorder.is_some() {
                return Err(ClientError::invalid(
                    "start_recording: a recording is already running; stop_recording() first",
                ));
            }
            state.recorder = Some(Recorder::create(&path.to_string_lossy())?);
            Ok(())
        })()
        .py_result(py)
    }

    fn stop_recording(&self, py: Python<'_>) -> PyResult<(usize, usize)> {
        (|| {
            let mut state = self.lock()?;
            match state.recorder.take() {
                Some(r) => r.finish(),
                None => Err(ClientError::invalid(
                    "stop_recording: no recording is running",
                )),
            }
        })()
        .py_result(py)
    }

    /// Frees the meshes and the renderer's state; closing twice is allowed.
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        (|| {
            let mut state = match self.state.try_lock() {
                Ok(g) => g,
                Err(TryLockError::Poisoned(p)) => p.into_inner(),
                Err(TryLockError::WouldBlock) => {
                    return Err(ClientError::Busy(
                        "another thread is using this session".into(),
                    ))
                }
            };
            if let Some(r) = state.recorder.take() {
                r.finish()?;
            }
            *state = LocalState::new(&self.limits);
            state.closed = true;
            Ok(())
        })()
        .py_result(py)
    }

    /// Same as close() (there is no daemon to stop).
    fn shutdown(&self, py: Python<'_>) -> PyResult<()> {
        self.close(py)
    }

    fn __repr__(&self) -> String {
        format!(
            "<antumbra._native.LocalSession{}>",
            if self.closed() { " closed" } else { "" }
        )
    }
}
