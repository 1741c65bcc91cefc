//! The socket session (`antumbra._native.Connection`): Python values in and out around the
//! protocol's one client, [`antumbra_protocol::client::Client`], waiting without the GIL.

mod connect;
mod wait;

use std::collections::HashSet;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard, TryLockError};
use std::time::Duration;

use antumbra_protocol::client::{Client, Sender};
use antumbra_protocol::{
    upload_from_image, upload_from_mesh, Limits, RenderRequest, Request, PROTOCOL_VERSION,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use self::connect::duration;
pub(crate) use self::wait::check_progress;
use self::wait::{call_progress, PyWait};

use crate::arrays::{image_from_array, mesh_from_arrays, MeshAlphaArgs};
use crate::compare::{compare_reply_to_py, compare_request};
use crate::error::{ClientError, ClientResult, IntoPyResult};
use crate::recording::Recorder;
use crate::result::{daemon_stats, frame_result_to_py, limits as limits_dict};
use crate::scene;
use crate::settings::RenderSettings;
use crate::trade::{trade_reply_to_py, trade_request};
use crate::uploads::{and_unrecorded, frame_missing, note_held, Kind, Upload};

/// What the session holds besides the client: the Python API's mesh bookkeeping and recording.
struct State {
    client: Client,
    /// Meshes the daemon confirmed it holds (MeshStored, or absent from a missing list).
    known: HashSet<u64>,
    /// Alpha images the daemon confirmed it holds, likewise.
    known_images: HashSet<u64>,
    recorder: Option<Recorder>,
}

/// A connection to the antumbra daemon (`antumbra._native.Connection`); use `antumbra.Client`.
#[pyclass(frozen, module = "antumbra._native")]
pub struct Connection {
    socket_path: String,
    server: String,
    limits: Limits,
    timeout: Option<Duration>,
    state: Mutex<Option<State>>,
    /// `cancel()` writes through this from another thread while the render's thread reads.
    sender: Sender,
    /// The request id of the render or comparison in progress (0: none).
    active_render: AtomicU64,
    next_id: AtomicU64,
}

impl State {
    fn known(&mut self, kind: Kind) -> &mut HashSet<u64> {
        match kind {
            Kind::Mesh => &mut self.known,
            Kind::Image => &mut self.known_images,
        }
    }

    /// Sends an upload, checks the hash the daemon stored it under (a mismatch is worded
    /// `"{stored} {hash}, this client computed ..."`) and notes it held; returns the upload as
    /// sent, for a recording.
    fn send(
        &mut self,
        wait: &mut PyWait<'_>,
        upload: Upload,
        hash: u64,
        stored: &str,
    ) -> ClientResult<Upload> {
        let (kind, sent) = match upload {
            Upload::Mesh(u) => {
                let sent = self.client.upload_mesh(wait, u);
                (Kind::Mesh, sent.map(|(u, h)| (Upload::Mesh(u), h)))
            }
            Upload::Image(u) => {
                let sent = self.client.upload_image(wait, u);
                (Kind::Image, sent.map(|(u, h)| (Upload::Image(u), h)))
            }
        };
        let (sent, stored_hash) = sent.map_err(|e| wait.error(e))?;
        if stored_hash != hash {
            let noun = if kind == Kind::Mesh { "mesh" } else { "image" };
            return Err(ClientError::Mismatch(format!(
                "{stored} {stored_hash:#018x}, this client computed {hash:#018x} (different \
                 {noun} hash functions?)"
            )));
        }
        self.known(kind).insert(hash);
        Ok(sent)
    }

    /// Writes an upload to the recording, if one is running.
    fn record(&mut self, upload: &Upload) -> ClientResult<()> {
        match self.recorder.as_mut() {
            Some(rec) => rec.upload(upload),
            None => Ok(()),
        }
    }
}

type Guard<'a> = MutexGuard<'a, Option<State>>;

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

    /// The open, usable session in `guard`.
    fn state<'g>(guard: &'g mut Guard<'_>) -> ClientResult<&'g mut State> {
        let state = guard
            .as_mut()
            .ok_or_else(|| ClientError::Lost("the client is closed".into()))?;
        state
            .client
            .usable()
            .map_err(|e| ClientError::Lost(e.to_string()))?;
        Ok(state)
    }

    /// Which of `hashes` the daemon lacks, noted in what it holds; while recording, those the
    /// file lacks too.
    fn missing(&self, py: Python<'_>, hashes: &Bound<'_, PyAny>, kind: Kind) -> PyResult<Vec<u64>> {
        let mut wait = PyWait::new(py);
        (|| {
            let hashes = scene::hashes(hashes)?;
            let mut guard = self.lock()?;
            let state = Self::state(&mut guard)?;
            let missing = match kind {
                Kind::Mesh => state.client.missing_meshes(&mut wait, hashes.clone()),
                Kind::Image => state.client.missing_images(&mut wait, hashes.clone()),
            }
            .map_err(|e| wait.error(e))?;
            note_held(state.known(kind), hashes.iter().copied(), &missing);
            Ok(and_unrecorded(
                missing,
                hashes,
                state.recorder.as_ref(),
                kind,
            ))
        })()
        .py_result(py)
    }

    fn close_inner(&self, py: Python<'_>, request: Option<Request>) -> ClientResult<()> {
        let mut wait = PyWait::new(py);
        let mut guard = self.lock()?;
        let mut result = Ok(());
        if let (Some(state), Some(request)) = (guard.as_mut(), request) {
            if state.client.usable().is_ok() {
                result = state
                    .client
                    .ack(&mut wait, &request)
                    .map_err(|e| wait.error(e));
            }
        }
        if let Some(mut state) = guard.take() {
            if let Some(rec) = state.recorder.take() {
                result = result.and(rec.finish().map(|_| ()));
            }
            state.client.disconnect();
        }
        result
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

    /// The protocol version of the session (the daemon's Welcome must match this client's).
    #[getter]
    fn protocol_version(&self) -> u32 {
        PROTOCOL_VERSION
    }

    /// Bytes sent to the daemon so far (every request, framing included).
    #[getter]
    fn bytes_sent(&self, py: Python<'_>) -> PyResult<u64> {
        (|| {
            let mut guard = self.lock()?;
            Ok(Self::state(&mut guard)?.client.bytes_sent())
        })()
        .py_result(py)
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

    /// Which of these mesh hashes the daemon lacks (and, while recording, the file).
    fn missing_meshes(&self, py: Python<'_>, hashes: &Bound<'_, PyAny>) -> PyResult<Vec<u64>> {
        self.missing(py, hashes, Kind::Mesh)
    }

    /// Which of these alpha image hashes the daemon lacks (and, while recording, the file).
    fn missing_images(&self, py: Python<'_>, hashes: &Bound<'_, PyAny>) -> PyResult<Vec<u64>> {
        self.missing(py, hashes, Kind::Image)
    }

    /// Hashes and checks an alpha image; uploads it unless the daemon holds it already (asked
    /// once per hash). Returns its content hash, which `alpha_materials`' "image" names.
    fn upload_image(&self, py: Python<'_>, texels: &Bound<'_, PyAny>) -> PyResult<u64> {
        let mut wait = PyWait::new(py);
        (|| {
            let (image, hash) = image_from_array(py, texels, self.limits.max_image_texels)?;
            let mut guard = self.lock()?;
            let state = Self::state(&mut guard)?;
            let recording = state
                .recorder
                .as_ref()
                .is_some_and(|r| !r.has(Kind::Image, hash));
            let held = state.known_images.contains(&hash)
                || state
                    .client
                    .missing_images(&mut wait, vec![hash])
                    .map_err(|e| wait.error(e))?
                    .is_empty();
            if held && !recording {
                state.known_images.insert(hash);
                return Ok(hash);
            }
            let mut upload = Upload::Image(py.detach(|| upload_from_image(&image)));
            drop(image);
            if !held {
                upload = state.send(&mut wait, upload, hash, "the daemon stored image hash")?;
            }
            state.known_images.insert(hash);
            state.record(&upload)?;
            Ok(hash)
        })()
        .py_result(py)
    }

    /// Hashes, checks and uploads a mesh; returns its content hash.
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
        let mut wait = PyWait::new(py);
        (|| {
            let name = crate::mesh_name(name)?;
            let alpha = MeshAlphaArgs {
                material_slots,
                uv_maps,
            };
            let (mesh, hash) =
                mesh_from_arrays(py, &name, positions, triangles, normals, alpha, true)?;
            let upload = py.detach(|| upload_from_mesh(&mesh));
            drop(mesh);
            let request = Request::UploadMesh(upload);
            antumbra_protocol::check_limits(&request, &self.limits)
                .map_err(|e| ClientError::invalid(e.to_string()))?;
            let Request::UploadMesh(upload) = request else {
                unreachable!("built above")
            };
            let mut upload = Upload::Mesh(upload);
            let mut guard = self.lock()?;
            let state = Self::state(&mut guard)?;
            // While recording, a mesh the daemon already holds goes to the file only.
            if !(state.recorder.is_some() && state.known.contains(&hash)) {
                let stored = format!("mesh '{name}': the daemon stored hash");
                upload = state.send(&mut wait, upload, hash, &stored)?;
            }
            state.record(&upload)?;
            Ok(hash)
        })()
        .py_result(py)
    }

    /// Sends a frame's scene state; returns the hashes of the meshes and of the alpha images
    /// it uses that the daemon lacks (upload them before rendering).
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
        let mut wait = PyWait::new(py);
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
            let mut guard = self.lock()?;
            let state = Self::state(&mut guard)?;
            let (update, missing) = state
                .client
                .frame_update(&mut wait, update)
                .map_err(|e| wait.error(e))?;
            note_held(
                &mut state.known,
                Kind::Mesh.in_frame(&update),
                &missing.meshes,
            );
            note_held(
                &mut state.known_images,
                Kind::Image.in_frame(&update),
                &missing.images,
            );
            frame_missing(
                state.recorder.as_mut(),
                &update,
                missing.meshes,
                missing.images,
            )
        })()
        .py_result(py)
    }

    /// Renders a frame sent with frame_update; returns a dict that `antumbra.Result` wraps. A
    /// progress callback that raises (or returns False) and Ctrl-C cancel the render; its last
    /// reply is still read so the session stays in step, then the exception is raised.
    /// `warm_up`: only the session's state (`RenderRequest::warm_up`): no images, no rows.
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
        let mut wait = PyWait::new(py);
        (|| {
            let frame = scene::frame_number(frame, "frame")?;
            let settings = settings.state.clone();
            antumbra_protocol::check_limits(
                &Request::Render(RenderRequest {
                    frame,
                    settings: settings.clone(),
                    passes: Default::default(),
                    request_id: 0,
                    warm_up: false,
                }),
                &self.limits,
            )
            .map_err(|e| ClientError::invalid(e.to_string()))?;
            let passes = scene::passes(passes)?;
            let between_replies = duration(timeout, "timeout")?;
            check_progress(progress.as_ref())?;
            let mut guard = self.lock()?;
            let state = Self::state(&mut guard)?;
            let request_id = self.next_id.fetch_add(1, Ordering::SeqCst);
            let request = Request::Render(RenderRequest {
                frame,
                settings,
                passes,
                request_id,
                warm_up,
            });
            state
                .client
                .send_with(&mut wait, &request)
                .map_err(|e| wait.error(e))?;
            self.active_render.store(request_id, Ordering::SeqCst);
            let result = state.client.finish_render_with(
                &mut wait,
                request_id,
                &format!("the result of Render frame {frame}"),
                between_replies,
                |wait, stage, done, total| {
                    call_progress(progress.as_ref(), wait, stage, done, total)
                },
            );
            self.active_render.store(0, Ordering::SeqCst);
            let result = result.map_err(|e| wait.error(e))?;
            frame_result_to_py(py, result)
        })()
        .py_result(py)
    }

    /// Renders a frame sent with frame_update with every method (see `compare::compare_request`
    /// for `methods`); returns `compare::compare_reply_to_py`'s dict, with each method's heat
    /// plane when `images`. `timeout`: seconds to wait between two replies (None: no limit).
    /// `progress` and Ctrl-C act as in `render`.
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
        let mut wait = PyWait::new(py);
        (|| {
            let frame = scene::frame_number(frame, "frame")?;
            let within = duration(timeout, "timeout")?;
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
            antumbra_protocol::check_limits(&Request::Compare(request.clone()), &self.limits)
                .map_err(|e| ClientError::invalid(e.to_string()))?;
            let mut guard = self.lock()?;
            let state = Self::state(&mut guard)?;
            let request_id = self.next_id.fetch_add(1, Ordering::SeqCst);
            request.request_id = request_id;
            self.active_render.store(request_id, Ordering::SeqCst);
            let reply = state.client.compare_with(
                &mut wait,
                request,
                within,
                |wait, stage, done, total| {
                    call_progress(progress.as_ref(), wait, stage, done, total)
                },
            );
            self.active_render.store(0, Ordering::SeqCst);
            let reply = reply.map_err(|e| wait.error(e))?;
            compare_reply_to_py(py, &asked, baseline, reply)
        })()
        .py_result(py)
    }

    /// Sweeps a frame sent with frame_update over every knob (see `trade::trade_request` for
    /// `knobs`); returns `trade::trade_reply_to_py`'s dict. `timeout`, `progress` and Ctrl-C
    /// act as in `compare`.
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
        let mut wait = PyWait::new(py);
        (|| {
            let frame = scene::frame_number(frame, "frame")?;
            let within = duration(timeout, "timeout")?;
            check_progress(progress.as_ref())?;
            let mut request = trade_request(frame, knobs, scene::repeat_count(repeat)?, settings)?;
            let asked = request.clone();
            antumbra_protocol::check_limits(&Request::Trade(request.clone()), &self.limits)
                .map_err(|e| ClientError::invalid(e.to_string()))?;
            let mut guard = self.lock()?;
            let state = Self::state(&mut guard)?;
            let request_id = self.next_id.fetch_add(1, Ordering::SeqCst);
            request.request_id = request_id;
            self.active_render.store(request_id, Ordering::SeqCst);
            let reply =
                state
                    .client
                    .trade_with(&mut wait, request, within, |wait, stage, done, total| {
                        call_progress(progress.as_ref(), wait, stage, done, total)
                    });
            self.active_render.store(0, Ordering::SeqCst);
            let reply = reply.map_err(|e| wait.error(e))?;
            trade_reply_to_py(py, &asked, reply)
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
        py.detach(|| self.sender.cancel(active))
            .map_err(|e| PyWait::new(py).error(e))
            .py_result(py)?;
        Ok(true)
    }

    /// The daemon's statistics.
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let mut wait = PyWait::new(py);
        (|| {
            let mut guard = self.lock()?;
            let state = Self::state(&mut guard)?;
            let stats = state.client.stats(&mut wait).map_err(|e| wait.error(e))?;
            Ok(daemon_stats(py, &stats)?)
        })()
        .py_result(py)
    }

    /// Starts writing the session's uploads and frames to a recording (`.antrec`). While
    /// recording, meshes the file lacks are reported as missing so that the caller uploads them
    /// (a mesh the daemon already holds then goes to the file only).
    fn start_recording(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        (|| {
            let mut guard = self.lock()?;
            let state = Self::state(&mut guard)?;
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

    /// Stops the recording; returns (frames written, frames left out because their meshes were
    /// never uploaded).
    fn stop_recording(&self, py: Python<'_>) -> PyResult<(usize, usize)> {
        (|| {
            let mut guard = self.lock()?;
            let state = guard
                .as_mut()
                .ok_or_else(|| ClientError::Lost("the client is closed".into()))?;
            match state.recorder.take() {
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
