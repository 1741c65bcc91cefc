//! Meshes and alpha images alike: the two kinds of upload a session and its recording hold by
//! content hash, and the bookkeeping both sessions (socket and in-process) do for them, written
//! once: which ones to send, what a frame still lacks, what goes to the recording.

use std::collections::HashSet;

use antumbra_protocol::{FrameUpdate, Request, UploadImage, UploadMesh};

use crate::error::ClientResult;
use crate::recording::Recorder;

/// Which kind of upload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    Mesh,
    Image,
}

impl Kind {
    /// The request asking a session which of `hashes` it lacks.
    pub fn missing_request(self, hashes: Vec<u64>) -> Request {
        match self {
            Kind::Mesh => Request::MissingMeshes { hashes },
            Kind::Image => Request::MissingImages { hashes },
        }
    }

    /// The hashes of this kind a frame uses, in frame order (with repeats).
    pub fn in_frame(self, update: &FrameUpdate) -> Vec<u64> {
        match self {
            Kind::Mesh => antumbra_protocol::frame_mesh_hashes(update).collect(),
            Kind::Image => antumbra_protocol::frame_image_hashes(update).collect(),
        }
    }
}

/// A mesh or an alpha image on its way to a session.
#[derive(Clone)]
pub(crate) enum Upload {
    Mesh(UploadMesh),
    Image(UploadImage),
}

impl Upload {
    pub fn into_request(self) -> Request {
        match self {
            Upload::Mesh(u) => Request::UploadMesh(u),
            Upload::Image(u) => Request::UploadImage(u),
        }
    }
}

/// `missing` (the session's answer), then each hash of `used` the recording lacks and
/// `missing` does not name: while recording, what the file lacks is asked for too.
pub(crate) fn and_unrecorded(
    mut missing: Vec<u64>,
    used: impl IntoIterator<Item = u64>,
    recorder: Option<&Recorder>,
    kind: Kind,
) -> Vec<u64> {
    if let Some(rec) = recorder {
        let mut seen: HashSet<u64> = missing.iter().copied().collect();
        missing.extend(
            used.into_iter()
                .filter(|&h| !rec.has(kind, h) && seen.insert(h)),
        );
    }
    missing
}

/// What a session answered to a frame (`meshes`, `images` it lacks), with what the recording
/// lacks added; the frame goes to the recording.
pub(crate) fn frame_missing(
    recorder: Option<&mut Recorder>,
    update: &FrameUpdate,
    meshes: Vec<u64>,
    images: Vec<u64>,
) -> ClientResult<(Vec<u64>, Vec<u64>)> {
    let Some(rec) = recorder else {
        return Ok((meshes, images));
    };
    let meshes = and_unrecorded(meshes, Kind::Mesh.in_frame(update), Some(rec), Kind::Mesh);
    let images = and_unrecorded(images, Kind::Image.in_frame(update), Some(rec), Kind::Image);
    rec.frame(update)?;
    Ok((meshes, images))
}

/// Updates what a session holds from the hashes asked about (or a frame's) and those it
/// reported missing.
pub(crate) fn note_held(
    known: &mut HashSet<u64>,
    used: impl IntoIterator<Item = u64>,
    missing: &[u64],
) {
    let missing: HashSet<u64> = missing.iter().copied().collect();
    for h in used {
        if missing.contains(&h) {
            known.remove(&h);
        } else {
            known.insert(h);
        }
    }
}
