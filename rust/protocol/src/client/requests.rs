//! The client's requests, each with the replies it expects: meshes, frames, renders, statistics.

use std::collections::HashSet;
use std::time::{Duration, Instant};

use antumbra_core::scene::Scene;

use super::{Blocking, Client, ClientError, Interrupt, Wait};
use crate::instances::changed_since;
use crate::{
    frame_update_from_scene, upload_from_image, upload_from_mesh, CompareRequest,
    CompareResultReply, DaemonStats, FrameResultReply, FrameUpdate, NamedSettings, Passes,
    RenderRequest, Reply, Request, TradeRequest, TradeResultReply, UploadImage, UploadMesh,
};

/// How long to wait for a cancelled render to end after the caller interrupted the wait.
const CANCEL_DRAIN: Duration = Duration::from_secs(30);

/// What sending a scene cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneSent {
    pub meshes_uploaded: usize,
    pub images_uploaded: usize,
    /// Bytes of `UploadMesh` and `UploadImage` frames sent.
    pub upload_bytes: u64,
    /// All bytes sent for the scene (questions, uploads, the frame update).
    pub bytes: u64,
}

/// What an accepted frame uses that the daemon lacks (`FrameAccepted`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Missing {
    pub meshes: Vec<u64>,
    pub images: Vec<u64>,
}

/// A rendered frame and the progress stages seen before it.
#[derive(Clone, Debug)]
pub struct Rendered {
    pub result: FrameResultReply,
    pub stages: Vec<String>,
}

impl Client {
    /// Which of these meshes the daemon lacks.
    pub fn missing_meshes(
        &mut self,
        wait: &mut impl Wait,
        hashes: Vec<u64>,
    ) -> Result<Vec<u64>, ClientError> {
        match self.request(wait, &Request::MissingMeshes { hashes })? {
            Reply::Missing { hashes } => Ok(hashes),
            other => Err(self.unexpected("MissingMeshes", &other)),
        }
    }

    /// Uploads a mesh; returns the upload (for a recording) and the hash the daemon stored it
    /// under.
    pub fn upload_mesh(
        &mut self,
        wait: &mut impl Wait,
        upload: UploadMesh,
    ) -> Result<(UploadMesh, u64), ClientError> {
        let request = Request::UploadMesh(upload);
        let reply = self.request(wait, &request)?;
        let Request::UploadMesh(upload) = request else {
            unreachable!("built above")
        };
        match reply {
            Reply::MeshStored { hash, .. } => Ok((upload, hash)),
            other => Err(self.unexpected("UploadMesh", &other)),
        }
    }

    /// Which of these alpha images the daemon lacks.
    pub fn missing_images(
        &mut self,
        wait: &mut impl Wait,
        hashes: Vec<u64>,
    ) -> Result<Vec<u64>, ClientError> {
        match self.request(wait, &Request::MissingImages { hashes })? {
            Reply::Missing { hashes } => Ok(hashes),
            other => Err(self.unexpected("MissingImages", &other)),
        }
    }

    /// Uploads an alpha image; returns the upload (for a recording) and the hash the daemon
    /// stored it under.
    pub fn upload_image(
        &mut self,
        wait: &mut impl Wait,
        upload: UploadImage,
    ) -> Result<(UploadImage, u64), ClientError> {
        let request = Request::UploadImage(upload);
        let reply = self.request(wait, &request)?;
        let Request::UploadImage(upload) = request else {
            unreachable!("built above")
        };
        match reply {
            Reply::ImageStored { hash } => Ok((upload, hash)),
            other => Err(self.unexpected("UploadImage", &other)),
        }
    }

    /// Sends a frame's state, its instance arrays that equal the last accepted frame's as
    /// `unchanged`; returns the whole update (for a recording) and what it uses that the daemon
    /// lacks.
    pub fn frame_update(
        &mut self,
        wait: &mut impl Wait,
        update: FrameUpdate,
    ) -> Result<(FrameUpdate, Missing), ClientError> {
        let request = Request::FrameUpdate(changed_since(&update, self.accepted.as_ref()));
        let reply = self.request(wait, &request)?;
        match reply {
            Reply::FrameAccepted {
                meshes_missing,
                images_missing,
                frame,
            } if frame == update.frame => {
                // Only the arrays are compared later; the rest is not kept.
                self.accepted = Some(FrameUpdate {
                    objects: Vec::new(),
                    lights: Vec::new(),
                    alpha_materials: Vec::new(),
                    ..update.clone()
                });
                let missing = Missing {
                    meshes: meshes_missing,
                    images: images_missing,
                };
                Ok((update, missing))
            }
            other => Err(self.unexpected("FrameUpdate", &other)),
        }
    }

    /// The daemon's statistics.
    pub fn stats(&mut self, wait: &mut impl Wait) -> Result<DaemonStats, ClientError> {
        match self.request(wait, &Request::Stats)? {
            Reply::DaemonStats(s) => Ok(s),
            other => Err(self.unexpected("Stats", &other)),
        }
    }

