//! Recordings (`.antrec`): a session's requests saved to a file so a scene sent from Blender can
//! be rendered again without Blender (`antumbra render --scene FILE.antrec`).
//!
//! Format: the 8 bytes `ANTREC1\n` (version 1), then framed [`Request`]s exactly as on the socket
//! (4-byte LE length + MessagePack body), until the end of the file. Replaying stores every
//! `UploadMesh` and `UploadImage` of the file, then builds each `FrameUpdate`'s scene, so a frame may come before the
//! meshes it uses (as the add-on sends them); every other request is skipped, and so are the
//! requests the protocol no longer has ([`RETIRED_REQUESTS`]), so older files still replay.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::ops::RangeInclusive;
use std::path::Path;
use std::sync::Arc;

use antumbra_core::alpha::AlphaImage;
use antumbra_core::scene::{Animation, Mesh, Scene};
use thiserror::Error;

use crate::check::check_limits;
use crate::convert::{image_from_upload, mesh_from_upload, scene_from_frame, scene_to_messages};
use crate::error::{FrameError, ProtocolError};
use crate::frame::{decode_body, read_frame, write_message};
use crate::limits::{Limits, MAX_FRAME_BYTES_CEILING};
use crate::messages::{FrameUpdate, Request};

/// Requests that older recordings hold and the protocol no longer has; the reader skips them.
/// `CameraPath` (the camera of every frame, sent up front) was stored and read by nothing.
pub const RETIRED_REQUESTS: &[&str] = &["CameraPath"];

/// Whether a frame's body is one of the [`RETIRED_REQUESTS`] (a one-entry map from its name).
fn is_retired(body: &[u8]) -> bool {
    let value: Result<BTreeMap<String, serde::de::IgnoredAny>, _> = decode_body(body);
    value.is_ok_and(|m| m.len() == 1 && m.keys().all(|k| RETIRED_REQUESTS.contains(&k.as_str())))
}

/// The version this antumbra writes; it reads every version from 1 up to it. (Replaying
/// regardless of order needed no new version: it reads every file the in-order replay read, to
/// the same scenes.)
pub const RECORDING_VERSION: u8 = 1;
pub const RECORDING_MAGIC: &[u8; 8] = &magic(RECORDING_VERSION);

const fn magic(version: u8) -> [u8; 8] {
    let mut m = *b"ANTREC0\n";
    m[6] = b'0' + version;
    m
}

/// The headers of every version this antumbra reads, as an error names them.
fn known_magics() -> String {
    let quoted: Vec<String> = (1..=RECORDING_VERSION)
        .map(|v| format!("{:?}", String::from_utf8_lossy(&magic(v))))
        .collect();
    quoted.join(" or ")
}

#[derive(Debug, Error)]
pub enum RecordingError {
    /// The inner error is in the message, not the source chain, so that printing the chain
    /// (`{:#}`) names the problem once.
    #[error("{path}: {error}")]
    File {
        path: String,
        error: Box<RecordingError>,
    },
    #[error("{0}")]
    Io(std::io::Error),
    #[error("not an antumbra recording: it does not start with {}", known_magics())]
    BadMagic,
    #[error(
        "a recording of version {0}, newer than this antumbra reads (up to {RECORDING_VERSION}): \
         replay it with a newer antumbra"
    )]
    NewerVersion(char),
    #[error("message {index}: {error}")]
    Frame { index: usize, error: FrameError },
    #[error("message {index} ({kind}): {error}")]
    Protocol {
        index: usize,
        kind: &'static str,
        error: ProtocolError,
    },
    #[error(
        "message {index} (FrameUpdate): frame {frame}: object '{object}' uses mesh {hash:#018x}, \
         which the recording never uploads"
    )]
    MissingMesh {
        index: usize,
        frame: i32,
        object: String,
        hash: u64,
    },
    #[error("the recording holds no FrameUpdate")]
    NoFrames,
}

impl From<std::io::Error> for RecordingError {
    fn from(e: std::io::Error) -> Self {
        RecordingError::Io(e)
    }
}

impl RecordingError {
    fn in_file(self, path: &Path) -> Self {
        RecordingError::File {
            path: path.display().to_string(),
            error: Box::new(self),
        }
    }
}

/// Appends requests to a recording.
pub struct RecordingWriter<W: Write> {
    w: W,
    /// Meshes already in the recording, so [`append_scene`](Self::append_scene) uploads each
    /// content once.
    uploaded: HashSet<u64>,
    /// Alpha images already in the recording, likewise.
    images: HashSet<u64>,
    written: usize,
}

