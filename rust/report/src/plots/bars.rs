//! Stacked bars: one bar per item (a method), split into named parts (build, preparation,
//! trace) whose heights add up to the item's total.

use anyhow::Result;
use plotters::prelude::*;

use super::{colour, draw_legend, LEGEND_WIDTH};

pub struct StackedBars<'a> {
    pub title: &'a str,
    pub y_label: &'a str,
    /// The parts' names, bottom to top.
    pub parts: &'a [&'a str],
    /// Each bar's name and its parts' values (in `parts` order).
    pub bars: &'a [(String, Vec<f64>)],
}

impl StackedBars<'_> {
    pub fn svg(&self, width: u32, height: u32) -> Result<String> {
        super::to_svg(self.title, width, height, |b| self.draw(b))
    }

    fn draw<DB: DrawingBackend>(&self, backend: DB) -> Result<(), String> {
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        let root = backend.into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (width, _) = root.dim_in_pixel();
        let (plot_area, legend_area) = root.split_horizontally(width.saturating_sub(LEGEND_WIDTH));
        let total = |v: &[f64]| v.iter().filter(|x| x.is_finite()).sum::<f64>();
        let y_max = self
            .bars
            .iter()
            .map(|(_, v)| total(v))
            .fold(0.0f64, f64::max)
            .max(1e-9)
            * 1.05;
        let n = self.bars.len().max(1);
        let names: Vec<String> = self.bars.iter().map(|(l, _)| l.clone()).collect();
        let mut chart = ChartBuilder::on(&plot_area)
            .caption(self.title, ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            // A segmented 0..k has k + 1 slots: one per bar.
            .build_cartesian_2d((0..n - 1).into_segmented(), 0.0..y_max)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n)
            .x_label_formatter(&|x| match x {
                SegmentValue::CenterOf(i) => names.get(*i).cloned().unwrap_or_default(),
                _ => String::new(),
            })
            .y_desc(self.y_label)
            .draw()
            .map_err(err)?;
        for (i, (_, values)) in self.bars.iter().enumerate() {
            let mut bottom = 0.0;
            for (k, v) in values.iter().enumerate() {
                let top = bottom + v.max(0.0);
                let mut bar = Rectangle::new(
                    [
                        (SegmentValue::Exact(i), bottom),
                        (SegmentValue::Exact(i + 1), top),
                    ],
                    colour(k).filled(),
                );
                bar.set_margin(0, 0, 12, 12);
                chart.draw_series(std::iter::once(bar)).map_err(err)?;
                bottom = top;
            }
        }
        draw_legend(&legend_area, self.parts.iter().copied()).map_err(err)?;
        root.present().map_err(err)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_rectangle_per_part_of_each_bar() {
        let bars = [
            ("base".to_string(), vec![1.0, 0.0, 3.0]),
            ("osah8".to_string(), vec![2.0, 0.5, 1.0]),
        ];
        let svg = StackedBars {
            title: "time per frame",
            y_label: "ms",
            parts: &["build", "preparation", "trace"],
            bars: &bars,
        }
        .svg(700, 400)
        .unwrap();
        for text in [
            "time per frame",
            "base",
            "osah8",
            "build",
            "preparation",
            "trace",
        ] {
            assert!(svg.contains(text), "{text} missing");
        }
        // The background and the six bar parts are the only rectangles.
        assert_eq!(svg.matches("<rect").count(), 1 + 6);
    }
}
