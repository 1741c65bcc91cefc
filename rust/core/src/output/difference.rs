//! Difference images (one method's per-pixel work minus another's) as PNG through a diverging
//! colour map centred on zero: blue where the method does less work, red where it does more.

use std::path::Path;

use image::ExtendedColorType;

use super::png::encode_png;
use crate::image::ImagePlane;
use crate::{Error, Result};

/// Moreland's cool-warm end points and the white centre, in 8-bit sRGB.
const COOL: [f32; 3] = [59.0, 76.0, 192.0];
const WARM: [f32; 3] = [180.0, 4.0, 38.0];
const CENTRE: [f32; 3] = [247.0, 247.0, 247.0];

/// The colour of `t` in [-1, 1] (clamped); NaN is black.
pub fn diverging_rgb(t: f32) -> [u8; 3] {
    if t.is_nan() {
        return [0, 0, 0];
    }
    let t = t.clamp(-1.0, 1.0);
    let end = if t < 0.0 { COOL } else { WARM };
    let f = t.abs();
    std::array::from_fn(|c| (CENTRE[c] + (end[c] - CENTRE[c]) * f).round() as u8)
}

/// `a - b` per pixel, named `name`.
pub fn difference_plane(name: &str, a: &ImagePlane, b: &ImagePlane) -> Result<ImagePlane> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::invalid(
            name,
            format!(
                "planes of {}x{} and {}x{} cannot be subtracted",
                a.width, a.height, b.width, b.height
            ),
        ));
    }
    let mut d = ImagePlane::new(name, a.width, a.height);
    for (o, (x, y)) in d.data.iter_mut().zip(a.data.iter().zip(&b.data)) {
        *o = x - y;
    }
    Ok(d)
}

/// The largest absolute difference, the colour scale's end (at least 1, so an all-zero image
/// stays white).
pub fn difference_scale(plane: &ImagePlane) -> f32 {
    plane
        .data
        .iter()
        .filter(|v| v.is_finite())
        .fold(1.0f32, |m, v| m.max(v.abs()))
}

/// Writes `plane` with -`scale` blue, 0 white and +`scale` red.
pub fn write_difference_png(path: &Path, plane: &ImagePlane, scale: f32) -> Result<()> {
    plane.check_size()?;
    let rgb: Vec<u8> = plane
        .data
        .iter()
        .flat_map(|&v| diverging_rgb(v / scale))
        .collect();
    encode_png(
        path,
        plane.width,
        plane.height,
        &rgb,
        ExtendedColorType::Rgb8,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_is_white_and_signs_are_blue_and_red() {
        assert_eq!(diverging_rgb(0.0), [247, 247, 247]);
        assert_eq!(diverging_rgb(-1.0), [59, 76, 192]);
        assert_eq!(diverging_rgb(2.0), [180, 4, 38]);
        let [r, _, b] = diverging_rgb(-0.5);
        assert!(b > r);
        let [r, _, b] = diverging_rgb(0.5);
        assert!(r > b);
    }

    #[test]
    fn difference_and_scale() {
        let mut a = ImagePlane::new("a", 2, 1);
        let mut b = ImagePlane::new("b", 2, 1);
        a.data = vec![5.0, 1.0];
        b.data = vec![2.0, 4.0];
        let d = difference_plane("d", &a, &b).unwrap();
        assert_eq!(d.data, vec![3.0, -3.0]);
        assert_eq!(difference_scale(&d), 3.0);
        assert!(difference_plane("d", &a, &ImagePlane::new("c", 1, 1)).is_err());
    }
}
