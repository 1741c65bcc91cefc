//! What a session holds between requests, and the one handler that answers them: its meshes
//! (a working set over a [`MeshCache`] that other sessions may share), its latest frames, and
//! the admission of renders, comparisons and trades into [`Job`]s.

use std::collections::{HashMap, HashSet, VecDeque};
use std::sync::{Arc, OnceLock};

use antumbra_core::alpha::AlphaImage;
use antumbra_core::scene::{Mesh, Scene};
use antumbra_protocol::{
    admit_compare, admit_render, admit_trade, check_frame_limits, check_limits, frame_image_hashes,
    frame_mesh_hashes, image_from_upload, image_label, instances::resolve_unchanged,
    mesh_from_upload, render_settings, reply_planes, scene_from_frame, Asked, CompareRequest,
    ErrorCode, FrameUpdate, Limits, ProtocolError, RenderRequest, Reply, Request, TradeRequest,
    UploadImage, UploadMesh,
};

use crate::cache::MeshCache;
use crate::job::{Job, JobKind};
use crate::reply::{error_reply, protocol_error};

/// Frame descriptions a session keeps for `Render` (the most recently updated ones).
pub const FRAMES_KEPT: usize = 8;

/// How [`SessionState::handle`] answered a request.
pub enum Handled {
    /// Answered at once: `Missing`, `MeshStored`, `ImageStored`, `FrameAccepted`, or an `Error`.
    Reply(Reply),
    /// A `Render`, `Compare` or `Trade` admitted: to run on the session's
    /// [`crate::SessionRenderer`].
    Job(Box<Job>),
    /// A `Render`, `Compare` or `Trade` refused before any work (a failed render): the `Error`.
    Refused(Reply),
    /// What the connection answers itself, being about the connection or the daemon.
    Control(Control),
}

/// The requests a session's state does not answer: its server does.
pub enum Control {
    Cancel { request_id: u64 },
    Stats,
    Close,
    Shutdown,
}

pub struct SessionState {
    cache: Arc<MeshCache>,
    limits: Limits,
    /// Frame updates seen (the generation of the session's mesh working set).
    generation: u64,
    /// The session's working set: meshes it uploaded, asked about or used recently, with the
    /// generation in which it last touched them. Holding the `Arc` keeps them out of eviction.
    pins: HashMap<u64, (Arc<Mesh>, u64)>,
    /// The alpha images of the working set, kept as meshes are.
    image_pins: HashMap<u64, (Arc<AlphaImage>, u64)>,
    frames: VecDeque<Arc<FrameUpdate>>,
}

impl SessionState {
    pub fn new(cache: Arc<MeshCache>, limits: Limits) -> Self {
        SessionState {
            cache,
            limits,
            generation: 0,
            pins: HashMap::new(),
            image_pins: HashMap::new(),
            frames: VecDeque::new(),
        }
    }

    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// The mesh with this hash if the session or its cache holds it (without touching it).
    pub fn held(&self, hash: u64) -> Option<Arc<Mesh>> {
        match self.pins.get(&hash) {
            Some((mesh, _)) => Some(mesh.clone()),
            None => self.cache.get(hash),
        }
    }

    /// The alpha image with this hash if the session or its cache holds it (without touching it).
    pub fn held_image(&self, hash: u64) -> Option<Arc<AlphaImage>> {
        match self.image_pins.get(&hash) {
            Some((image, _)) => Some(image.clone()),
            None => self.cache.image(hash),
        }
    }

    /// Answers `request` (checked against the limits first).
    pub fn handle(&mut self, request: Request) -> Handled {
        let request_id = match &request {
            Request::Render(r) => Some(r.request_id),
            Request::Compare(c) => Some(c.request_id),
            Request::Trade(t) => Some(t.request_id),
            _ => None,
        };
        if let Err(e) = check_limits(&request, &self.limits) {
            tracing::warn!(request = request.kind(), error = %e, "request refused");
            let reply = protocol_error(&e, request_id);
            return match request_id {
                Some(_) => Handled::Refused(reply),
                None => Handled::Reply(reply),
            };
        }
        let admitted = match request {
            Request::Hello { .. } => {
                return Handled::Reply(error_reply(
                    ErrorCode::InvalidInput,
                    "Hello: this session has already said Hello",
                    true,
                    None,
                ))
            }
            Request::MissingMeshes { hashes } => return Handled::Reply(self.missing(hashes)),
            Request::UploadMesh(upload) => return Handled::Reply(self.upload(&upload)),
            Request::MissingImages { hashes } => {
                return Handled::Reply(self.missing_images(hashes))
            }
            Request::UploadImage(upload) => return Handled::Reply(self.upload_image(&upload)),
            Request::FrameUpdate(update) => return Handled::Reply(self.frame_update(update)),
            Request::Render(r) => self.render(r),
            Request::Compare(c) => self.compare(c),
            Request::Trade(t) => self.trade(t),
            Request::Cancel { request_id } => {
                return Handled::Control(Control::Cancel { request_id })
            }
            Request::Stats => return Handled::Control(Control::Stats),
            Request::Close => return Handled::Control(Control::Close),
            Request::Shutdown => return Handled::Control(Control::Shutdown),
        };
        match admitted {
            Ok(job) => Handled::Job(Box::new(job)),
            Err(reply) => Handled::Refused(reply),
        }
    }

