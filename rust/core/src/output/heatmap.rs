//! Heat-map PNGs: a plane through a colour map, with a legend strip below that shows the scale.

use std::path::Path;

use image::ExtendedColorType;

use super::colormap::ColorMap;
use super::legend::{draw_legend, heat_legend_height};
use super::png::encode_png;
use crate::image::ImagePlane;
use crate::{Error, Result};

/// How plane values are mapped onto the colour map. Both scales start at 0, so zero work is
/// always the colour map's first colour and images of one scene compare by eye.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HeatScale {
    /// 0 → first colour, `max` (finite, > 0) → last colour; larger values are clamped.
    /// A fixed `max` makes heat maps of several frames or builders comparable.
    Linear { max: f32 },
    /// `max` is the plane's largest finite value.
    Auto,
}

/// The mapping a heat map was drawn with: values `min ..= max` span the colour map.
#[derive(Clone, Debug, PartialEq)]
pub struct HeatLegend {
    pub min: f32,
    pub max: f32,
    /// The plane's name.
    pub label: String,
}

impl std::fmt::Display for HeatLegend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {} .. {}", self.label, self.min, self.max)
    }
}

impl HeatScale {
    fn range(self, plane: &ImagePlane) -> Result<(f32, f32)> {
        match self {
            HeatScale::Linear { max } if max.is_finite() && max > 0.0 => Ok((0.0, max)),
            HeatScale::Linear { max } => Err(Error::invalid(
                format!("heat map '{}'", plane.name),
                format!("linear scale max must be finite and > 0, got {max}"),
            )),
            // A plane with nothing above 0 keeps max = 0: everything shows as the first colour.
            HeatScale::Auto => Ok((0.0, plane.range().1.max(0.0))),
        }
    }
}

/// Writes `plane` as a colour-mapped PNG with a legend strip below it (total height: the plane's
/// height + [`heat_legend_height`]`(width)`). Values map linearly from the scale's min (first colour) to
/// its max (last colour), clamped; NaN is black. Written atomically.
pub fn write_heatmap_png(
    path: &Path,
    plane: &ImagePlane,
    map: ColorMap,
    scale: HeatScale,
) -> Result<HeatLegend> {
    plane.check_size()?;
    let (min, max) = scale.range(plane)?;
    let (w, h) = (plane.width, plane.height);
    let legend_h = heat_legend_height(w);
    let total_h = h.checked_add(legend_h).ok_or_else(|| {
        Error::invalid(
            format!("heat map '{}'", plane.name),
            "image too tall for a legend",
        )
    })?;
    let mut rgb = vec![0u8; w as usize * total_h as usize * 3];
    let (image_part, legend_part) = rgb.split_at_mut(plane.data.len() * 3);
    colorize_into(image_part, plane, map, min, max);
    draw_legend(legend_part, w, map, min, max, &plane.name);
    encode_png(path, w, total_h, &rgb, ExtendedColorType::Rgb8)?;
    Ok(HeatLegend {
        min,
        max,
        label: plane.name.clone(),
    })
}

/// `plane` through the colour map as 8-bit sRGB, rows as in the plane, without a legend: what a
/// heat-map PNG shows, for viewers that draw their own scale (the Blender add-on).
pub fn heatmap_rgb(
    plane: &ImagePlane,
    map: ColorMap,
    scale: HeatScale,
) -> Result<(Vec<u8>, HeatLegend)> {
    plane.check_size()?;
    let (min, max) = scale.range(plane)?;
    let mut rgb = vec![0u8; plane.data.len() * 3];
    colorize_into(&mut rgb, plane, map, min, max);
    Ok((
        rgb,
        HeatLegend {
            min,
            max,
            label: plane.name.clone(),
        },
    ))
}

fn colorize_into(rgb: &mut [u8], plane: &ImagePlane, map: ColorMap, min: f32, max: f32) {
    for (px, &v) in rgb.chunks_exact_mut(3).zip(&plane.data) {
        px.copy_from_slice(&map.map(normalize(v, min, max)));
    }
}