impl RecordingWriter<BufWriter<File>> {
    pub fn create(path: impl AsRef<Path>) -> Result<Self, RecordingError> {
        let path = path.as_ref();
        let file = File::create(path).map_err(|e| RecordingError::from(e).in_file(path))?;
        RecordingWriter::new(BufWriter::new(file)).map_err(|e| e.in_file(path))
    }

    /// Flushes the recording and waits until it is on disk (a spool job's folder is renamed
    /// into place right after).
    pub fn close(self) -> std::io::Result<()> {
        let file = self.finish()?.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()
    }
}

impl<W: Write> RecordingWriter<W> {
    /// Starts a recording by writing the magic header.
    pub fn new(mut w: W) -> Result<Self, RecordingError> {
        w.write_all(RECORDING_MAGIC)?;
        Ok(RecordingWriter {
            w,
            uploaded: HashSet::new(),
            images: HashSet::new(),
            written: 0,
        })
    }

    pub fn append(&mut self, request: &Request) -> Result<(), FrameError> {
        match request {
            Request::UploadMesh(u) => {
                self.uploaded.insert(u.hash);
            }
            Request::UploadImage(u) => {
                self.images.insert(u.hash);
            }
            _ => {}
        }
        write_message(&mut self.w, request)?;
        self.written += 1;
        Ok(())
    }

    /// Whether the recording holds an upload of this mesh.
    pub fn has_mesh(&self, hash: u64) -> bool {
        self.uploaded.contains(&hash)
    }

    /// Whether the recording holds an upload of this alpha image.
    pub fn has_image(&self, hash: u64) -> bool {
        self.images.contains(&hash)
    }

    /// Requests appended so far.
    pub fn written(&self) -> usize {
        self.written
    }

    /// Appends a scene as a daemon would receive it: uploads of meshes not yet in the recording,
    /// then its `FrameUpdate`.
    pub fn append_scene(&mut self, scene: &Scene) -> Result<(), RecordingError> {
        let (uploads, update) =
            scene_to_messages(scene).map_err(|source| RecordingError::Protocol {
                index: self.written,
                kind: "FrameUpdate",
                error: source,
            })?;
        for request in uploads.iter().chain([&update]) {
            let held = match request {
                Request::UploadMesh(u) => self.uploaded.contains(&u.hash),
                Request::UploadImage(u) => self.images.contains(&u.hash),
                _ => false,
            };
            if held {
                continue;
            }
            let index = self.written;
            self.append(request)
                .map_err(|source| RecordingError::Frame {
                    index,
                    error: source,
                })?;
        }
        Ok(())
    }

    pub fn flush(&mut self) -> std::io::Result<()> {
        self.w.flush()
    }

    /// Flushes and returns the writer.
    pub fn finish(mut self) -> std::io::Result<W> {
        self.w.flush()?;
        Ok(self.w)
    }
}

/// Reads the requests of a recording in order.
pub struct RecordingReader<R: Read> {
    r: R,
    version: u8,
    limits: Limits,
    index: usize,
    done: bool,
}

/// Opens `path` for reading only if it is a regular file: a FIFO or device would block the
/// reader (or never end), so it is refused without waiting for a writer.
pub fn open_regular(path: &Path) -> std::io::Result<File> {
    use std::os::unix::fs::OpenOptionsExt;
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)?;
    if !file.metadata()?.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file",
        ));
    }
    Ok(file)
}

impl RecordingReader<BufReader<File>> {
    pub fn open(path: impl AsRef<Path>) -> Result<Self, RecordingError> {
        let path = path.as_ref();
        let file = open_regular(path).map_err(|e| RecordingError::from(e).in_file(path))?;
        RecordingReader::new(BufReader::new(file)).map_err(|e| e.in_file(path))
    }
}

impl<R: Read> RecordingReader<R> {
    /// Checks the magic header. Frames may be as large as a 4-byte prefix allows (a recording is
    /// a local file, not a peer), but are still read only as far as bytes exist.
    pub fn new(r: R) -> Result<Self, RecordingError> {
        let limits = Limits {
            max_frame_bytes: MAX_FRAME_BYTES_CEILING,
            ..Limits::default()
        };
        RecordingReader::with_limits(r, limits)
    }

