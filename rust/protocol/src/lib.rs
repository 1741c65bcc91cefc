//! The wire protocol between the Blender add-on (through the Python client) and the antumbra
//! daemon: versioned messages ([`Request`], [`Reply`]), length-prefixed MessagePack framing
//! ([`frame`]), limits ([`Limits`], [`check_limits`]), admission ([`admission`]: work and
//! memory, the daemon's and the command line's alike), conversions to and from antumbra-core's
//! scene and results ([`convert`]), session recordings ([`recording`]), and the one client of
//! the daemon ([`client`]), which the Python binding wraps.
//!
//! The normative description, with byte layouts and an example session, is `docs/protocol.md`.

pub mod admission;
pub mod bytes;
pub mod check;
#[cfg(unix)]
pub mod client;
pub mod compare;
pub mod convert;
pub mod error;
pub mod frame;
#[doc(hidden)]
pub mod fuzzing;
pub mod instances;
mod light_kind;
pub mod limits;
pub mod messages;
pub mod recording;
pub mod trade;

pub use admission::{admit_compare, admit_render, admit_trade, Asked};
pub use check::{
    check_frame_limits, check_image_texels, check_limits, check_repeat, reply_planes,
    MAX_COMPARE_REPEAT,
};
pub use compare::{
    compare_result_reply, heat_from_reply, CompareMethod, CompareRequest, CompareResultReply,
    CompareRowState, MismatchState, COMPARE_STAGE, DEFAULT_REPEAT,
};
pub use convert::{
    distinct_lacking, frame_image_hashes, frame_mesh_hashes, frame_result_reply,
    frame_update_from_scene, image_from_upload, image_label, mesh_from_upload, missing_images,
    missing_meshes, planes_from_reply, render_settings, scene_from_frame, scene_to_messages,
    stats_from_reply, upload_from_image, upload_from_mesh, visible_from_reply, warm_up_reply,
    MeshStore,
};
pub use error::{FrameError, ProtocolError};
pub use frame::{
    decode_body, encode_body, encode_message, encode_message_within, read_frame, read_message,
    write_message, FrameDecoder,
};
pub use limits::{Limits, DEFAULT_MAX_RENDER_BYTES, DEFAULT_MAX_REQUEST_PASSES};
pub use messages::*;
pub use recording::{
    replay_scenes, RecordedAnimation, RecordingError, RecordingReader, RecordingWriter, Replay,
};
pub use trade::{TradeMismatchState, TradeRequest, TradeResultReply, TradeRowState, TRADE_STAGE};
