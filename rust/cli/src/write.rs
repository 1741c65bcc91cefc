//! Writing one frame's results: an EXR with every plane (numbers), PNGs for people, and the
//! statistics table.

use std::path::{Path, PathBuf};

use antumbra_core::output::{
    write_exr, write_heatmap_png, write_mask_png, ColorMap, HeatScale, ImagePlane,
};
use antumbra_core::render::FrameResult;
use anyhow::Result;

/// File names of one frame, all under `dir`: `frame_0001.exr` and `frame_0001_<plane>.png`.
pub fn frame_files(dir: &Path, frame: i32) -> (PathBuf, impl Fn(&str) -> PathBuf + '_) {
    let exr = dir.join(format!("frame_{frame:04}.exr"));
    let png = move |plane: &str| dir.join(format!("frame_{frame:04}_{}.png", sanitize(plane)));
    (exr, png)
}

fn sanitize(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Writes the frame's images; returns one line per heat map describing its colour scale.
pub fn write_frame(dir: &Path, result: &FrameResult) -> Result<Vec<String>> {
    let (exr, png) = frame_files(dir, result.frame);
    let mut planes: Vec<ImagePlane> = Vec::new();
    for m in &result.masks {
        let mut m = m.clone();
        m.name = format!("shadow.{}", m.name);
        planes.push(m);
    }
    planes.push(result.combined.clone());
    if let Some(h) = &result.heat {
        planes.extend(h.primary.iter().cloned());
        planes.extend(h.shadow.iter().cloned());
    }
    write_exr(&exr, &planes.iter().collect::<Vec<_>>())?;
    for m in &result.masks {
        write_mask_png(&png(&format!("shadow_{}", m.name)), m)?;
    }
    write_mask_png(&png("combined"), &result.combined)?;
    let mut scales = Vec::new();
    if let Some(h) = &result.heat {
        for p in h.primary.iter().chain(h.shadow.iter()) {
            let legend = write_heatmap_png(
                &png(&format!("heat_{}", p.name)),
                p,
                ColorMap::Turbo,
                HeatScale::Auto,
            )?;
            scales.push(format!(
                "{}: {} .. {} (turbo)",
                p.name, legend.min, legend.max
            ));
        }
    }
    Ok(scales)
}