    /// Renders a frame sent before with every method of `request`, waiting at most `within`
    /// between two replies (None: for ever); its `Progress` replies are read and dropped.
    /// Interrupting the wait cancels the comparison as [`finish_render_with`] does.
    ///
    /// [`finish_render_with`]: Self::finish_render_with
    pub fn compare(
        &mut self,
        wait: &mut impl Wait,
        request: CompareRequest,
        within: Option<Duration>,
    ) -> Result<CompareResultReply, ClientError> {
        self.compare_with(wait, request, within, |_, _, _, _| Ok(true))
    }

    /// As [`compare`](Self::compare), with `progress` seeing each stage (`queued`, then
    /// [`COMPARE_STAGE`](crate::COMPARE_STAGE) with method passes done of all) and able to
    /// cancel, as in [`finish_render_with`](Self::finish_render_with).
    pub fn compare_with<W: Wait>(
        &mut self,
        wait: &mut W,
        request: CompareRequest,
        between_replies: Option<Duration>,
        progress: impl FnMut(&mut W, &str, u32, u32) -> Result<bool, Interrupt>,
    ) -> Result<CompareResultReply, ClientError> {
        let request_id = request.request_id;
        let frame = request.frame;
        self.send_with(wait, &Request::Compare(request))?;
        self.finish_with(
            wait,
            request_id,
            ("Compare", &format!("the result of Compare frame {frame}")),
            between_replies,
            progress,
            |reply| match reply {
                Reply::CompareResult(r) if r.request_id == request_id => Ok(r),
                other => Err(other),
            },
        )
    }

    /// As [`compare_with`](Self::compare_with), for a `Trade`: `progress` sees `queued`, then
    /// [`TRADE_STAGE`](crate::TRADE_STAGE) with passes done of all.
    pub fn trade_with<W: Wait>(
        &mut self,
        wait: &mut W,
        request: TradeRequest,
        between_replies: Option<Duration>,
        progress: impl FnMut(&mut W, &str, u32, u32) -> Result<bool, Interrupt>,
    ) -> Result<TradeResultReply, ClientError> {
        let request_id = request.request_id;
        let frame = request.frame;
        self.send_with(wait, &Request::Trade(request))?;
        self.finish_with(
            wait,
            request_id,
            ("Trade", &format!("the result of Trade frame {frame}")),
            between_replies,
            progress,
            |reply| match reply {
                Reply::TradeResult(r) if r.request_id == request_id => Ok(r),
                other => Err(other),
            },
        )
    }

    /// Sends one frame's scene: asks which meshes are missing, uploads those, then sends the
    /// `FrameUpdate` (which must come back with nothing missing).
    pub fn send_scene(&mut self, scene: &Scene) -> Result<SceneSent, ClientError> {
        let wait = &mut Blocking;
        let start = self.bytes_sent();
        let update = frame_update_from_scene(scene)?;
        let mut seen = HashSet::new();
        let hashes: Vec<u64> = update
            .objects
            .iter()
            .map(|o| o.mesh_hash)
            .filter(|h| seen.insert(*h))
            .collect();
        let mut sent = SceneSent::default();
        for h in self.missing_meshes(wait, hashes)? {
            let Some(mesh) = scene.meshes.iter().find(|m| m.content_hash() == h) else {
                return Err(ClientError::Mismatch(format!(
                    "the daemon asked for mesh {h:#x}, which the scene does not have"
                )));
            };
            let before = self.bytes_sent();
            self.upload_mesh(wait, upload_from_mesh(mesh))?;
            sent.meshes_uploaded += 1;
            sent.upload_bytes += self.bytes_sent() - before;
        }
        let images: Vec<u64> = {
            let mut seen = HashSet::new();
            crate::frame_image_hashes(&update)
                .filter(|h| seen.insert(*h))
                .collect()
        };
        if !images.is_empty() {
            for h in self.missing_images(wait, images)? {
                let Some(image) = scene.alpha.images.iter().find(|i| i.content_hash() == h) else {
                    return Err(ClientError::Mismatch(format!(
                        "the daemon asked for image {h:#x}, which the scene does not have"
                    )));
                };
                let before = self.bytes_sent();
                self.upload_image(wait, upload_from_image(image))?;
                sent.images_uploaded += 1;
                sent.upload_bytes += self.bytes_sent() - before;
            }
        }
        let (_, missing) = self.frame_update(wait, update)?;
        if !missing.meshes.is_empty() || !missing.images.is_empty() {
            return Err(ClientError::Mismatch(format!(
                "still missing after upload: meshes {:x?}, images {:x?}",
                missing.meshes, missing.images
            )));
        }
        sent.bytes = self.bytes_sent() - start;
        Ok(sent)
    }

