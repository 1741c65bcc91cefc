//! The in-process session: the same methods as the socket session, rendering with
//! antumbra-core in this process. It goes through the protocol's conversions exactly as the
//! daemon does (uploads through `mesh_from_upload`, frames through `scene_from_frame`, results
//! through `frame_result_reply`), so both sessions give the same images.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, TryLockError};
use std::time::Instant;

use antumbra_core::cancel::CancelToken;
use antumbra_core::render::Renderer;
use antumbra_core::scene::Mesh;
use antumbra_protocol::{
    admit_compare, admit_trade, check_limits, frame_result_reply, mesh_from_upload, missing_meshes,
    render_settings, scene_from_frame, upload_from_mesh, warm_up_reply, Asked, CameraState,
    CompareState, DaemonStats, ErrorCode, FrameUpdate, Limits, ProtocolError, Request, TradeState,
    COMPARE_STAGE, TRADE_STAGE,
};

/// The progress stages, as the daemon reports them: ("render", 0, 2), then ("encode", 1, 2).
const STAGES: u32 = 2;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};

use crate::arrays::mesh_from_arrays;
use crate::compare::{compare_reply_to_py, compare_request};
use crate::connection::check_progress;
use crate::error::{ClientError, ClientResult, IntoPyResult};
use crate::recording::Recorder;
use crate::result::{daemon_stats, frame_result_to_py, limits as limits_dict};
use crate::scene;
use crate::settings::RenderSettings;
use crate::trade::{trade_reply_to_py, trade_request};

