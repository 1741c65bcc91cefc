//! Error replies, worded once for every session.

use antumbra_protocol::{ErrorCode, ProtocolError, Reply};

pub fn error_reply(
    code: ErrorCode,
    message: impl Into<String>,
    session_usable: bool,
    request_id: Option<u64>,
) -> Reply {
    Reply::Error {
        code,
        message: message.into(),
        session_usable,
        request_id,
    }
}

/// The reply to `e`, naming the request it ends (if any).
pub fn protocol_error(e: &ProtocolError, request_id: Option<u64>) -> Reply {
    match e.to_reply() {
        Reply::Error {
            code,
            message,
            session_usable,
            ..
        } => error_reply(code, message, session_usable, request_id),
        other => other,
    }
}
