//! The legend strip under a heat map: a gradient bar of the colour map, the values at its two
//! ends and the plane's name, so a PNG on its own tells a reader what its colours mean.

use super::colormap::ColorMap;
use super::font::{text_width, Canvas, GLYPH_H};

/// Legend layout in font pixels (multiplied by the scale): separator line, gap, bar, gap, text, gap.
const SEPARATOR: u32 = 1;
const GAP: u32 = 2;
const BAR: u32 = 10;
const UNIT_HEIGHT: u32 = SEPARATOR + GAP + BAR + GAP + GLYPH_H + GAP;

const BACKGROUND: [u8; 3] = [24, 24, 24];
const SEPARATOR_COLOR: [u8; 3] = [96, 96, 96];
const TEXT: [u8; 3] = [240, 240, 240];

/// Text scale: larger images get larger text so it stays readable when the image is viewed whole.
fn scale(width: u32) -> u32 {
    (width / 400).clamp(1, 3)
}

/// Height in pixels of the legend strip added below a heat map `width` pixels wide.
pub fn heat_legend_height(width: u32) -> u32 {
    UNIT_HEIGHT * scale(width)
}

/// Rows `bar_rows(width)` of the legend (relative to its top) hold the gradient; column x of the
/// bar shows the colour of t = x / (width - 1).
pub(crate) fn bar_rows(width: u32) -> std::ops::Range<u32> {
    let s = scale(width);
    (SEPARATOR + GAP) * s..(SEPARATOR + GAP + BAR) * s
}

/// Draws the legend into `rgb`, an RGB8 buffer of exactly `width` × `heat_legend_height(width)`.
pub(crate) fn draw_legend(
    rgb: &mut [u8],
    width: u32,
    map: ColorMap,
    min: f32,
    max: f32,
    label: &str,
) {
    let s = scale(width);
    let height = heat_legend_height(width);
    let mut canvas = Canvas { rgb, width, height };
    for y in 0..height as i64 {
        let color = if y < (SEPARATOR * s) as i64 {
            SEPARATOR_COLOR
        } else {
            BACKGROUND
        };
        for x in 0..width as i64 {
            canvas.put(x, y, color);
        }
    }
    let denom = width.saturating_sub(1).max(1) as f32;
    for x in 0..width {
        let color = map.map(x as f32 / denom);
        for y in bar_rows(width) {
            canvas.put(x as i64, y as i64, color);
        }
    }

    let y = ((SEPARATOR + GAP + BAR + GAP) * s) as i64;
    let margin = s as i64;
    let (lo, hi) = (format_value(min), format_value(max));
    let (lo_w, hi_w) = (text_width(&lo, s) as i64, text_width(&hi, s) as i64);
    let hi_x = (width as i64 - margin - hi_w).max(margin + lo_w + 2 * s as i64);
    canvas.text(margin, y, &lo, TEXT, s);
    canvas.text(hi_x, y, &hi, TEXT, s);
    // The label goes in the middle, only where it cannot collide with the numbers.
    let label = format!("{label} ({map})");
    let label_w = text_width(&label, s) as i64;
    let label_x = (width as i64 - label_w) / 2;
    let gap = text_width("  ", s) as i64;
    if label_x >= margin + lo_w + gap && label_x + label_w + gap <= hi_x {
        canvas.text(label_x, y, &label, TEXT, s);
    }
}

/// A short, exact-enough rendering of a scale value: integers as integers, otherwise 4
/// significant digits, switching to exponent form for very large or small magnitudes.
pub(crate) fn format_value(v: f32) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    if v == 0.0 {
        return "0".into(); // also for -0
    }
    let a = v.abs();
    if v.fract() == 0.0 && a < 1e7 {
        return format!("{}", v as i64);
    }
    if (1e-3..1e7).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
        return trim_zeros(&format!("{v:.decimals$}")).to_string();
    }
    let s = format!("{v:.3e}");
    match s.split_once('e') {
        Some((mantissa, exp)) => format!("{}e{exp}", trim_zeros(mantissa)),
        None => s,
    }
}

fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_legend_format_value() {
        assert_eq!(format_value(0.0), "0");
        assert_eq!(format_value(-0.0), "0");
        assert_eq!(format_value(37.0), "37");
        assert_eq!(format_value(-4.0), "-4");
        assert_eq!(format_value(0.5), "0.5");
        assert_eq!(format_value(12.345678), "12.35");
        assert_eq!(format_value(1234.56), "1235");
        assert_eq!(format_value(1.0e9), "1e9");
        assert_eq!(format_value(1.5e-6), "1.5e-6");
        assert_eq!(format_value(f32::NAN), "NaN");
        assert_eq!(format_value(f32::INFINITY), "inf");
    }

    #[test]
    fn output_legend_draws_any_width() {
        for width in [1, 2, 7, 40, 399, 400, 1280, 5000] {
            let h = heat_legend_height(width);
            let mut rgb = vec![0u8; (width * h * 3) as usize];
            draw_legend(
                &mut rgb,
                width,
                ColorMap::Turbo,
                0.0,
                123456.0,
                "primary.N_B",
            );
            let bar_y = bar_rows(width).start;
            let at = |x: u32, y: u32| {
                let i = ((y * width + x) * 3) as usize;
                [rgb[i], rgb[i + 1], rgb[i + 2]]
            };
            assert_eq!(at(0, bar_y), ColorMap::Turbo.map(0.0));
            if width > 1 {
                assert_eq!(at(width - 1, bar_y), ColorMap::Turbo.map(1.0));
            }
        }
    }
}