struct LocalState {
    meshes: HashMap<u64, Arc<Mesh>>,
    frames: HashMap<i32, FrameUpdate>,
    cameras: BTreeMap<i32, CameraState>,
    renderer: Renderer,
    /// The comparison kept across `Compare` requests, as the daemon's session keeps it.
    comparison: CompareState,
    /// The trade kept across `Trade` requests, likewise.
    trade: TradeState,
    stats: DaemonStats,
    recorder: Option<Recorder>,
    closed: bool,
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
    /// Runs a `Compare` or `Trade` (`what`, reporting progress under `stage`) of a frame sent
    /// with frame_update, counted as the daemon counts it: `progress(stage, done, total)` and
    /// Ctrl-C are read between passes; returning False or raising cancels.
    #[allow(clippy::too_many_arguments)]
    fn measure<R: Send>(
        &self,
        py: Python<'_>,
        frame: i32,
        request_id: u64,
        (what, stage): (&str, &str),
        progress: Option<Bound<'_, PyAny>>,
        run: impl FnOnce(
                &mut LocalState,
                &antumbra_core::scene::Scene,
                &CancelToken,
                &mut (dyn FnMut(u32, u32) + Send),
            ) -> Result<R, ProtocolError>
            + Send,
    ) -> ClientResult<R> {
        let mut state = self.lock()?;
        let state = &mut *state;
        let update = state.frames.get(&frame).ok_or_else(|| {
            request_error(
                ErrorCode::InvalidInput,
                format!(
                    "{what} frame {frame} (request {request_id}): no FrameUpdate for frame \
                     {frame} in this session"
                ),
                request_id,
            )
        })?;
        let scene = scene_from_frame(update, &state.meshes).map_err(|e| {
            state.stats.renders_failed += 1;
            render_error(&e, request_id)
        })?;
        let callback = progress.map(Bound::unbind);
        let cancel = CancelToken::new();
        // The first exception of the callback or of Ctrl-C, raised once the frame ends.
        let mut raised: Option<PyErr> = None;
        let result = py.detach(|| {
            run(state, &scene, &cancel, &mut |done, total| {
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
        match result {
            Ok(reply) => {
                state.stats.renders_done += 1;
                Ok(reply)
            }
            Err(e) if e.code() == ErrorCode::Cancelled => {
                state.stats.renders_cancelled += 1;
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
                state.stats.renders_failed += 1;
                Err(render_error(&e, request_id))
            }
        }
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
        LocalSession {
            label: client_name,
            limits: Limits::default(),
            started: Instant::now(),
            state: Mutex::new(LocalState {
                meshes: HashMap::new(),
                frames: HashMap::new(),
                cameras: BTreeMap::new(),
                renderer: Renderer::new(),
                comparison: CompareState::new(),
                trade: TradeState::new(),
                stats: DaemonStats {
                    sessions: 1,
                    sessions_total: 1,
                    ..DaemonStats::default()
                },
                recorder: None,
                closed: false,
            }),
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
        (|| {
            let hashes = scene::hashes(hashes)?;
            check_limits(
                &Request::MissingMeshes {
                    hashes: hashes.clone(),
                },
                &self.limits,
            )
            .map_err(|e| ClientError::invalid(e.to_string()))?;
            let state = self.lock()?;
            let mut seen = HashSet::new();
            let mut out = Vec::new();
            for h in hashes {
                let in_file = !matches!(&state.recorder, Some(r) if !r.has_mesh(h));
                if (!state.meshes.contains_key(&h) || !in_file) && seen.insert(h) {
                    out.push(h);
                }
            }
            Ok(out)
        })()
        .py_result(py)
    }

    #[pyo3(signature = (name, positions, triangles, normals = None))]
    fn upload_mesh(
        &self,
        py: Python<'_>,
        name: &Bound<'_, PyAny>,
        positions: &Bound<'_, PyAny>,
        triangles: &Bound<'_, PyAny>,
        normals: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<u64> {
        (|| {
            let name = crate::mesh_name(name)?;
            let (mesh, hash) = mesh_from_arrays(py, &name, positions, triangles, normals, true)?;
            let request = Request::UploadMesh(py.detach(|| upload_from_mesh(&mesh)));
            drop(mesh);
            check_limits(&request, &self.limits)
                .map_err(|e| ClientError::invalid(e.to_string()))?;
            let Request::UploadMesh(upload) = &request else {
                unreachable!()
            };
            let mut state = self.lock()?;
            if !state.meshes.contains_key(&hash) {
                // As the daemon stores an upload.
                let mesh = py
                    .detach(|| mesh_from_upload(upload, &self.limits))
                    .map_err(|e| ClientError::local(&e))?;
                state.stats.meshes_cached += 1;
                state.stats.bytes_cached +=
                    (upload.positions.len() + upload.triangles.len()) as u64;
                state.meshes.insert(hash, Arc::new(mesh));
            }
            if let Some(rec) = state.recorder.as_mut() {
                rec.mesh(upload)?;
            }
            Ok(hash)
        })()
        .py_result(py)
    }

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
            let mut state = self.lock()?;
            let mut missing = missing_meshes(&update, &state.meshes);
            if let Some(rec) = state.recorder.as_mut() {
                let mut seen: HashSet<u64> = missing.iter().copied().collect();
                missing.extend(rec.missing(&update).into_iter().filter(|h| seen.insert(*h)));
                rec.frame(&update)?;
            }
            state.cameras.insert(update.frame, update.camera.clone());
            state.frames.insert(update.frame, update);
            Ok(missing)
        })()
        .py_result(py)
    }

    fn camera_path(&self, py: Python<'_>, frames: &Bound<'_, PyAny>) -> PyResult<()> {
        (|| {
            let frames = scene::camera_path(frames)?;
            let mut state = self.lock()?;
            if let Some(rec) = state.recorder.as_mut() {
                rec.camera_path(&Request::CameraPath {
                    frames: frames.clone(),
                })?;
            }
            state.cameras.extend(frames);
            Ok(())
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
            let update = state.frames.get(&frame).ok_or_else(|| {
                request_error(
                    ErrorCode::InvalidInput,
                    format!(
                        "Render frame {frame} (request {request_id}): no FrameUpdate for frame \
                         {frame} in this session"
                    ),
                    request_id,
                )
            })?;
            let settings =
                render_settings(&settings_state).map_err(|e| render_error(&e, request_id))?;
            let scene = scene_from_frame(update, &state.meshes).map_err(|e| {
                state.stats.renders_failed += 1;
                render_error(&e, request_id)
            })?;
            let stop = |v: Bound<'py, PyAny>| -> bool {
                v.is_instance_of::<PyBool>() && !v.is_truthy().unwrap_or(true)
            };
            if let Some(cb) = &progress {
                if stop(cb.call1(("render", 0u32, STAGES))?) {
                    state.stats.renders_cancelled += 1;
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
            let reply = py
                .detach(|| match warm_up {
                    true => renderer
                        .warm_up(&scene, &settings)
                        .map(|w| warm_up_reply(&w, request_id, &passes)),
                    false => renderer
                        .render(label, &scene, &settings)
                        .map(|r| frame_result_reply(&r, request_id, &passes)),
                })
                .map_err(|error| {
                    state.stats.renders_failed += 1;
                    render_error(&ProtocolError::InFrame { frame, error }, request_id)
                })?;
            if let Some(cb) = &progress {
                cb.call1(("encode", 1u32, STAGES))?;
            }
            state.stats.renders_done += 1;
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
            let reply = self.measure(
                py,
                frame,
                request_id,
                ("Compare", COMPARE_STAGE),
                progress,
                |state, scene, cancel, progress| {
                    // The daemon's admission, on the scene as this session holds it.
                    let what = format!("Compare frame {frame} (request {request_id})");
                    let asked = Asked {
                        what: &what,
                        scene,
                        frames: 1,
                    };
                    admit_compare(asked, &request.comparison()?, request.images, &self.limits)?;
                    let label = self.label.as_str();
                    state
                        .comparison
                        .frame(&request, label, scene, cancel, progress)
                },
            )?;
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
            let reply = self.measure(
                py,
                frame,
                request_id,
                ("Trade", TRADE_STAGE),
                progress,
                |state, scene, cancel, progress| {
                    let what = format!("Trade frame {frame} (request {request_id})");
                    let asked = Asked {
                        what: &what,
                        scene,
                        frames: 1,
                    };
                    admit_trade(asked, &request.trade()?, &self.limits)?;
                    let label = self.label.as_str();
                    state.trade.frame(&request, label, scene, cancel, progress)
                },
            )?;
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
            let mut s = state.stats.clone();
            s.uptime_s = self.started.elapsed().as_secs_f64();
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
            state.closed = true;
            state.meshes.clear();
            state.frames.clear();
            state.renderer = Renderer::new();
            state.comparison.clear();
            state.trade.clear();
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
