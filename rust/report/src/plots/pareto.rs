//! A scatter of named points (a method's work against its time, both lower is better) with
//! the Pareto front marked: the points no other point beats on both axes.

use anyhow::Result;
use plotters::prelude::*;

use super::{colour, draw_legend, LEGEND_WIDTH};

/// Indices of the points that no other point is at least as good as on both axes and better
/// on one (lower is better on both), in increasing x.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let dominated = |i: usize| {
        let (x, y) = points[i];
        points
            .iter()
            .any(|&(a, b)| a <= x && b <= y && (a < x || b < y))
    };
    let mut front: Vec<usize> = (0..points.len()).filter(|&i| !dominated(i)).collect();
    front.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0));
    front
}

pub struct ParetoPlot<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    /// Each point's name and (x, y).
    pub points: &'a [(String, (f64, f64))],
}

impl ParetoPlot<'_> {
    pub fn svg(&self, width: u32, height: u32) -> Result<String> {
        super::to_svg(self.title, width, height, |b| self.draw(b))
    }

    /// The same plot as a PNG file at `path`.
    pub fn png(&self, path: &std::path::Path, width: u32, height: u32) -> Result<()> {
        super::to_png(self.title, path, width, height, |b| self.draw(b))
    }

    fn draw<DB: DrawingBackend>(&self, backend: DB) -> Result<(), String> {
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        let root = backend.into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (width, _) = root.dim_in_pixel();
        let (plot_area, legend_area) = root.split_horizontally(width.saturating_sub(LEGEND_WIDTH));
        let xy: Vec<(f64, f64)> = self.points.iter().map(|(_, p)| *p).collect();
        let max = |f: fn(&(f64, f64)) -> f64| {
            xy.iter()
                .map(f)
                .filter(|v| v.is_finite())
                .fold(0.0f64, f64::max)
                .max(1e-9)
                * 1.1
        };
        let mut chart = ChartBuilder::on(&plot_area)
            .caption(self.title, ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..max(|p| p.0), 0.0..max(|p| p.1))
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(self.x_label)
            .y_desc(self.y_label)
            .draw()
            .map_err(err)?;
        let front = pareto_front(&xy);
        chart
            .draw_series(LineSeries::new(
                front.iter().map(|&i| xy[i]),
                BLACK.stroke_width(1),
            ))
            .map_err(err)?;
        for (i, p) in xy.iter().enumerate() {
            let on_front = front.contains(&i);
            let style = if on_front {
                colour(i).filled()
            } else {
                colour(i).stroke_width(2)
            };
            chart
                .draw_series(std::iter::once(Circle::new(*p, 7, style)))
                .map_err(err)?;
        }
        let names: Vec<String> = self
            .points
            .iter()
            .enumerate()
            .map(|(i, (n, _))| {
                if front.contains(&i) {
                    format!("{n} (Pareto front)")
                } else {
                    n.clone()
                }
            })
            .collect();
        draw_legend(&legend_area, names.iter().map(String::as_str)).map_err(err)?;
        root.present().map_err(err)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn front_holds_exactly_the_undominated_points() {
        let p = [(1.0, 5.0), (2.0, 2.0), (3.0, 3.0), (4.0, 1.0), (2.0, 2.0)];
        // (3,3) is beaten by (2,2); the two equal (2,2) points do not beat each other.
        assert_eq!(pareto_front(&p), vec![0, 1, 4, 3]);
        assert_eq!(pareto_front(&[]), Vec::<usize>::new());
    }

    #[test]
    fn svg_marks_the_front_in_the_legend() {
        let points = [
            ("base".to_string(), (25.0, 10.0)),
            ("sorted8".to_string(), (7.0, 6.0)),
            ("slow".to_string(), (8.0, 9.0)),
        ];
        let svg = ParetoPlot {
            title: "time against work",
            x_label: "node visits per ray",
            y_label: "ms per frame",
            points: &points,
        }
        .svg(700, 400)
        .unwrap();
        assert!(svg.contains("sorted8 (Pareto front)"));
        assert!(!svg.contains("base (Pareto front)"));
        assert!(!svg.contains("slow (Pareto front)"));
        assert_eq!(svg.matches("<circle").count(), 3);
    }

    #[test]
    fn png_decodes_with_its_text_drawn() {
        let points = [("a".to_string(), (1.0, 2.0)), ("b".to_string(), (2.0, 1.0))];
        let plot = ParetoPlot {
            title: "A TITLE IN CAPITALS",
            x_label: "ms per frame",
            y_label: "tests per ray",
            points: &points,
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.png");
        plot.png(&path, 700, 400).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (700, 400));
        // The caption's band holds dark pixels: the title was drawn with the shipped font.
        let dark = img
            .enumerate_pixels()
            .filter(|(_, y, p)| *y < 30 && p.0.iter().all(|&c| c < 100))
            .count();
        assert!(dark > 50, "{dark} dark pixels in the caption");
    }
}
