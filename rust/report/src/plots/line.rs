//! Line plots of per-frame numbers (the benchmarks' and comparisons' curves).

use std::path::Path;

use antumbra_core::atomic_file::write_bytes_atomic;
use anyhow::Result;
use plotters::prelude::*;

use super::{draw_legend, LEGEND_WIDTH};

/// A titled plot of named series against the frame number (`first_frame` for each series' first
/// value), y from 0 to just above the largest value, with ticks on both axes.
pub struct LinePlot<'a> {
    pub title: &'a str,
    pub y_label: &'a str,
    pub first_frame: i32,
    pub series: &'a [(String, Vec<f64>)],
    /// Per series and frame, the range of the repeated measurements (the slowest and fastest
    /// timed pass), drawn as a bar through the point: a reader sees the noise beside the trend.
    pub ranges: Option<&'a [Vec<(f64, f64)>]>,
}

impl LinePlot<'_> {
    /// Writes the plot as a `width` x `height` SVG file.
    pub fn write_svg(&self, path: &Path, width: u32, height: u32) -> Result<()> {
        let svg = self.svg(width, height)?;
        write_bytes_atomic(path, svg.as_bytes())?;
        Ok(())
    }

    /// The plot as SVG text.
    pub fn svg(&self, width: u32, height: u32) -> Result<String> {
        super::to_svg(self.title, width, height, |b| self.draw(b))
    }

    fn draw<DB: DrawingBackend>(&self, backend: DB) -> Result<(), String> {
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        let root = backend.into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (width, _) = root.dim_in_pixel();
        let (plot_area, legend_area) = root.split_horizontally(width.saturating_sub(LEGEND_WIDTH));
        let range_tops = self
            .ranges
            .into_iter()
            .flatten()
            .flat_map(|r| r.iter().map(|&(_, hi)| hi));
        let y_max = self
            .series
            .iter()
            .flat_map(|(_, v)| v.iter().copied())
            .chain(range_tops)
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max)
            .max(1e-9)
            * 1.05;
        let longest = self.series.iter().map(|(_, v)| v.len()).max().unwrap_or(1);
        let first = self.first_frame;
        let last = first + longest.max(2) as i32 - 1;
        let mut chart = ChartBuilder::on(&plot_area)
            .caption(self.title, ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(first..last, 0.0..y_max)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("frame")
            .y_desc(self.y_label)
            .draw()
            .map_err(err)?;
        for (i, (_, values)) in self.series.iter().enumerate() {
            let color = super::colour(i).stroke_width(2);
            let points = values
                .iter()
                .enumerate()
                .map(|(k, &v)| (first + k as i32, v));
            chart
                .draw_series(LineSeries::new(points, color))
                .map_err(err)?;
            let ranges = self.ranges.and_then(|r| r.get(i)).into_iter().flatten();
            let bars = ranges.enumerate().map(|(k, &(lo, hi))| {
                let x = first + k as i32;
                PathElement::new(vec![(x, lo), (x, hi)], super::colour(i).stroke_width(1))
            });
            chart.draw_series(bars).map_err(err)?;
        }
        draw_legend(&legend_area, self.series.iter().map(|(n, _)| n.as_str())).map_err(err)?;
        root.present().map_err(err)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svg_has_title_ticks_legend_and_curves() {
        let dir = tempfile::TempDir::new().unwrap();
        let path = dir.path().join("plot.svg");
        let series = [
            ("SAH (1.00)".to_string(), vec![1.0, 2.0, 1.5, 1.0]),
            ("OSAH (2.00)".to_string(), vec![2.0, 2.5, 2.0, 1.5]),
        ];
        LinePlot {
            ranges: None,
            title: "bedroom: primary Mrays/s per frame",
            y_label: "Mrays/s",
            first_frame: 1,
            series: &series,
        }
        .write_svg(&path, 900, 420)
        .unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..80]);
        for text in [
            "bedroom: primary Mrays/s per frame",
            "SAH (1.00)",
            "OSAH (2.00)",
            "frame",
        ] {
            assert!(svg.contains(text), "{text} missing");
        }
        // x ticks: the frame numbers 1..=4 are labelled.
        for frame in 1..=4 {
            assert!(
                svg.contains(&format!(">\n{frame}\n</text>")),
                "tick {frame}"
            );
        }
        // Curves and legend lines are the only lines two pixels wide.
        assert_eq!(svg.matches(r#"stroke-width="2""#).count(), 2 + 2);
    }
}
