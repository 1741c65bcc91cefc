//! The `decode_frame` target: arbitrary bytes as a peer's stream, through the three readers and
//! the daemon's checks of every request decoded.

use crate::check::check_limits;
use crate::convert::{missing_images, missing_meshes, render_settings};
use crate::error::FrameError;
use crate::frame::{decode_body, encode_message, read_message, FrameDecoder};
use crate::limits::Limits;
use crate::messages::Request;
use crate::recording::Replay;

/// Small limits keep the work per input small; the code paths are the same.
fn limits() -> Limits {
    Limits {
        max_frame_bytes: 1 << 20,
        max_triangles_per_mesh: 100_000,
        ..Limits::default()
    }
}

/// One decoding step, in a form that can be compared across the three readers.
fn outcome(r: &Result<Request, FrameError>) -> String {
    match r {
        Ok(req) => format!("{req:?}"),
        Err(FrameError::Decode(_)) => "decode error".into(),
        Err(e) => format!("{e}"),
    }
}

/// Feeds `data` as a byte stream to the incremental decoder (whole, and in uneven pieces) and to
/// the blocking reader; checks they agree, then runs every decoded request through the checks a
/// daemon would apply. Must never panic except on a real disagreement (a bug).
pub fn decode_frame(data: &[u8]) {
    let limits = limits();

    let mut whole = FrameDecoder::new(&limits);
    whole.push(data);
    let mut a = Vec::new();
    loop {
        match whole.next_message::<Request>() {
            Ok(Some(r)) => a.push(Ok(r)),
            Ok(None) => {
                let end = whole.finish();
                if !matches!(end, FrameError::Closed) {
                    a.push(Err(end));
                }
                break;
            }
            Err(e @ FrameError::TooLarge { .. }) => {
                a.push(Err(e));
                break;
            }
            Err(e) => a.push(Err(e)),
        }
    }

    let mut pieces = FrameDecoder::new(&limits);
    let mut b = Vec::new();
    let mut rest = data;
    let mut step = 0usize;
    let mut fatal = false;
    while !rest.is_empty() && !fatal {
        let n = [1, 3, 17, 2, 256, 5][step % 6].min(rest.len());
        step += 1;
        pieces.push(&rest[..n]);
        rest = &rest[n..];
        loop {
            match pieces.next_message::<Request>() {
                Ok(Some(r)) => b.push(Ok(r)),
                Ok(None) => break,
                Err(e @ FrameError::TooLarge { .. }) => {
                    b.push(Err(e));
                    fatal = true;
                    break;
                }
                Err(e) => b.push(Err(e)),
            }
        }
    }
    if !fatal {
        let end = pieces.finish();
        if !matches!(end, FrameError::Closed) {
            b.push(Err(end));
        }
    }

    let mut reader = data;
    let mut c = Vec::new();
    loop {
        match read_message::<_, Request>(&mut reader, &limits) {
            Err(FrameError::Closed) => break,
            Err(e @ (FrameError::TooLarge { .. } | FrameError::Truncated { .. })) => {
                c.push(Err(e));
                break;
            }
            r => c.push(r),
        }
    }

    let (a, b, c): (Vec<_>, Vec<_>, Vec<_>) = (
        a.iter().map(outcome).collect(),
        b.iter().map(outcome).collect(),
        c.iter().map(outcome).collect(),
    );
    assert_eq!(a, b, "whole vs piecewise decoding");
    assert_eq!(a, c, "incremental vs blocking decoding");

    // What a daemon does with each request; errors are expected, panics are bugs.
    let mut replay = Replay::new(limits.clone());
    let mut decoder = FrameDecoder::new(&limits);
    decoder.push(data);
    while let Ok(Some(request)) = decoder.next_message::<Request>() {
        // Re-encoding gives the same request back.
        if let Ok(bytes) = encode_message(&request) {
            let again = decode_body::<Request>(&bytes[4..]);
            assert_eq!(
                outcome(&again),
                outcome(&Ok(request.clone())),
                "re-encoding"
            );
        }
        if check_limits(&request, &limits).is_err() {
            continue;
        }
        match &request {
            Request::Render(r) => {
                let _ = render_settings(&r.settings);
            }
            Request::FrameUpdate(u) => {
                let _ = missing_meshes(u, &replay.meshes);
                let _ = missing_images(u, &(&replay.meshes, &replay.images));
            }
            _ => {}
        }
        let _ = replay.apply(request);
    }
    let _ = replay.scenes();
}
