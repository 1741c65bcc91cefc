//! The wire protocol between the Blender add-on (through the Python client) and the antumbra
//! daemon: versioned messages ([`Request`], [`Reply`]), length-prefixed MessagePack framing
//! ([`frame`]), limits ([`Limits`], [`check_limits`]), conversions to and from antumbra-core's
//! scene and results ([`convert`]), session recordings ([`recording`]), and the one client of
//! the daemon ([`client`]), which the Python binding wraps.
//!
//! The normative description, with byte layouts and an example session, is `docs/protocol.md`.

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
pub mod limits;
pub mod messages;
pub mod recording;
pub mod trade;

pub use check::{
    check_compare_memory, check_limits, check_render_memory, check_trade_memory, reply_planes,
};
pub use compare::{
    compare_result_reply, heat_from_reply, CompareMethod, CompareRequest, CompareResultReply,
    CompareRowState, CompareState, MismatchState, COMPARE_STAGE,
};
pub use convert::{
    frame_result_reply, frame_update_from_scene, mesh_from_upload, missing_meshes,
    planes_from_reply, render_settings, scene_from_frame, scene_to_messages, stats_from_reply,
    upload_from_mesh, visible_from_reply, warm_up_reply, MeshStore,
};
pub use error::{FrameError, ProtocolError};
pub use frame::{
    decode_body, encode_body, encode_message, encode_message_within, read_frame, read_message,
    write_message, FrameDecoder,
};
pub use limits::{Limits, DEFAULT_MAX_RENDER_BYTES};
pub use messages::*;
pub use recording::{
    replay_scenes, RecordedAnimation, RecordingError, RecordingReader, RecordingWriter, Replay,
};
pub use trade::{
    TradeMismatchState, TradeRequest, TradeResultReply, TradeRowState, TradeState, TRADE_STAGE,
};