    /// The mesh with this hash from the working set or the cache; adds it to the working set.
    fn resolve(&mut self, hash: u64) -> Option<Arc<Mesh>> {
        let generation = self.generation;
        if let Some((mesh, touched)) = self.pins.get_mut(&hash) {
            *touched = generation;
            return Some(mesh.clone());
        }
        let mesh = self.cache.get(hash)?;
        self.pins.insert(hash, (mesh.clone(), generation));
        Some(mesh)
    }

    /// The alpha image with this hash from the working set or the cache; adds it to the set.
    fn resolve_image(&mut self, hash: u64) -> Option<Arc<AlphaImage>> {
        let generation = self.generation;
        if let Some((image, touched)) = self.image_pins.get_mut(&hash) {
            *touched = generation;
            return Some(image.clone());
        }
        let image = self.cache.image(hash)?;
        self.image_pins.insert(hash, (image.clone(), generation));
        Some(image)
    }

    fn missing_images(&mut self, hashes: Vec<u64>) -> Reply {
        let mut seen = HashSet::new();
        let hashes = hashes
            .into_iter()
            .filter(|&h| seen.insert(h) && self.resolve_image(h).is_none())
            .collect();
        Reply::Missing { hashes }
    }

    fn upload_image(&mut self, upload: &UploadImage) -> Reply {
        match image_from_upload(upload, &self.limits) {
            Ok(image) => {
                let (width, height) = (image.width, image.height);
                let image = self.cache.insert_image(upload.hash, image);
                self.image_pins
                    .insert(upload.hash, (image, self.generation));
                tracing::debug!(image = %image_label(upload.hash), width, height, "image stored");
                Reply::ImageStored { hash: upload.hash }
            }
            Err(e) => {
                tracing::warn!(image = %image_label(upload.hash), error = %e, "image refused");
                e.to_reply()
            }
        }
    }

    /// The alpha images of a frame by hash, and the hashes the session lacks (first use order).
    fn frame_images(&mut self, update: &FrameUpdate) -> (HashMap<u64, Arc<AlphaImage>>, Vec<u64>) {
        let mut found = HashMap::new();
        let mut missing = Vec::new();
        for h in frame_image_hashes(update) {
            if found.contains_key(&h) || missing.contains(&h) {
                continue;
            }
            match self.resolve_image(h) {
                Some(i) => {
                    found.insert(h, i);
                }
                None => missing.push(h),
            }
        }
        (found, missing)
    }

    fn missing(&mut self, hashes: Vec<u64>) -> Reply {
        let mut seen = HashSet::new();
        let hashes = hashes
            .into_iter()
            .filter(|&h| seen.insert(h) && self.resolve(h).is_none())
            .collect();
        Reply::Missing { hashes }
    }

    fn upload(&mut self, upload: &UploadMesh) -> Reply {
        match mesh_from_upload(upload, &self.limits) {
            Ok(mesh) => {
                let triangles = mesh.triangles.len() as u32;
                let mesh = self.cache.insert(upload.hash, mesh);
                self.pins.insert(upload.hash, (mesh, self.generation));
                tracing::debug!(mesh = %upload.name, triangles, "mesh stored");
                Reply::MeshStored {
                    hash: upload.hash,
                    triangles,
                }
            }
            Err(e) => {
                tracing::warn!(mesh = %upload.name, error = %e, "mesh refused");
                e.to_reply()
            }
        }
    }

