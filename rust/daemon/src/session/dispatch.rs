//! Answering a session's requests: the mesh working set, frame updates, and renders handed to the
//! session's render worker.

use std::collections::{HashMap, HashSet};
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::TrySendError;
use std::sync::{Arc, OnceLock};

use antumbra_core::cancel::CancelToken;
use antumbra_core::scene::Mesh;
use antumbra_protocol::{
    admit_render, check_limits, mesh_from_upload, render_settings, reply_planes, scene_from_frame,
    Asked, ErrorCode, FrameUpdate, Reply, Request, UploadMesh,
};

use super::out::{error_reply, protocol_error};
use super::worker::{Job, JobKind, RenderCtl, RENDER_QUEUE};
use super::{End, Flow, Session, FRAMES_KEPT};
use crate::shared::bump;

impl Session<'_> {
    pub(super) fn handle(&mut self, request: Request) -> Flow {
        if let Err(e) = check_limits(&request, &self.limits) {
            let request_id = match &request {
                Request::Render(r) => {
                    bump(&self.shared.counters.renders_failed);
                    Some(r.request_id)
                }
                Request::Compare(c) => {
                    bump(&self.shared.counters.renders_failed);
                    Some(c.request_id)
                }
                Request::Trade(t) => {
                    bump(&self.shared.counters.renders_failed);
                    Some(t.request_id)
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
            Request::Render(r) => self.render(r),
            Request::Compare(c) => self.compare(c),
            Request::Trade(t) => self.trade(t),
            Request::Cancel { request_id } => {
                let requests = self.controls.cancel(request_id);
                if requests > 0 {
                    tracing::info!(request_id, requests, "cancel requested");
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
    pub(super) fn frame_meshes(
        &mut self,
        update: &FrameUpdate,
    ) -> (HashMap<u64, Arc<Mesh>>, Vec<u64>) {
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
        let planes = reply_planes(&r.passes, &scene, &settings);
        let what = format!("Render frame {} (request {request_id})", r.frame);
        let asked = Asked {
            what: &what,
            scene: &scene,
            frames: 1,
        };
        if let Err(e) = admit_render(asked, &settings, planes, &self.limits) {
            tracing::warn!(request_id, error = %e, "render refused");
            return fail(self, protocol_error(&e, Some(request_id)));
        }
        let ctl = Arc::new(RenderCtl {
            cancel: CancelToken::new(),
            started: AtomicBool::new(false),
        });
        let job = Job {
            request_id,
            scene,
            settings,
            passes: r.passes,
            warm_up: r.warm_up,
            ctl: ctl.clone(),
            kind: JobKind::Render,
        };
        let tx = self.worker().tx.clone();
        self.controls.add(request_id, ctl);
        match tx.try_send(job) {
            Ok(()) => {}
            Err(TrySendError::Full(job)) => {
                self.controls.remove(job.request_id, &job.ctl);
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
                self.controls.remove(job.request_id, &job.ctl);
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
