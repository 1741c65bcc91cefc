//! Session recordings (`.antrec`) written by the client: the uploads and frames a session sends,
//! in an order that replays (a frame is written once every mesh and alpha image it uses is in
//! the file).

use std::collections::HashSet;
use std::fs::File;
use std::io::BufWriter;

use antumbra_protocol::{FrameUpdate, RecordingWriter, Request, UploadImage, UploadMesh};

use crate::error::{ClientError, ClientResult};

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

    pub fn has_mesh(&self, hash: u64) -> bool {
        self.meshes.contains(&hash)
    }

    pub fn has_image(&self, hash: u64) -> bool {
        self.images.contains(&hash)
    }

    fn append(&mut self, request: &Request) -> ClientResult<()> {
        self.writer
            .append(request)
            .map_err(|e| ClientError::invalid(format!("recording {}: {e}", self.path)))
    }

    pub fn mesh(&mut self, upload: &UploadMesh) -> ClientResult<()> {
        if self.meshes.insert(upload.hash) {
            self.append(&Request::UploadMesh(upload.clone()))?;
            self.flush_ready()?;
        }
        Ok(())
    }

    pub fn image(&mut self, upload: &UploadImage) -> ClientResult<()> {
        if self.images.insert(upload.hash) {
            self.append(&Request::UploadImage(upload.clone()))?;
            self.flush_ready()?;
        }
        Ok(())
    }

    /// Alpha images a frame's materials read that the file lacks (distinct, first use order).
    pub fn missing_images(&self, update: &FrameUpdate) -> Vec<u64> {
        let mut seen = HashSet::new();
        antumbra_protocol::frame_image_hashes(update)
            .filter(|h| seen.insert(*h) && !self.images.contains(h))
            .collect()
    }

    /// Records a frame now if the file holds its meshes, else once they have been uploaded.
    pub fn frame(&mut self, update: &FrameUpdate) -> ClientResult<()> {
        // A frame sent again replaces its earlier pending version.
        self.pending.retain(|p| p.frame != update.frame);
        self.pending.push(update.clone());
        self.flush_ready()
    }

    /// Meshes a frame uses that the file lacks (distinct, in order of first use).
    pub fn missing(&self, update: &FrameUpdate) -> Vec<u64> {
        let mut seen = HashSet::new();
        antumbra_protocol::frame_mesh_hashes(update)
            .filter(|h| seen.insert(*h) && !self.meshes.contains(h))
            .collect()
    }

    fn flush_ready(&mut self) -> ClientResult<()> {
        let mut i = 0;
        while i < self.pending.len() {
            let pending = &self.pending[i];
            if self.missing(pending).is_empty() && self.missing_images(pending).is_empty() {
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
