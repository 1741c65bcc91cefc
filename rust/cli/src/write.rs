//! Writing one frame's results the way every antumbra tool does (`frame_NNNN.exr` with every
//! plane, PNGs for people; see `antumbra_core::output::write_frame_files`), and describing the
//! heat maps' colour scales for the terminal.

use std::path::Path;

use antumbra_core::output::{write_frame_files, Outputs};
use antumbra_core::render::FrameResult;
use anyhow::Result;

/// Writes the frame's images (the statistics table is written for all frames by the caller);
/// returns one line per heat map describing its colour scale.
pub fn write_frame(dir: &Path, result: &FrameResult) -> Result<Vec<String>> {
    let outputs = Outputs {
        exr: true,
        png: true,
        stats: false,
    };
    let written = write_frame_files(dir, result, &outputs)?;
    Ok(written
        .legends
        .iter()
        .map(|l| format!("{}: {} .. {} (turbo)", l.label, l.min, l.max))
        .collect())
}
