//! Session recordings (`.antrec`) written by the client: the uploads and frames a session sends,
//! in an order that replays (a frame is written once every mesh and alpha image it uses is in
//! the file).

use std::collections::HashSet;
use std::fs::File;
use std::io::BufWriter;

use antumbra_protocol::{FrameUpdate, RecordingWriter, Request};

use crate::error::{ClientError, ClientResult};
use crate::uploads::{Kind, Upload};

pub struct Recorder {
    path: String,
    writer: RecordingWriter<BufWriter<File>>,
    /// Meshes already in the file.
    meshes: HashSet<u64>,
    /// Alpha images already in the file.
    images: HashSet<u64>,
    /// Frames waiting for meshes that are not in the file yet, in the order they were sent.
    pending: Vec<FrameUpdate>,
    frames: usize,
}

impl Recorder {
    pub fn create(path: &str) -> ClientResult<Self> {
        let writer = RecordingWriter::create(path)
            .map_err(|e| ClientError::invalid(format!("start_recording: {e}")))?;
        Ok(Recorder {
            path: path.to_string(),
            writer,
            meshes: HashSet::new(),
            images: HashSet::new(),
            pending: Vec::new(),
            frames: 0,
        })
    }

    /// Whether the file holds the mesh or image `hash`.
    pub fn has(&self, kind: Kind, hash: u64) -> bool {
        match kind {
            Kind::Mesh => self.meshes.contains(&hash),
            Kind::Image => self.images.contains(&hash),
        }
    }

    fn append(&mut self, request: &Request) -> ClientResult<()> {
        self.writer
            .append(request)
            .map_err(|e| ClientError::invalid(format!("recording {}: {e}", self.path)))
    }

    /// Writes an upload unless the file holds it already.
    pub fn upload(&mut self, upload: &Upload) -> ClientResult<()> {
        let new = match upload {
            Upload::Mesh(u) => self.meshes.insert(u.hash),
            Upload::Image(u) => self.images.insert(u.hash),
        };
        if new {
            self.append(&upload.clone().into_request())?;
            self.flush_ready()?;
        }
        Ok(())
    }

    /// Records a frame now if the file holds its meshes, else once they have been uploaded.
    pub fn frame(&mut self, update: &FrameUpdate) -> ClientResult<()> {
        // A frame sent again replaces its earlier pending version.
        self.pending.retain(|p| p.frame != update.frame);
        self.pending.push(update.clone());
        self.flush_ready()
    }

    /// Whether the file holds every mesh and image a frame uses.
    fn ready(&self, update: &FrameUpdate) -> bool {
        [Kind::Mesh, Kind::Image]
            .into_iter()
            .all(|kind| kind.in_frame(update).into_iter().all(|h| self.has(kind, h)))
    }

    fn flush_ready(&mut self) -> ClientResult<()> {
        let mut i = 0;
        while i < self.pending.len() {
            let pending = &self.pending[i];
            if self.ready(pending) {
                let update = self.pending.remove(i);
                self.append(&Request::FrameUpdate(update))?;
                self.frames += 1;
            } else {
                i += 1;
            }
        }
        Ok(())
    }

    /// Closes the file; returns (frames written, frames dropped because meshes or images never
    /// came).
    pub fn finish(self) -> ClientResult<(usize, usize)> {
        let path = self.path;
        self.writer
            .close()
            .map_err(|e| ClientError::invalid(format!("recording {path}: {e}")))?;
        Ok((self.frames, self.pending.len()))
    }
}
