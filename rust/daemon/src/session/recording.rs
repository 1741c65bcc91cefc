//! A session's recording (`--record DIR`): its requests as they arrive, and each mesh and alpha
//! image its frames use uploaded once, so the file replays on its own whatever the daemon
//! already held.

use antumbra_protocol::{upload_from_image, upload_from_mesh, RecordingWriter, Request};

use super::{recording_path, Session};

impl Session<'_> {
    pub(super) fn start_recording(&mut self) {
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

    /// Appends a request to the recording (a Hello without its token). A frame update comes
    /// after the meshes and images it uses that the daemon holds and the file lacks (an earlier
    /// session may have uploaded them). An upload is not written here: it is returned, to be
    /// recorded with [`record_upload`](Self::record_upload) once handled (a refused upload
    /// never is).
    pub(super) fn record(&mut self, request: &Request) -> Option<Upload> {
        self.recorder.as_ref()?;
        let result = match request {
            Request::Hello {
                version, client, ..
            } => self.append(&Request::Hello {
                version: *version,
                client: client.clone(),
                token: None,
            }),
            Request::UploadMesh(u) => return Some(Upload::Mesh(u.hash)),
            Request::UploadImage(u) => return Some(Upload::Image(u.hash)),
            Request::FrameUpdate(update) => {
                self.record_meshes(antumbra_protocol::frame_mesh_hashes(update));
                self.record_images(antumbra_protocol::frame_image_hashes(update));
                self.append(request)
            }
            other => self.append(other),
        };
        self.keep_or_stop(result);
        None
    }

    /// Records an upload of each of these meshes that the file lacks and the daemon holds (in
    /// the session's working set or the shared cache), so each mesh is in the file once.
    fn record_meshes(&mut self, hashes: impl IntoIterator<Item = u64>) {
        for hash in hashes {
            let Some(w) = &self.recorder else {
                return;
            };
            if w.has_mesh(hash) {
                continue;
            }
            if let Some(mesh) = self.state.held(hash) {
                let result = self.append(&Request::UploadMesh(upload_from_mesh(&mesh)));
                self.keep_or_stop(result);
            }
        }
    }

    /// Records an upload [`record`](Self::record) returned, from what the daemon now holds.
    pub(super) fn record_upload(&mut self, upload: Upload) {
        match upload {
            Upload::Mesh(hash) => self.record_meshes([hash]),
            Upload::Image(hash) => self.record_images([hash]),
        }
    }

    /// Records an upload of each of these alpha images that the file lacks and the daemon holds.
    fn record_images(&mut self, hashes: impl IntoIterator<Item = u64>) {
        for hash in hashes {
            let Some(w) = &self.recorder else {
                return;
            };
            if w.has_image(hash) {
                continue;
            }
            if let Some(image) = self.state.held_image(hash) {
                let result = self.append(&Request::UploadImage(upload_from_image(&image)));
                self.keep_or_stop(result);
            }
        }
    }

    fn append(&mut self, request: &Request) -> Result<(), String> {
        let Some(w) = &mut self.recorder else {
            return Ok(());
        };
        w.append(request)
            .map_err(|e| e.to_string())
            .and_then(|()| w.flush().map_err(|e| e.to_string()))
    }

    fn keep_or_stop(&mut self, result: Result<(), String>) {
        if let Err(e) = result {
            tracing::warn!(error = %e, "recording failed; stopping it");
            self.recorder = None;
        }
    }
}

/// An upload to record once the session has stored it.
pub(super) enum Upload {
    Mesh(u64),
    Image(u64),
}