    pub fn with_limits(mut r: R, limits: Limits) -> Result<Self, RecordingError> {
        let mut header = [0u8; 8];
        match r.read_exact(&mut header) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
                return Err(RecordingError::BadMagic)
            }
            Err(e) => return Err(e.into()),
        }
        let version = match header[6].checked_sub(b'0') {
            Some(v @ 1..=9) if header == magic(v) => v,
            _ => return Err(RecordingError::BadMagic),
        };
        if version > RECORDING_VERSION {
            return Err(RecordingError::NewerVersion(header[6] as char));
        }
        Ok(RecordingReader {
            r,
            version,
            limits,
            index: 0,
            done: false,
        })
    }

    /// The file's format version (from its header).
    pub fn version(&self) -> u8 {
        self.version
    }

    /// The next request, `None` at the end of the recording.
    pub fn next_request(&mut self) -> Result<Option<Request>, RecordingError> {
        while !self.done {
            let read = read_frame(&mut self.r, &self.limits).and_then(|body| {
                decode_body(&body)
                    .map(Some)
                    .or_else(|e| match is_retired(&body) {
                        true => Ok(None),
                        false => Err(e),
                    })
            });
            match read {
                Ok(request) => {
                    // A retired request is counted too, so errors name messages as the file holds them.
                    self.index += 1;
                    if request.is_some() {
                        return Ok(request);
                    }
                }
                Err(FrameError::Closed) => self.done = true,
                Err(source) => {
                    // A bad frame may have left the reader mid-stream; nothing after it is trusted.
                    self.done = true;
                    return Err(RecordingError::Frame {
                        index: self.index,
                        error: source,
                    });
                }
            }
        }
        Ok(None)
    }

    /// The limits the reader was made with (mesh uploads are checked against them on replay).
    pub fn limits(&self) -> &Limits {
        &self.limits
    }
}

impl<R: Read> Iterator for RecordingReader<R> {
    type Item = Result<Request, RecordingError>;
    fn next(&mut self) -> Option<Self::Item> {
        self.next_request().transpose()
    }
}

/// Replays requests whatever their order: stores every upload's mesh (and alpha image) and keeps every
/// `FrameUpdate`, then [`scenes`](Self::scenes) builds the frames from all the meshes. Meshes with
/// the same hash are the same `Arc` in every scene, so a renderer reuses its BVHs for frames whose
/// geometry did not change.
#[derive(Default)]
pub struct Replay {
    pub meshes: HashMap<u64, Arc<Mesh>>,
    pub images: HashMap<u64, Arc<AlphaImage>>,
    pub limits: Limits,
    /// The frame updates with their message index, in order.
    frames: Vec<(usize, FrameUpdate)>,
    /// Requests applied so far (the next one's message index).
    applied: usize,
}

impl Replay {
    pub fn new(limits: Limits) -> Self {
        Replay {
            limits,
            ..Replay::default()
        }
    }

    /// Applies the next request of the recording: stores an upload's mesh (checked as the daemon
    /// checks it; the first upload of a hash wins), keeps a `FrameUpdate`, skips the rest.
    pub fn apply(&mut self, request: Request) -> Result<(), RecordingError> {
        let index = self.applied;
        self.applied += 1;
        // Checked as a daemon checks it on the socket, so a crafted file cannot ask for more.
        check_limits(&request, &self.limits).map_err(|error| RecordingError::Protocol {
            index,
            kind: request.kind(),
            error,
        })?;
        match request {
            Request::UploadMesh(upload) if !self.meshes.contains_key(&upload.hash) => {
                let mesh = mesh_from_upload(&upload, &self.limits).map_err(|source| {
                    RecordingError::Protocol {
                        index,
                        kind: "UploadMesh",
                        error: source,
                    }
                })?;
                self.meshes.insert(upload.hash, Arc::new(mesh));
            }
            Request::UploadImage(upload) if !self.images.contains_key(&upload.hash) => {
                let image = image_from_upload(&upload, &self.limits).map_err(|source| {
                    RecordingError::Protocol {
                        index,
                        kind: "UploadImage",
                        error: source,
                    }
                })?;
                self.images.insert(upload.hash, Arc::new(image));
            }
            Request::FrameUpdate(mut update) => {
                // Arrays recorded as unchanged repeat the frame before, as the daemon read them.
                let previous = self.frames.last().map(|(_, f)| f);
                crate::instances::resolve_unchanged(&mut update, previous)
                    .and_then(|()| crate::check::check_frame_limits(&update, &self.limits))
                    .map_err(|error| RecordingError::Protocol {
                        index,
                        kind: "FrameUpdate",
                        error,
                    })?;
                self.frames.push((index, update))
            }
            _ => {}
        }
        Ok(())
    }

