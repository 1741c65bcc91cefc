//! PNG output for people: shadow masks in 8-bit grey (the numbers live in the EXR).

use std::path::Path;

use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{ExtendedColorType, ImageEncoder};

use crate::atomic_file::write_atomic;
use crate::image::ImagePlane;
use crate::{Error, Result};

/// Writes a mask as an 8-bit grey PNG: value clamped to [0, 1] × 255, rounded (1 = lit = white,
/// 0 = shadowed = black; NaN counts as shadowed). Written atomically.
pub fn write_mask_png(path: &Path, plane: &ImagePlane) -> Result<()> {
    plane.check_size()?;
    let grey: Vec<u8> = plane.data.iter().map(|&v| mask_byte(v)).collect();
    encode_png(
        path,
        plane.width,
        plane.height,
        &grey,
        ExtendedColorType::L8,
    )
}

fn mask_byte(v: f32) -> u8 {
    if v.is_nan() {
        0
    } else {
        (v.clamp(0.0, 1.0) * 255.0).round() as u8
    }
}

/// Encodes 8-bit pixels (`L8` or `Rgb8`) into a PNG at `path`, atomically.
pub(crate) fn encode_png(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[u8],
    color: ExtendedColorType,
) -> Result<()> {
    write_atomic(path, |w| {
        PngEncoder::new_with_quality(w, CompressionType::Default, FilterType::Adaptive)
            .write_image(pixels, width, height, color)
            .map_err(|e| Error::io(path, e))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::file_names;
    use tempfile::TempDir;

    #[test]
    fn output_mask_png_values() {
        let dir = TempDir::new().unwrap();
        let path = dir.path().join("mask.png");
        let mut plane = ImagePlane::new("sun", 4, 2);
        plane.data = vec![0.0, 1.0, 0.5, 0.25, -3.0, 7.0, f32::NAN, 0.999];
        write_mask_png(&path, &plane).unwrap();
        let img = image::open(&path).unwrap();
        assert_eq!(img.color(), image::ColorType::L8);
        let grey = img.into_luma8();
        assert_eq!(grey.dimensions(), (4, 2));
        assert_eq!(grey.into_raw(), vec![0, 255, 128, 64, 0, 255, 0, 255]);
        assert_eq!(file_names(dir.path()), vec!["mask.png".to_string()]);
    }

    #[test]
    fn output_mask_png_rejects_bad_planes() {
        let dir = TempDir::new().unwrap();
        let empty = ImagePlane::new("empty", 0, 3);
        let err = write_mask_png(&dir.path().join("a.png"), &empty).unwrap_err();
        assert!(err.to_string().contains("empty"), "{err}");
        let mut short = ImagePlane::new("short", 2, 2);
        short.data.pop();
        let err = write_mask_png(&dir.path().join("b.png"), &short).unwrap_err();
        assert!(
            matches!(err, Error::Invalid { .. }) && err.to_string().contains("short"),
            "{err}"
        );
        assert!(file_names(dir.path()).is_empty());
    }
}