    /// The meshes of a frame by hash, from the working set or the cache, and the hashes found
    /// in neither (in order of first use).
    fn frame_meshes(&mut self, update: &FrameUpdate) -> (HashMap<u64, Arc<Mesh>>, Vec<u64>) {
        let mut found = HashMap::new();
        let mut missing = Vec::new();
        for h in frame_mesh_hashes(update) {
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

    fn frame_update(&mut self, mut update: FrameUpdate) -> Reply {
        // Arrays sent as unchanged repeat the last frame accepted; the kept frame is whole.
        let resolved = resolve_unchanged(&mut update, self.frames.back().map(|f| &**f))
            .and_then(|()| check_frame_limits(&update, &self.limits));
        if let Err(e) = resolved {
            tracing::warn!(frame = update.frame, error = %e, "frame refused");
            return e.to_reply();
        }
        self.generation += 1;
        let (mut meshes, missing) = self.frame_meshes(&update);
        // Check everything but the missing meshes now, so the client hears of a bad camera or
        // light at once rather than at Render.
        for &h in &missing {
            meshes.insert(h, placeholder_mesh());
        }
        let (mut images, images_missing) = self.frame_images(&update);
        for &h in &images_missing {
            images.insert(h, placeholder_image());
        }
        if let Err(e) = scene_from_frame(&update, &(&meshes, &images)) {
            tracing::warn!(frame = update.frame, error = %e, "frame refused");
            return e.to_reply();
        }
        // Keep meshes touched in this generation or the one before (uploads that came before
        // this update), drop the rest from the working set.
        let keep_from = self.generation.saturating_sub(1);
        self.pins.retain(|_, (_, touched)| *touched >= keep_from);
        self.image_pins
            .retain(|_, (_, touched)| *touched >= keep_from);
        let frame = update.frame;
        self.frames.retain(|f| f.frame != frame);
        self.frames.push_back(Arc::new(update));
        while self.frames.len() > FRAMES_KEPT {
            self.frames.pop_front();
        }
        tracing::debug!(
            frame,
            missing = missing.len(),
            images_missing = images_missing.len(),
            "frame accepted"
        );
        Reply::FrameAccepted {
            frame,
            meshes_missing: missing,
            images_missing,
        }
    }

    /// The scene of `frame` for request `what` (`Render frame 3 (request 7)`): an error reply
    /// names a frame never sent (or no longer kept) and what the scene lacks.
    fn scene(&mut self, frame: i32, what: &str, request_id: u64) -> Result<Scene, Reply> {
        let Some(update) = self.frames.iter().rev().find(|f| f.frame == frame).cloned() else {
            tracing::warn!(frame, request_id, "{what}: unknown frame");
            let message = format!(
                "{what}: no FrameUpdate for frame {frame} in this session (it keeps the last \
                 {FRAMES_KEPT} frames sent)"
            );
            return Err(error_reply(
                ErrorCode::InvalidInput,
                message,
                true,
                Some(request_id),
            ));
        };
        let (meshes, _) = self.frame_meshes(&update);
        let (images, _) = self.frame_images(&update);
        scene_from_frame(&update, &(&meshes, &images)).map_err(|e| refused(what, &e, request_id))
    }

    fn render(&mut self, r: RenderRequest) -> Result<Job, Reply> {
        let request_id = r.request_id;
        let what = format!("Render frame {} (request {request_id})", r.frame);
        let scene = self.scene(r.frame, &what, request_id)?;
        let settings = render_settings(&r.settings).map_err(|e| refused(&what, &e, request_id))?;
        let planes = reply_planes(&r.passes, &scene, &settings);
        admit_render(self.asked(&what, &scene), &settings, planes, &self.limits)
            .map_err(|e| refused(&what, &e, request_id))?;
        Ok(Job {
            request_id,
            scene,
            kind: JobKind::Render {
                settings,
                passes: r.passes,
                warm_up: r.warm_up,
            },
        })
    }

    fn compare(&mut self, c: CompareRequest) -> Result<Job, Reply> {
        let request_id = c.request_id;
        let what = format!("Compare frame {} (request {request_id})", c.frame);
        let scene = self.scene(c.frame, &what, request_id)?;
        // Built here only to check the methods and size the work; the renderer keeps its own.
        let admitted = c.comparison().and_then(|comparison| {
            admit_compare(
                self.asked(&what, &scene),
                &comparison,
                c.images,
                &self.limits,
            )
        });
        admitted.map_err(|e| refused(&what, &e, request_id))?;
        Ok(Job {
            request_id,
            scene,
            kind: JobKind::Compare(c),
        })
    }

    fn trade(&mut self, t: TradeRequest) -> Result<Job, Reply> {
        let request_id = t.request_id;
        let what = format!("Trade frame {} (request {request_id})", t.frame);
        let scene = self.scene(t.frame, &what, request_id)?;
        let admitted = t
            .trade()
            .and_then(|trade| admit_trade(self.asked(&what, &scene), &trade, &self.limits));
        admitted.map_err(|e| refused(&what, &e, request_id))?;
        Ok(Job {
            request_id,
            scene,
            kind: JobKind::Trade(t),
        })
    }

    fn asked<'a>(&self, what: &'a str, scene: &'a Scene) -> Asked<'a> {
        Asked {
            what,
            scene,
            frames: 1,
        }
    }
}

/// The error reply of a request refused before any work.
fn refused(what: &str, e: &ProtocolError, request_id: u64) -> Reply {
    tracing::warn!(request_id, error = %e, "{what} refused");
    protocol_error(e, Some(request_id))
}

/// A one-texel image standing in for missing images while a frame is checked.
fn placeholder_image() -> Arc<AlphaImage> {
    static IMAGE: OnceLock<Arc<AlphaImage>> = OnceLock::new();
    IMAGE
        .get_or_init(|| {
            Arc::new(AlphaImage {
                width: 1,
                height: 1,
                texels: vec![1.0],
            })
        })
        .clone()
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