/// `v` as a fraction of `min ..= max` (unclamped; the colour map clamps). An empty range maps
/// everything to 0; NaN stays NaN.
fn normalize(v: f32, min: f32, max: f32) -> f32 {
    if max > min {
        (v - min) / (max - min)
    } else if v.is_nan() {
        v
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::file_names;
    use crate::output::legend::bar_rows;
    use tempfile::TempDir;

    fn pixel(img: &image::RgbImage, x: u32, y: u32) -> [u8; 3] {
        img.get_pixel(x, y).0
    }

    #[test]
    fn output_heatmap_png_auto_scale_and_legend() {
        let dir = TempDir::new().unwrap();
        let path = dir.path().join("heat.png");
        let mut plane = ImagePlane::new("primary.N_B", 5, 3);
        for (i, v) in plane.data.iter_mut().enumerate() {
            *v = i as f32; // 0 .. 14
        }
        plane.data[7] = f32::NAN;
        plane.data[8] = f32::INFINITY; // not finite: ignored by Auto, clamped to the top colour
        let legend = write_heatmap_png(&path, &plane, ColorMap::Turbo, HeatScale::Auto).unwrap();
        assert_eq!(
            legend,
            HeatLegend {
                min: 0.0,
                max: 14.0,
                label: "primary.N_B".into()
            }
        );
        assert_eq!(legend.to_string(), "primary.N_B: 0 .. 14");

        let img = image::open(&path).unwrap();
        assert_eq!(img.color(), image::ColorType::Rgb8);
        let img = img.into_rgb8();
        assert_eq!(img.dimensions(), (5, 3 + heat_legend_height(5)));
        for y in 0..3 {
            for x in 0..5 {
                let v = plane.get(x, y);
                let expected = match v {
                    v if v.is_nan() => [0, 0, 0],
                    v if v.is_infinite() => ColorMap::Turbo.map(1.0),
                    v => ColorMap::Turbo.map(v / 14.0),
                };
                assert_eq!(pixel(&img, x, y), expected, "pixel {x},{y} value {v}");
            }
        }
        let bar_y = 3 + bar_rows(5).start;
        assert_eq!(pixel(&img, 0, bar_y), ColorMap::Turbo.map(0.0));
        assert_eq!(pixel(&img, 4, bar_y), ColorMap::Turbo.map(1.0));
        assert_eq!(file_names(dir.path()), vec!["heat.png".to_string()]);
    }

    #[test]
    fn output_heatmap_png_linear_scale_clamps() {
        let dir = TempDir::new().unwrap();
        let path = dir.path().join("heat.png");
        let mut plane = ImagePlane::new("N_T", 4, 1);
        plane.data = vec![0.0, 5.0, 10.0, 40.0];
        let legend = write_heatmap_png(
            &path,
            &plane,
            ColorMap::Viridis,
            HeatScale::Linear { max: 10.0 },
        )
        .unwrap();
        assert_eq!((legend.min, legend.max), (0.0, 10.0));
        let img = image::open(&path).unwrap().into_rgb8();
        let v = ColorMap::Viridis;
        assert_eq!(pixel(&img, 0, 0), v.map(0.0));
        assert_eq!(pixel(&img, 1, 0), v.map(0.5));
        assert_eq!(pixel(&img, 2, 0), v.map(1.0));
        assert_eq!(pixel(&img, 3, 0), v.map(1.0));
    }

    #[test]
    fn output_heatmap_png_all_zero_plane() {
        let dir = TempDir::new().unwrap();
        let path = dir.path().join("heat.png");
        let plane = ImagePlane::new("idle", 3, 2);
        let legend = write_heatmap_png(&path, &plane, ColorMap::Turbo, HeatScale::Auto).unwrap();
        assert_eq!((legend.min, legend.max), (0.0, 0.0));
        let img = image::open(&path).unwrap().into_rgb8();
        assert_eq!(pixel(&img, 2, 1), ColorMap::Turbo.map(0.0));
    }

    #[test]
    fn output_heatmap_png_rejects_bad_input() {
        let dir = TempDir::new().unwrap();
        let path = dir.path().join("heat.png");
        let plane = ImagePlane::new("N_L", 2, 2);
        for max in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            let err = write_heatmap_png(&path, &plane, ColorMap::Turbo, HeatScale::Linear { max })
                .unwrap_err();
            assert!(err.to_string().contains("N_L"), "{err}");
        }
        let empty = ImagePlane::new("empty", 3, 0);
        assert!(write_heatmap_png(&path, &empty, ColorMap::Turbo, HeatScale::Auto).is_err());
        assert!(file_names(dir.path()).is_empty());
    }
}
