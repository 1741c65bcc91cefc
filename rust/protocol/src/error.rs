//! Errors of the protocol layer. Every message names the mesh, object, frame or field at fault so
//! the daemon can send it to Blender as is (see [`ProtocolError::to_reply`]).

use antumbra_core::render::{format_bytes, RenderMemory};
use antumbra_core::scene::limits::limit_exceeded;
use thiserror::Error;

use crate::messages::{ErrorCode, Reply};

/// Errors of the framing layer: reading or decoding one length-prefixed message.
#[derive(Debug, Error)]
pub enum FrameError {
    /// The stream ended cleanly at a message boundary.
    #[error("connection closed")]
    Closed,
    /// The stream ended inside a frame.
    #[error("truncated frame: expected {expected} bytes, got {got}")]
    Truncated { expected: u64, got: u64 },
    /// The length prefix exceeds the limit; refused before anything was allocated. The stream
    /// cannot be resynchronised after this.
    #[error("frame of {len} bytes exceeds the limit of {max} bytes (max_frame_bytes)")]
    TooLarge { len: u64, max: u64 },
    /// The frame's body is not a valid message. The next frame can still be read.
    #[error("undecodable message: {0}")]
    Decode(String),
    /// A message could not be encoded (or is too large to frame).
    #[error("cannot encode message: {0}")]
    Encode(String),
    #[error("i/o error: {0}")]
    Io(#[from] std::io::Error),
}

impl FrameError {
    pub fn code(&self) -> ErrorCode {
        match self {
            FrameError::TooLarge { .. } => ErrorCode::TooLarge,
            FrameError::Closed
            | FrameError::Truncated { .. }
            | FrameError::Decode(_)
            | FrameError::Encode(_) => ErrorCode::BadFrame,
            FrameError::Io(_) => ErrorCode::Internal,
        }
    }

    /// Whether the byte stream is still aligned on frame boundaries after this error, so the
    /// session can go on: only a body that failed to decode leaves the framing intact.
    pub fn session_usable(&self) -> bool {
        matches!(self, FrameError::Decode(_))
    }

