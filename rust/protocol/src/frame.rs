//! Framing: each message is a 4-byte little-endian body length, then the body, a MessagePack
//! value written with `rmp_serde::to_vec_named` (structs as maps keyed by field name, so a peer
//! in another language reads them by name, field order does not matter and unknown fields are
//! skipped).
//!
//! Readers check the length against [`Limits::max_frame_bytes`] before they allocate anything,
//! and allocate at most twice the bytes that actually arrived, so neither a huge prefix nor a
//! slow sender of a large frame makes them reserve memory that is not backed by received data.

use std::io::{ErrorKind, Read, Write};
use std::ops::Range;

use serde::de::{DeserializeOwned, IgnoredAny};
use serde::{Deserialize, Serialize};

use crate::error::FrameError;
use crate::limits::Limits;

pub const LENGTH_PREFIX_BYTES: usize = 4;

/// Nesting bound for decoding: the deepest real message is about 6 levels, and a low bound keeps
/// hostile input (arrays in arrays in ...) far from the stack limit.
const MAX_DEPTH: usize = 32;

/// First read chunk of a body; later chunks are as large as what has arrived.
const FIRST_CHUNK: u64 = 64 * 1024;

/// Encodes `message` as one frame: length prefix and body.
pub fn encode_message<T: Serialize + ?Sized>(message: &T) -> Result<Vec<u8>, FrameError> {
    let mut out = vec![0u8; LENGTH_PREFIX_BYTES];
    rmp_serde::encode::write_named(&mut out, message)
        .map_err(|e| FrameError::Encode(e.to_string()))?;
    let len = out.len() - LENGTH_PREFIX_BYTES;
    let len = u32::try_from(len).map_err(|_| {
        FrameError::Encode(format!(
            "the message is {len} bytes, more than a 4-byte length prefix can frame"
        ))
    })?;
    out[..LENGTH_PREFIX_BYTES].copy_from_slice(&len.to_le_bytes());
    Ok(out)
}

/// Encodes `message` as one frame, refusing a body above `limits.max_frame_bytes` with
/// `TooLarge`: for a daemon's replies, which its clients read with the limits of `Welcome`.
pub fn encode_message_within<T: Serialize + ?Sized>(
    message: &T,
    limits: &Limits,
) -> Result<Vec<u8>, FrameError> {
    let framed = encode_message(message)?;
    let len = (framed.len() - LENGTH_PREFIX_BYTES) as u64;
    let max = limits.frame_limit();
    if len > max {
        return Err(FrameError::TooLarge { len, max });
    }
    Ok(framed)
}

/// Encodes `message` as a bare body (no length prefix).
pub fn encode_body<T: Serialize + ?Sized>(message: &T) -> Result<Vec<u8>, FrameError> {
    rmp_serde::to_vec_named(message).map_err(|e| FrameError::Encode(e.to_string()))
}

/// Decodes one message from a frame body. The body must hold exactly one MessagePack value.
pub fn decode_body<T: DeserializeOwned>(body: &[u8]) -> Result<T, FrameError> {
    let mut de = rmp_serde::Deserializer::from_read_ref(body);
    de.set_max_depth(MAX_DEPTH);
    // The path names the field at fault (`FrameUpdate.camera.lens: invalid type: ...`).
    let value = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner().to_string();
        FrameError::Decode(if path == "." || path.is_empty() {
            inner
        } else {
            format!("{path}: {inner}")
        })
    })?;
    // The deserializer does not expose its position; a second read that fails on a clean end of
    // input proves the body was consumed, anything else is trailing data.
    match IgnoredAny::deserialize(&mut de) {
        Err(rmp_serde::decode::Error::InvalidMarkerRead(e))
            if e.kind() == ErrorKind::UnexpectedEof =>
        {
            Ok(value)
        }
        _ => Err(FrameError::Decode(
            "trailing bytes after the message in the frame".into(),
        )),
    }
}

/// Writes one frame and flushes nothing (wrap `w` in a `BufWriter` as needed).
pub fn write_message<W: Write, T: Serialize + ?Sized>(
    w: &mut W,
    message: &T,
) -> Result<(), FrameError> {
    w.write_all(&encode_message(message)?)?;
    Ok(())
}

/// Reads the length prefix: `Closed` on a clean end of stream, `Truncated` inside it.
fn read_prefix<R: Read>(r: &mut R) -> Result<u32, FrameError> {
    let mut prefix = [0u8; LENGTH_PREFIX_BYTES];
    let mut got = 0;
    while got < LENGTH_PREFIX_BYTES {
        match r.read(&mut prefix[got..]) {
            Ok(0) if got == 0 => return Err(FrameError::Closed),
            Ok(0) => {
                return Err(FrameError::Truncated {
                    expected: LENGTH_PREFIX_BYTES as u64,
                    got: got as u64,
                })
            }
            Ok(n) => got += n,
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e.into()),
        }
    }
    Ok(u32::from_le_bytes(prefix))
}

/// Reads from `r` into `buf` until it holds `upto` bytes; `Truncated` (of a `len`-byte body of
/// which `before` bytes came earlier) if the stream ends first.
fn fill<R: Read>(
    r: &mut R,
    buf: &mut Vec<u8>,
    upto: usize,
    len: u64,
    before: u64,
) -> Result<(), FrameError> {
    while buf.len() < upto {
        let n = r
            .by_ref()
            .take((upto - buf.len()) as u64)
            .read_to_end(buf)?;
        if n == 0 {
            return Err(FrameError::Truncated {
                expected: len,
                got: before + buf.len() as u64,
            });
        }
    }
    Ok(())
}

