//! Per-frame difference heat maps: each method's shadow-ray node visits per pixel (N_B summed
//! over lights and samples) minus the baseline's, written as `diff/<label>/frame_NNNN.png`.

use std::path::{Path, PathBuf};

use antumbra_core::compare::FrameComparison;
use antumbra_core::output::{difference_plane, difference_scale, frame_stem, write_difference_png};
use anyhow::{Context, Result};

/// One written difference image.
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

pub struct DiffMaps {
    out: PathBuf,
    baseline: String,
    pub maps: Vec<DiffMap>,
}

impl DiffMaps {
    pub fn new(out: &Path, baseline: &str) -> Self {
        DiffMaps {
            out: out.to_path_buf(),
            baseline: baseline.to_string(),
            maps: Vec::new(),
        }
    }

    /// The difference images of one frame, one per method but the baseline.
    pub fn add(&mut self, frame: &FrameComparison) -> Result<()> {
        let Some(base) = frame.methods.iter().find(|m| m.label == self.baseline) else {
            return Ok(());
        };
        let Some(base_heat) = &base.result.heat else {
            return Ok(());
        };
        for m in frame.methods.iter().filter(|m| m.label != self.baseline) {
            let Some(heat) = &m.result.heat else { continue };
            let name = format!("{} - {} N_B", m.label, self.baseline);
            let plane = difference_plane(&name, &heat.shadow[0], &base_heat.shadow[0])?;
            let scale = difference_scale(&plane);
            let file = Path::new("diff")
                .join(&m.label)
                .join(format!("{}.png", frame_stem(frame.frame)));
            let path = self.out.join(&file);
            std::fs::create_dir_all(path.parent().expect("a file in a folder"))
                .with_context(|| format!("creating {}", path.display()))?;
            write_difference_png(&path, &plane, scale)?;
            self.maps.push(DiffMap {
                label: m.label.clone(),
                frame: frame.frame,
                file,
                scale,
                total: plane.data.iter().map(|&v| v as f64).sum(),
            });
        }
        Ok(())
    }
}
