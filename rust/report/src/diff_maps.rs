//! Per-frame difference heat maps: each method's shadow-ray node visits per pixel (N_B summed
//! over lights and samples) minus the baseline's, written as `diff/<label>/frame_NNNN.png`.

use std::path::{Path, PathBuf};

use antumbra_core::image::ImagePlane;
use antumbra_core::output::{difference_plane, difference_scale, frame_stem, write_difference_png};
use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

/// One written difference image.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiffMap {
    pub label: String,
    pub frame: i32,
    /// Relative to the report folder.
    pub file: PathBuf,
    /// Node visits per pixel at the ends of the colour scale (±scale).
    pub scale: f32,
    /// Sum over pixels of the difference (negative: the method visits fewer nodes).
    pub total: f64,
}

/// `label`'s heat plane minus the baseline's, per pixel.
pub fn difference(
    label: &str,
    baseline: &str,
    heat: &ImagePlane,
    base: &ImagePlane,
) -> Result<ImagePlane> {
    Ok(difference_plane(
        &format!("{label} - {baseline} N_B"),
        heat,
        base,
    )?)
}

/// The difference images of one frame, one per method but the baseline; `heat` holds each
/// method's shadow N_B plane by label, in method order; none without the baseline's plane.
pub fn write_diff_maps(
    out: &Path,
    frame: i32,
    baseline: &str,
    heat: &[(String, ImagePlane)],
) -> Result<Vec<DiffMap>> {
    let Some((_, base)) = heat.iter().find(|(l, _)| l == baseline) else {
        return Ok(Vec::new());
    };
    let mut maps = Vec::new();
    for (label, plane) in heat.iter().filter(|(l, _)| l != baseline) {
        let plane = difference(label, baseline, plane, base)?;
        let scale = difference_scale(&plane);
        let file = Path::new("diff")
            .join(label)
            .join(format!("{}.png", frame_stem(frame)));
        let path = out.join(&file);
        std::fs::create_dir_all(path.parent().expect("a file in a folder"))
            .with_context(|| format!("creating {}", path.display()))?;
        write_difference_png(&path, &plane, scale)?;
        maps.push(DiffMap {
            label: label.clone(),
            frame,
            file,
            scale,
            total: plane.data.iter().map(|&v| v as f64).sum(),
        });
    }
    Ok(maps)
}