/// Reads one frame's body from a blocking reader.
///
/// The first half of a large body arrives into chunks, each as large as all before it, so no
/// byte is copied and no buffer is outgrown while the body grows; once half has arrived the
/// whole body is allocated (at most twice what arrived) and the rest is read into it. A frame
/// that never ends so costs about the bytes sent, not the three times of a doubling buffer.
pub fn read_frame<R: Read>(r: &mut R, limits: &Limits) -> Result<Vec<u8>, FrameError> {
    let len = read_prefix(r)? as u64;
    let max = limits.frame_limit();
    if len > max {
        return Err(FrameError::TooLarge { len, max });
    }
    let mut chunks: Vec<Vec<u8>> = Vec::new();
    let mut got = 0u64;
    while got < len && (got == 0 || got * 2 < len) {
        let size = (len - got).min(got.max(FIRST_CHUNK)) as usize;
        let mut chunk = Vec::with_capacity(size);
        fill(r, &mut chunk, size, len, got)?;
        got += size as u64;
        chunks.push(chunk);
    }
    if got == len && chunks.len() <= 1 {
        return Ok(chunks.pop().unwrap_or_default());
    }
    let mut body = Vec::with_capacity(len as usize);
    for chunk in chunks {
        body.extend_from_slice(&chunk);
    }
    fill(r, &mut body, len as usize, len, 0)?;
    Ok(body)
}

/// Reads and decodes one message from a blocking reader.
///
/// Errors: `Closed` at a clean end of stream between messages, `Truncated` inside a frame,
/// `TooLarge` for a prefix above the limit (nothing allocated), `Decode` for a bad body (the
/// stream is still aligned: the next call reads the next frame).
pub fn read_message<R: Read, T: DeserializeOwned>(
    r: &mut R,
    limits: &Limits,
) -> Result<T, FrameError> {
    decode_body(&read_frame(r, limits)?)
}

/// An incremental frame decoder for non-blocking loops: [`push`](Self::push) the bytes as they
/// arrive, then pop messages with [`next_message`](Self::next_message) until it returns
/// `Ok(None)`.
///
/// After `TooLarge` the stream cannot be resynchronised: the decoder returns that error from
/// then on and ignores further input. A `Decode` error consumes the bad frame only.
#[derive(Debug)]
pub struct FrameDecoder {
    buf: Vec<u8>,
    /// Start of the bytes not yet consumed.
    start: usize,
    max: u64,
    too_large: Option<u64>,
}

impl FrameDecoder {
    pub fn new(limits: &Limits) -> Self {
        FrameDecoder {
            buf: Vec::new(),
            start: 0,
            max: limits.frame_limit(),
            too_large: None,
        }
    }

    pub fn push(&mut self, bytes: &[u8]) {
        if self.too_large.is_some() {
            return;
        }
        // Drop consumed bytes once they are at least half the buffer: amortised O(1) per byte.
        if self.start > 0 && self.start * 2 >= self.buf.len() {
            self.buf.drain(..self.start);
            self.start = 0;
        }
        self.buf.extend_from_slice(bytes);
    }

    /// Bytes received and not yet returned as a frame.
    pub fn buffered(&self) -> usize {
        self.buf.len() - self.start
    }

    /// The body range of the next complete frame, if one is buffered; checks the prefix as soon
    /// as its 4 bytes are here.
    fn next_range(&mut self) -> Result<Option<Range<usize>>, FrameError> {
        if let Some(len) = self.too_large {
            return Err(FrameError::TooLarge { len, max: self.max });
        }
        let pending = &self.buf[self.start..];
        let Some(prefix) = pending.first_chunk::<LENGTH_PREFIX_BYTES>() else {
            return Ok(None);
        };
        let len = u32::from_le_bytes(*prefix) as u64;
        if len > self.max {
            self.too_large = Some(len);
            self.buf = Vec::new();
            self.start = 0;
            return Err(FrameError::TooLarge { len, max: self.max });
        }
        // Compared in u64 first: once the buffer holds `total` bytes, `total` fits a usize.
        let total = LENGTH_PREFIX_BYTES as u64 + len;
        if (pending.len() as u64) < total {
            return Ok(None);
        }
        let body = self.start + LENGTH_PREFIX_BYTES..self.start + total as usize;
        self.start += total as usize;
        Ok(Some(body))
    }

    /// The next complete frame's body, or `None` until more bytes arrive.
    pub fn next_frame(&mut self) -> Result<Option<Vec<u8>>, FrameError> {
        Ok(self.next_range()?.map(|r| self.buf[r].to_vec()))
    }

    /// The next complete message, or `None` until more bytes arrive. A body that does not
    /// decode is consumed and reported as `Decode`; the following frames are unaffected.
    pub fn next_message<T: DeserializeOwned>(&mut self) -> Result<Option<T>, FrameError> {
        match self.next_range()? {
            Some(r) => decode_body(&self.buf[r]).map(Some),
            None => Ok(None),
        }
    }

    /// The error to report at end of stream, after popping every complete frame: `Closed` if
    /// the stream ended between frames, `Truncated` inside one.
    pub fn finish(&self) -> FrameError {
        if let Some(len) = self.too_large {
            return FrameError::TooLarge { len, max: self.max };
        }
        let pending = &self.buf[self.start..];
        match pending.first_chunk::<LENGTH_PREFIX_BYTES>() {
            None if pending.is_empty() => FrameError::Closed,
            None => FrameError::Truncated {
                expected: LENGTH_PREFIX_BYTES as u64,
                got: pending.len() as u64,
            },
            Some(prefix) => FrameError::Truncated {
                expected: u32::from_le_bytes(*prefix) as u64,
                got: (pending.len() - LENGTH_PREFIX_BYTES) as u64,
            },
        }
    }
}
