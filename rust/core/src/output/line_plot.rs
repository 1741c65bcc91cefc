//! A minimal line plot as PNG (per-frame curves in the benchmarks), drawn with the legend font
//! so the project needs no plotting dependency.

use std::path::Path;

use image::ExtendedColorType;

use super::font::Canvas;
use super::png::encode_png;
use crate::Result;

const COLORS: [[u8; 3]; 6] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
];

/// Plots each named series against its index (x = 0, 1, ...), y from 0 to the largest value,
/// with a title and a legend, into a `width` x `height` PNG.
pub fn write_line_plot(
    path: &Path,
    title: &str,
    series: &[(String, Vec<f64>)],
    width: u32,
    height: u32,
) -> Result<()> {
    let mut rgb = vec![255u8; (width * height * 3) as usize];
    let mut c = Canvas {
        rgb: &mut rgb,
        width,
        height,
    };
    let (left, right, top, bottom) = (60i64, width as i64 - 20, 40i64, height as i64 - 30);
    let y_max = series
        .iter()
        .flat_map(|(_, v)| v.iter().copied())
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max)
        .max(1e-9)
        * 1.05;
    let x_max = series
        .iter()
        .map(|(_, v)| v.len())
        .max()
        .unwrap_or(1)
        .max(2)
        - 1;
    let black = [0, 0, 0];
    for x in left..=right {
        c.put(x, bottom, black);
    }
    for y in top..=bottom {
        c.put(left, y, black);
    }
    for k in 0..=4 {
        let v = y_max * k as f64 / 4.0;
        let y = bottom - ((bottom - top) as f64 * k as f64 / 4.0) as i64;
        for x in left - 4..left {
            c.put(x, y, black);
        }
        c.text(4, y - 3, &format!("{v:.2}"), black, 1);
    }
    c.text(left, 8, title, black, 2);
    c.text(right - 60, bottom + 12, &format!("frame {x_max}"), black, 1);
    let to_px = |i: usize, v: f64| {
        let x = left + ((right - left) as f64 * i as f64 / x_max as f64) as i64;
        let y = bottom - ((bottom - top) as f64 * (v / y_max)) as i64;
        (x, y)
    };
    for (s, (name, values)) in series.iter().enumerate() {
        let color = COLORS[s % COLORS.len()];
        for (i, pair) in values.windows(2).enumerate() {
            let (a, b) = (to_px(i, pair[0]), to_px(i + 1, pair[1]));
            line(&mut c, a, b, color);
        }
        let ly = top + 4 + 12 * s as i64;
        for x in left + 10..left + 30 {
            c.put(x, ly + 3, color);
        }
        c.text(left + 36, ly, name, color, 1);
    }
    encode_png(path, width, height, &rgb, ExtendedColorType::Rgb8)
}

fn line(c: &mut Canvas, (x0, y0): (i64, i64), (x1, y1): (i64, i64), color: [u8; 3]) {
    let steps = (x1 - x0).abs().max((y1 - y0).abs()).max(1);
    for t in 0..=steps {
        let x = x0 + (x1 - x0) * t / steps;
        let y = y0 + (y1 - y0) * t / steps;
        c.put(x, y, color);
    }
}