    /// The scene of every `FrameUpdate` applied, in order, each with its meshes from the whole
    /// recording.
    pub fn scenes(&self) -> Result<Vec<Scene>, RecordingError> {
        self.frames
            .iter()
            .map(|(index, update)| {
                let store = (&self.meshes, &self.images);
                scene_from_frame(update, &store).map_err(|source| match source {
                    ProtocolError::UnknownMesh {
                        frame,
                        object,
                        hash,
                    } => RecordingError::MissingMesh {
                        index: *index,
                        frame,
                        object,
                        hash,
                    },
                    source => RecordingError::Protocol {
                        index: *index,
                        kind: "FrameUpdate",
                        error: source,
                    },
                })
            })
            .collect()
    }
}

fn replay_reader<R: Read>(mut reader: RecordingReader<R>) -> Result<Vec<Scene>, RecordingError> {
    let mut replay = Replay::new(reader.limits().clone());
    while let Some(request) = reader.next_request()? {
        replay.apply(request)?;
    }
    replay.scenes()
}

/// The scene of every `FrameUpdate` in a recording, in file order.
pub fn replay_scenes(path: impl AsRef<Path>) -> Result<Vec<Scene>, RecordingError> {
    let path = path.as_ref();
    replay_reader(RecordingReader::open(path)?).map_err(|e| e.in_file(path))
}

/// Replays a recording from any reader (the magic header first).
pub fn replay_scenes_from<R: Read>(r: R) -> Result<Vec<Scene>, RecordingError> {
    replay_reader(RecordingReader::new(r)?)
}

/// A recording as an [`Animation`]: named after the file stem, spanning the recorded frames.
pub struct RecordedAnimation {
    name: String,
    frames: BTreeMap<i32, Scene>,
}

impl RecordedAnimation {
    pub fn open(path: impl AsRef<Path>) -> Result<Self, RecordingError> {
        let path = path.as_ref();
        let name = path
            .file_stem()
            .map_or_else(|| "recording".into(), |s| s.to_string_lossy().into_owned());
        RecordedAnimation::from_scenes(name, replay_scenes(path)?).map_err(|e| e.in_file(path))
    }

    /// A later scene of the same frame number replaces an earlier one (a client resent it).
    pub fn from_scenes(
        name: impl Into<String>,
        scenes: Vec<Scene>,
    ) -> Result<Self, RecordingError> {
        if scenes.is_empty() {
            return Err(RecordingError::NoFrames);
        }
        Ok(RecordedAnimation {
            name: name.into(),
            frames: scenes.into_iter().map(|s| (s.frame, s)).collect(),
        })
    }

    /// The frame numbers that were recorded (the range may have gaps).
    pub fn recorded_frames(&self) -> impl Iterator<Item = i32> + '_ {
        self.frames.keys().copied()
    }
}

impl Animation for RecordedAnimation {
    fn name(&self) -> &str {
        &self.name
    }

    fn frame_range(&self) -> RangeInclusive<i32> {
        let first = self.frames.keys().next().copied().unwrap_or(0);
        let last = self.frames.keys().next_back().copied().unwrap_or(first);
        first..=last
    }

    /// The recorded scene of `frame`; in a gap, the last recorded frame before it is held (as
    /// Blender holds an unkeyed value), and before the first frame the first is used.
    fn frame(&self, frame: i32) -> Scene {
        let held = self
            .frames
            .range(..=frame)
            .next_back()
            .or_else(|| self.frames.iter().next())
            .map(|(_, s)| s.clone());
        // from_scenes refuses an empty recording, so `held` is always Some.
        let mut scene = held.unwrap_or_else(|| Scene {
            frame,
            meshes: Vec::new(),
            objects: Vec::new(),
            camera: antumbra_core::scene::Camera::look_at(
                glam::DVec3::Z,
                glam::DVec3::ZERO,
                glam::DVec3::Y,
            ),
            lights: Vec::new(),
            resolution: antumbra_core::scene::Resolution::new(1, 1),
            alpha: Default::default(),
        });
        scene.frame = frame;
        scene
    }
}