    /// The error reply to send for this error (when the connection can still carry one).
    pub fn to_reply(&self) -> Reply {
        Reply::Error {
            code: self.code(),
            message: self.to_string(),
            session_usable: self.session_usable(),
            request_id: None,
        }
    }
}

/// Names both versions and which side to update: usually the add-on, which carries the client.
fn version_mismatch(client: u32, server: u32) -> String {
    let update = if client < server {
        "update the Blender add-on (it carries the antumbra client) to this daemon's release"
    } else {
        "update the antumbra daemon to the add-on's release"
    };
    format!(
        "protocol version mismatch: the client speaks version {client}, this daemon speaks \
         version {server}: {update}"
    )
}

/// Errors in the content of a well-framed message.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ProtocolError {
    #[error("{}", version_mismatch(*client, *server))]
    VersionMismatch { client: u32, server: u32 },
    /// A field with a value outside its valid range; `field` names the mesh/object/frame too.
    #[error("{field}: {message}")]
    Invalid { field: String, message: String },
    #[error("mesh '{mesh}': declared hash {declared:#018x} but its positions and triangles hash to {actual:#018x}")]
    HashMismatch {
        mesh: String,
        declared: u64,
        actual: u64,
    },
    #[error(
        "image {declared:#018x}: its size and texels hash to {actual:#018x}, not the declared hash"
    )]
    ImageHashMismatch { declared: u64, actual: u64 },
    #[error("frame {frame}: alpha material '{material}' refers to image {hash:#018x}, which the daemon does not hold (upload it first)")]
    UnknownImage {
        frame: i32,
        material: String,
        hash: u64,
    },
    #[error("frame {frame}: object '{object}' refers to mesh {hash:#018x}, which the daemon does not hold (upload it first)")]
    UnknownMesh {
        frame: i32,
        object: String,
        hash: u64,
    },
    #[error("{}", limit_exceeded(what, *value, *limit, limit_name))]
    LimitExceeded {
        what: String,
        value: u64,
        limit: u64,
        limit_name: &'static str,
    },
    /// A render estimated to need more memory than the budget; refused before any work.
    #[error(
        "frame {frame}: the render needs {estimate}, over the render memory budget of {} \
         (max_render_bytes)",
        format_bytes(*limit)
    )]
    RenderMemory {
        frame: i32,
        estimate: Box<RenderMemory>,
        limit: u64,
    },
    /// A comparison whose methods together (each keeps its own trees) are estimated to need
    /// more memory than the budget; refused before any work.
    #[error(
        "frame {frame}: comparing {methods} methods needs {estimate}, every method's trees \
         together, over the render memory budget of {} (max_render_bytes); compare fewer \
         methods at once",
        format_bytes(*limit)
    )]
    CompareMemory {
        frame: i32,
        methods: usize,
        estimate: Box<RenderMemory>,
        limit: u64,
    },
    /// A trade whose knob values together (each keeps its own trees) are estimated to need
    /// more memory than the budget; refused before any work.
    #[error(
        "frame {frame}: trading {values} knob values needs {estimate}, every value's trees \
         together, over the render memory budget of {} (max_render_bytes); trade fewer knobs \
         at once",
        format_bytes(*limit)
    )]
    TradeMemory {
        frame: i32,
        values: usize,
        estimate: Box<RenderMemory>,
        limit: u64,
    },
    /// A request asking for more method passes than `max_request_passes`; refused before any
    /// work, so that no request runs for ever.
    #[error(
        "{what}: {passes} passes ({per_frame} per frame, x {frames} {}) exceed the limit of \
         {limit} passes per request (max_request_passes); ask for fewer methods, values, \
         repeats or frames",
        if *frames == 1 { "frame" } else { "frames" }
    )]
    RequestPasses {
        what: String,
        /// What one frame's passes are made of, e.g. `5 methods x (1 counted + 3 timed)`.
        per_frame: String,
        frames: u64,
        passes: u64,
        limit: u64,
    },
    /// A core validation error found in one frame's data.
    #[error("frame {frame}: {error}")]
    InFrame {
        frame: i32,
        error: antumbra_core::Error,
    },
    /// A core validation error outside a frame (mesh uploads, settings).
    #[error(transparent)]
    Core(#[from] antumbra_core::Error),
}

impl ProtocolError {
    pub(crate) fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        ProtocolError::Invalid {
            field: field.into(),
            message: message.into(),
        }
    }

    pub fn code(&self) -> ErrorCode {
        match self {
            ProtocolError::VersionMismatch { .. } => ErrorCode::VersionMismatch,
            ProtocolError::UnknownMesh { .. } => ErrorCode::UnknownMesh,
            ProtocolError::UnknownImage { .. } => ErrorCode::UnknownImage,
            ProtocolError::LimitExceeded { .. }
            | ProtocolError::RenderMemory { .. }
            | ProtocolError::CompareMemory { .. }
            | ProtocolError::TradeMemory { .. }
            | ProtocolError::RequestPasses { .. } => ErrorCode::LimitExceeded,
            ProtocolError::InFrame {
                error: antumbra_core::Error::Cancelled,
                ..
            }
            | ProtocolError::Core(antumbra_core::Error::Cancelled) => ErrorCode::Cancelled,
            ProtocolError::Invalid { .. }
            | ProtocolError::HashMismatch { .. }
            | ProtocolError::ImageHashMismatch { .. }
            | ProtocolError::InFrame { .. }
            | ProtocolError::Core(_) => ErrorCode::InvalidInput,
        }
    }

    /// The error reply for this error. Only a version mismatch ends the session: every other
    /// content error rejects one request and leaves the session as it was.
    pub fn to_reply(&self) -> Reply {
        Reply::Error {
            code: self.code(),
            message: self.to_string(),
            session_usable: !matches!(self, ProtocolError::VersionMismatch { .. }),
            request_id: None,
        }
    }
}