    /// Renders a frame sent before; reads `Progress` replies until the result.
    pub fn render(
        &mut self,
        frame: i32,
        settings: NamedSettings,
        passes: Passes,
        request_id: u64,
    ) -> Result<Rendered, ClientError> {
        self.send(&Request::Render(RenderRequest {
            frame,
            settings,
            passes,
            request_id,
            warm_up: false,
        }))?;
        self.finish_render(request_id)
    }

    /// Warms the session up on a frame sent before (`RenderRequest::warm_up`): its trees and
    /// visible set, no shadow ray; the result has no images and no rows (the visible set when
    /// `passes` asks for it).
    pub fn warm_up(
        &mut self,
        frame: i32,
        settings: NamedSettings,
        passes: Passes,
        request_id: u64,
    ) -> Result<Rendered, ClientError> {
        self.send(&Request::Render(RenderRequest {
            frame,
            settings,
            passes,
            request_id,
            warm_up: true,
        }))?;
        self.finish_render(request_id)
    }

    /// Reads the replies of render `request_id` up to its result or error, each within the
    /// client's timeout.
    pub fn finish_render(&mut self, request_id: u64) -> Result<Rendered, ClientError> {
        let mut stages = Vec::new();
        let timeout = self.timeout();
        let result = self.finish_render_with(
            &mut Blocking,
            request_id,
            &format!("the result of render request {request_id}"),
            timeout,
            |_, stage, _, _| {
                stages.push(stage.to_string());
                Ok(true)
            },
        )?;
        Ok(Rendered { result, stages })
    }

    fn cancel(&self, wait: &mut impl Wait, request_id: u64) -> Result<(), ClientError> {
        let sender = &self.sender;
        wait.block(|| sender.cancel(request_id))
    }

    /// Reads render `request_id`'s replies until its result or error, waiting at most
    /// `between_replies` for each. `progress(wait, stage, done, total)` sees each stage and
    /// returns false to cancel the render, or [`Interrupt`] to cancel it and fail. A cancelled
    /// render's last reply is still read so the session stays in step; after an interrupted
    /// wait (Ctrl-C) that is bounded by [`CANCEL_DRAIN`], and a second interrupt gives up at
    /// once (the session then cannot be used). The first interruption is the error returned.
    pub fn finish_render_with<W: Wait>(
        &mut self,
        wait: &mut W,
        request_id: u64,
        waiting_for: &str,
        between_replies: Option<Duration>,
        progress: impl FnMut(&mut W, &str, u32, u32) -> Result<bool, Interrupt>,
    ) -> Result<FrameResultReply, ClientError> {
        self.finish_with(
            wait,
            request_id,
            ("Render", waiting_for),
            between_replies,
            progress,
            |reply| match reply {
                Reply::FrameResult(r) if r.request_id == request_id => Ok(r),
                other => Err(other),
            },
        )
    }

    /// The reading loop of a render or a comparison (`what`: the request's name, and what the
    /// caller waits for); `result` picks the request's own result out of a reply.
    fn finish_with<W: Wait, T>(
        &mut self,
        wait: &mut W,
        request_id: u64,
        (what, waiting_for): (&str, &str),
        between_replies: Option<Duration>,
        mut progress: impl FnMut(&mut W, &str, u32, u32) -> Result<bool, Interrupt>,
        result: impl Fn(Reply) -> Result<T, Reply>,
    ) -> Result<T, ClientError> {
        let interrupted = || ClientError::Interrupted {
            waiting_for: waiting_for.into(),
        };
        let mut abort: Option<ClientError> = None;
        let mut drain_until: Option<Instant> = None;
        loop {
            let deadline = match (drain_until, between_replies) {
                (Some(d), _) => Some(d),
                (None, Some(t)) => Some(Instant::now() + t),
                (None, None) => None,
            };
            let reply = match self.recv_within(wait, waiting_for, deadline) {
                Ok(r) => r,
                Err(e @ ClientError::Interrupted { .. }) if abort.is_none() => {
                    // Ctrl-C: cancel, then wait for the render to end.
                    self.broken = None;
                    self.cancel(wait, request_id)?;
                    abort = Some(e);
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
                    let go_on = progress(wait, &stage, done, total).unwrap_or_else(|Interrupt| {
                        abort = Some(interrupted());
                        false
                    });
                    if !go_on {
                        self.cancel(wait, request_id)?;
                    }
                }
                Reply::Error {
                    request_id: Some(id),
                    ..
                } if id != request_id => return Err(self.unexpected(what, &reply)),
                Reply::Error { .. } => {
                    let e = self.error_of(reply).expect_err("an Error reply");
                    return Err(abort.unwrap_or(e));
                }
                other => match result(other) {
                    Ok(r) => return abort.map_or(Ok(r), Err),
                    Err(other) => return Err(self.unexpected(what, &other)),
                },
            }
        }
    }
}
