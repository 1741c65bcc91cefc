//! A session's recording (`--record DIR`): its requests as they arrive, and each mesh its frames
//! use uploaded once, so the file replays on its own whatever the daemon already held.

use antumbra_protocol::{upload_from_mesh, RecordingWriter, Request};

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
    /// after the meshes it uses that the daemon holds and the file lacks (an earlier session may
    /// have uploaded them). An upload is not written here: its hash is returned, to be recorded
    /// with [`record_meshes`](Self::record_meshes) once handled (a refused upload never is).
    pub(super) fn record(&mut self, request: &Request) -> Option<u64> {
        self.recorder.as_ref()?;
        let result = match request {
            Request::Hello {
                version, client, ..
            } => self.append(&Request::Hello {
                version: *version,
                client: client.clone(),
                token: None,
            }),
            Request::UploadMesh(u) => return Some(u.hash),
            Request::FrameUpdate(update) => {
                self.record_meshes(antumbra_protocol::frame_mesh_hashes(update));
                self.append(request)
            }
            other => self.append(other),
        };
        self.keep_or_stop(result);
        None
    }

    /// Records an upload of each of these meshes that the file lacks and the daemon holds (in
    /// the session's working set or the shared cache), so each mesh is in the file once.
    pub(super) fn record_meshes(&mut self, hashes: impl IntoIterator<Item = u64>) {
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
