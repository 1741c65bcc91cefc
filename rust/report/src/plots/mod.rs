//! Plots drawn with plotters, as SVG (the viewer renders the text) or PNG (text drawn with the
//! DejaVu Sans subset in `fonts/`, which also measures the SVG's text for layout).
//! Every plot keeps its legend in a column of its own right of the chart, so it never covers
//! a mark, and colours series by their index in the same palette.

mod bars;
mod line;
mod pareto;

pub use bars::StackedBars;
pub use line::LinePlot;
pub use pareto::{pareto_front, ParetoPlot};

use plotters::coord::Shift;
use plotters::prelude::*;

/// Width of the legend column right of the plot.
const LEGEND_WIDTH: u32 = 220;

/// The font every plot's text is drawn and measured with, shipped so that PNGs are the same on
/// every machine.
const FONT: &[u8] = include_bytes!("../../fonts/DejaVuSans-subset.ttf");

/// Registers [`FONT`] as plotters' `sans-serif` (once).
fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
            .unwrap_or_else(|_| panic!("the shipped font parses"));
    });
}

/// The plot `draw` makes on a `width` x `height` SVG canvas, as SVG text.
fn to_svg(
    title: &str,
    width: u32,
    height: u32,
    draw: impl FnOnce(SVGBackend) -> Result<(), String>,
) -> anyhow::Result<String> {
    register_font();
    let mut svg = String::new();
    draw(SVGBackend::with_string(&mut svg, (width, height)))
        .map_err(|e| anyhow::anyhow!("plotting '{title}': {e}"))?;
    Ok(svg)
}

/// The plot `draw` makes on a `width` x `height` bitmap, written to `path` as PNG.
fn to_png(
    title: &str,
    path: &std::path::Path,
    width: u32,
    height: u32,
    draw: impl FnOnce(BitMapBackend) -> Result<(), String>,
) -> anyhow::Result<()> {
    register_font();
    let mut rgb = vec![0u8; width as usize * height as usize * 3];
    draw(BitMapBackend::with_buffer(&mut rgb, (width, height)))
        .map_err(|e| anyhow::anyhow!("plotting '{title}': {e}"))?;
    // The best compression: plots are committed to the docs, and they are small to encode.
    // Written atomically like every other file, so a reader never sees half a plot.
    let write = || -> anyhow::Result<()> {
        use image::codecs::png::{CompressionType, FilterType, PngEncoder};
        use image::ImageEncoder;
        let mut file = antumbra_core::atomic_file::AtomicFile::create(path)?;
        PngEncoder::new_with_quality(&mut file, CompressionType::Best, FilterType::Adaptive)
            .write_image(&rgb, width, height, image::ExtendedColorType::Rgb8)?;
        file.commit()?;
        Ok(())
    };
    write().map_err(|e| anyhow::anyhow!("writing {}: {e}", path.display()))
}

/// Series `i`'s colour.
fn colour(i: usize) -> PaletteColor<Palette99> {
    Palette99::pick(i)
}

/// A line of each name's colour and the name, one per row.
fn draw_legend<'a, DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    names: impl Iterator<Item = &'a str>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    for (i, name) in names.enumerate() {
        let y = 50 + 22 * i as i32;
        area.draw(&PathElement::new(
            vec![(8, y), (32, y)],
            colour(i).stroke_width(2),
        ))?;
        area.draw(&Text::new(
            name,
            (40, y - 7),
            ("sans-serif", 14).into_font().color(&BLACK),
        ))?;
    }
    Ok(())
}
