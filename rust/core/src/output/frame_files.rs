//! One rendered frame as files, as `antumbra render` writes them: `frame_NNNN.exr` with every
//! plane, `frame_NNNN_<plane>.png` for people, and the frame's statistics as `stats.json`.

use std::path::Path;

use super::names::{file_safe, mask_names};
use super::{write_exr, write_heatmap_png, write_mask_png, ColorMap, HeatLegend, HeatScale};
use crate::image::ImagePlane;
use crate::render::FrameResult;
use crate::stats::write_json;
use serde::{Deserialize, Serialize};

/// Which files a frame gets. Every field defaults to true.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Outputs {
    /// `frame_NNNN.exr`: every plane as 32-bit float (`shadow.<light>`, `combined`,
    /// `primary.N_B|N_L|N_T`, `shadow.N_B|N_L|N_T`).
    pub exr: bool,
    /// `frame_NNNN_shadow_<light>.png`, `frame_NNNN_combined.png` and
    /// `frame_NNNN_heat_<plane>.png` (turbo colour map with its scale).
    pub png: bool,
    /// `stats.json`: the frame's statistics rows.
    pub stats: bool,
}

impl Default for Outputs {
    fn default() -> Self {
        Outputs {
            exr: true,
            png: true,
            stats: true,
        }
    }
}

/// The folder and file stem of a frame: `frame_0007`.
pub fn frame_stem(frame: i32) -> String {
    format!("frame_{frame:04}")
}

/// The planes of a result in the EXR's order, named as the CLI and the protocol name them.
pub fn planes(result: &FrameResult) -> Vec<ImagePlane> {
    let mut planes: Vec<ImagePlane> = Vec::new();
    for (m, name) in result.masks.iter().zip(mask_names(result)) {
        let mut m = m.clone();
        m.name = name.plane;
        planes.push(m);
    }
    planes.push(result.combined.clone());
    if let Some(h) = &result.heat {
        planes.extend(h.primary.iter().cloned());
        planes.extend(h.shadow.iter().cloned());
    }
    planes
}

/// What [`write_frame_files`] wrote: file names (relative to the folder) and the colour scale of
/// every heat map.
#[derive(Clone, Debug, Default)]
pub struct FrameFiles {
    pub files: Vec<String>,
    pub legends: Vec<HeatLegend>,
}

/// Writes the files of one frame into `dir` (which exists), each atomically.
pub fn write_frame_files(
    dir: &Path,
    result: &FrameResult,
    outputs: &Outputs,
) -> crate::Result<FrameFiles> {
    let stem = frame_stem(result.frame);
    let mut files = Vec::new();
    let mut legends = Vec::new();
    if outputs.exr {
        let name = format!("{stem}.exr");
        let planes = planes(result);
        write_exr(&dir.join(&name), &planes.iter().collect::<Vec<_>>())?;
        files.push(name);
    }
    if outputs.png {
        let mut png = |plane: &str| {
            let name = format!("{stem}_{}.png", file_safe(plane));
            files.push(name.clone());
            dir.join(name)
        };
        for (m, name) in result.masks.iter().zip(mask_names(result)) {
            write_mask_png(&png(&name.file), m)?;
        }
        write_mask_png(&png("combined"), &result.combined)?;
        if let Some(h) = &result.heat {
            for p in h.primary.iter().chain(h.shadow.iter()) {
                legends.push(write_heatmap_png(
                    &png(&format!("heat_{}", p.name)),
                    p,
                    ColorMap::Turbo,
                    HeatScale::Auto,
                )?);
            }
        }
    }
    if outputs.stats {
        write_json(&dir.join("stats.json"), &result.stats)?;
        files.push("stats.json".into());
    }
    Ok(FrameFiles { files, legends })
}
