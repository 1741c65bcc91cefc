//! The image knobs' error of a light's mask against the reference's: RMSE, the 99th percentile
//! of the absolute error and the share of pixels whose lit/shadowed class flips; a mask of
//! another size is first upsampled bilinearly to the reference's.

use serde::{Deserialize, Serialize};

use crate::image::ImagePlane;

/// Shadow samples per pixel of the image knobs' reference (at the full resolution).
pub const REFERENCE_SPP: u32 = 256;

/// A pixel is lit when its mask value (the visible share of the light) is at least this.
pub const LIT_THRESHOLD: f32 = 0.5;

/// One mask's error against the reference's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MaskError {
    pub rmse: f64,
    /// 99th percentile (nearest rank) of the absolute error per pixel.
    pub p99_abs: f64,
    /// Share of pixels lit in one and shadowed in the other (see [`LIT_THRESHOLD`]).
    pub flip_share: f64,
}

/// `plane` resized to `width` x `height` by bilinear interpolation between pixel centres
/// (edges clamped): what a compositor's scale node does to a lower-resolution pass.
pub fn upsample(plane: &ImagePlane, width: u32, height: u32) -> ImagePlane {
    let mut out = ImagePlane::new(plane.name.clone(), width, height);
    let (sw, sh) = (plane.width as f32, plane.height as f32);
    // The source coordinate of a target pixel centre, its two neighbours and the weight.
    let axis = |i: u32, src: f32, dst: u32| {
        let u = ((i as f32 + 0.5) * src / dst as f32 - 0.5).clamp(0.0, src - 1.0);
        let i0 = u.floor() as u32;
        let i1 = (i0 + 1).min(src as u32 - 1);
        (i0, i1, u - i0 as f32)
    };
    for y in 0..height {
        let (y0, y1, fy) = axis(y, sh, height);
        for x in 0..width {
            let (x0, x1, fx) = axis(x, sw, width);
            let top = plane.get(x0, y0) * (1.0 - fx) + plane.get(x1, y0) * fx;
            let bottom = plane.get(x0, y1) * (1.0 - fx) + plane.get(x1, y1) * fx;
            out.data[(y * width + x) as usize] = top * (1.0 - fy) + bottom * fy;
        }
    }
    out
}

/// `mask`'s error against `reference` (upsampled first when smaller).
pub fn mask_error(mask: &ImagePlane, reference: &ImagePlane) -> MaskError {
    let resized;
    let mask = if (mask.width, mask.height) == (reference.width, reference.height) {
        mask
    } else {
        resized = upsample(mask, reference.width, reference.height);
        &resized
    };
    let n = reference.data.len().max(1);
    let mut abs: Vec<f32> = Vec::with_capacity(n);
    let (mut squares, mut flips) = (0.0f64, 0usize);
    for (&a, &b) in mask.data.iter().zip(&reference.data) {
        let d = (a - b).abs();
        abs.push(d);
        squares += f64::from(d) * f64::from(d);
        flips += usize::from((a >= LIT_THRESHOLD) != (b >= LIT_THRESHOLD));
    }
    abs.sort_by(f32::total_cmp);
    // Nearest rank: the smallest value at or above 99% of the pixels.
    let rank = ((0.99 * abs.len() as f64).ceil() as usize).clamp(1, abs.len().max(1)) - 1;
    MaskError {
        rmse: (squares / n as f64).sqrt(),
        p99_abs: abs.get(rank).copied().map_or(0.0, f64::from),
        flip_share: flips as f64 / n as f64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane(w: u32, h: u32, data: Vec<f32>) -> ImagePlane {
        ImagePlane {
            name: "L".into(),
            width: w,
            height: h,
            data,
        }
    }

    #[test]
    fn equal_masks_have_no_error() {
        let a = plane(2, 2, vec![0.0, 0.25, 1.0, 0.5]);
        assert_eq!(mask_error(&a, &a), MaskError::default());
    }

    #[test]
    fn rmse_percentile_and_flips() {
        let reference = plane(10, 10, vec![1.0; 100]);
        let mut data = vec![1.0; 100];
        data[0] = 0.0; // flips, error 1
        data[1] = 0.6; // stays lit, error 0.4
        let e = mask_error(&plane(10, 10, data), &reference);
        assert!((e.rmse - ((1.0 + 0.16f64) / 100.0).sqrt()).abs() < 1e-6);
        // 99th of 100 sorted errors is the second largest.
        assert!((e.p99_abs - 0.4).abs() < 1e-6, "{e:?}");
        assert_eq!(e.flip_share, 0.01);
    }

    #[test]
    fn upsampling_keeps_constants_and_interpolates_between_centres() {
        let flat = upsample(&plane(2, 1, vec![0.5, 0.5]), 8, 4);
        assert!(flat.data.iter().all(|&v| v == 0.5));
        let ramp = upsample(&plane(2, 1, vec![0.0, 1.0]), 4, 1);
        assert_eq!(ramp.data, vec![0.0, 0.25, 0.75, 1.0]);
        let small = plane(2, 1, vec![0.0, 1.0]);
        let e = mask_error(&small, &plane(4, 1, vec![0.0, 0.25, 0.75, 1.0]));
        assert_eq!(e, MaskError::default());
    }
}
