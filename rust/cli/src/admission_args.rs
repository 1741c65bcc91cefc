//! The limits a run is admitted under, as flags: `antumbra serve` gives them to its daemon, and
//! `render`, `compare` and `trade` check themselves against them with the daemon's own
//! admission (`antumbra_protocol::admission`), so a run the daemon would refuse is refused here
//! too, with the same message and the flag that sets the limit.

use std::ops::RangeInclusive;

use antumbra_protocol::{
    Limits, ProtocolError, DEFAULT_MAX_RENDER_BYTES, DEFAULT_MAX_REQUEST_PASSES,
};
use clap::Args;

#[derive(Args, Debug, Clone)]
pub struct AdmissionArgs {
    /// Memory a frame may need at its peak, in MiB (a render, or every method or knob value of
    /// a comparison or trade together), estimated before it starts; past it the frame is
    /// refused (LimitExceeded from the daemon, exit code 1 on the command line).
    #[arg(long, default_value_t = DEFAULT_MAX_RENDER_BYTES >> 20)]
    pub render_memory_mb: u64,
    /// Method passes one request may ask for (methods or knob values x (1 + repeat), times the
    /// frames of a run), so that none runs for ever; past it the request is refused.
    #[arg(long, default_value_t = DEFAULT_MAX_REQUEST_PASSES)]
    pub max_request_passes: u64,
}

impl AdmissionArgs {
    /// The default limits with these two set.
    pub fn limits(&self) -> Limits {
        Limits {
            max_render_bytes: self.render_memory_mb.saturating_mul(1 << 20),
            max_request_passes: self.max_request_passes,
            ..Limits::default()
        }
    }
}

/// A refusal as a command-line error, naming the flag that sets the limit it is past.
pub fn refused(e: ProtocolError) -> anyhow::Error {
    let flag = match &e {
        ProtocolError::RenderMemory { .. }
        | ProtocolError::CompareMemory { .. }
        | ProtocolError::TradeMemory { .. } => "; --render-memory-mb sets the budget",
        ProtocolError::RequestPasses { .. } => "; --max-request-passes sets the bound",
        _ => "",
    };
    anyhow::anyhow!("{e}{flag}")
}

/// The frames of `range`, counted without overflow (`1-2147483647` is 2^31 - 1 frames).
pub fn frame_count(range: &RangeInclusive<i32>) -> u64 {
    (*range.end() as i64 - *range.start() as i64 + 1).max(0) as u64
}

/// `frames A-B` or `frame A`, naming a run in messages.
pub fn frames_text(range: &RangeInclusive<i32>) -> String {
    match range.start() == range.end() {
        true => format!("frame {}", range.start()),
        false => format!("frames {}-{}", range.start(), range.end()),
    }
}
