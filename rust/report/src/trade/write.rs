//! The trade's folder: `trade.csv` (every row), `plots/KNOB.svg` and `.png` (frame time
//! against error or work, Pareto front marked) and `trade.md` (per knob its values' figures and
//! the recommended value with its reason).

use std::fmt::Write as _;
use std::path::Path;

use antumbra_core::atomic_file::write_bytes_atomic;
use antumbra_core::trade::{
    recommend, summarise, to_csv, Knob, KnobKind, TradeRow, ValueSummary, LIT_THRESHOLD,
    REFERENCE_SPP, RMSE_BOUND,
};
use anyhow::{Context, Result};

use crate::plots::ParetoPlot;
use crate::Table;

/// Plot size in pixels (SVG and PNG alike).
const PLOT_SIZE: (u32, u32) = (760, 420);

/// What the run was: for the heading of trade.md.
pub struct RunInfo<'a> {
    pub scene: &'a str,
    /// `A-B`, or the frames one by one when they are not consecutive.
    pub frames: String,
    pub size: String,
    pub repeat: usize,
    /// The shared settings, `NAME=VALUE, ...`.
    pub common: String,
}

/// One knob's rows and summaries.
pub struct KnobReport<'a> {
    pub knob: &'a Knob,
    pub base: String,
    pub values: Vec<ValueSummary>,
}

impl<'a> KnobReport<'a> {
    pub fn of(knob: &'a Knob, rows: &[TradeRow]) -> Self {
        let mine: Vec<&TradeRow> = rows.iter().filter(|r| r.knob == knob.name).collect();
        KnobReport {
            knob,
            base: knob.base.to_string(),
            values: summarise(&mine),
        }
    }

    fn axis(&self) -> (String, fn(&ValueSummary) -> f64) {
        match self.knob.kind {
            KnobKind::Image => (format!("RMSE (reference: spp {REFERENCE_SPP})"), |v| {
                v.rmse.unwrap_or(0.0)
            }),
            KnobKind::Work => ("box + triangle tests per ray".into(), |v| v.work_per_ray),
        }
    }

    /// The Pareto plot as SVG and PNG under `plots/`.
    fn plot(&self, dir: &Path) -> Result<()> {
        let (y_label, y) = self.axis();
        let points: Vec<(String, (f64, f64))> = self
            .values
            .iter()
            .map(|v| {
                let name = if v.is_default {
                    format!("{} (default)", v.value)
                } else {
                    v.value.clone()
                };
                (name, (v.frame_ms, y(v)))
            })
            .collect();
        let title = match self.knob.kind {
            KnobKind::Image => format!("{}: error against frame time", self.knob.name),
            KnobKind::Work => format!("{}: work against frame time", self.knob.name),
        };
        let plot = ParetoPlot {
            title: &title,
            x_label: "ms per frame",
            y_label: &y_label,
            points: &points,
        };
        let (w, h) = PLOT_SIZE;
        let svg = dir.join(format!("{}.svg", self.knob.name));
        write_bytes_atomic(&svg, plot.svg(w, h)?.as_bytes())?;
        plot.png(&dir.join(format!("{}.png", self.knob.name)), w, h)
    }

    fn table(&self) -> Table {
        let image = self.knob.kind == KnobKind::Image;
        let mut header: Vec<String> = [
            "value",
            "frame ms",
            "spread ms",
            "build ms",
            "prep ms",
            "trace ms",
            "tests/ray",
        ]
        .map(String::from)
        .to_vec();
        if image {
            header.extend(["RMSE", "p99 abs", "flips"].map(String::from));
        } else {
            header.push("answers".into());
        }
        let opt = |x: Option<f64>| x.map_or("-".into(), |x| format!("{x:.4}"));
        let rows = self
            .values
            .iter()
            .map(|v| {
                let mut r = vec![
                    if v.is_default {
                        format!("**{}** (default)", v.value)
                    } else {
                        v.value.clone()
                    },
                    format!("{:.2}", v.frame_ms),
                    format!("{:.2}", v.spread_ms),
                    format!("{:.2}", v.build_ms),
                    format!("{:.2}", v.prep_ms),
                    format!("{:.2}", v.trace_ms),
                    format!("{:.2}", v.work_per_ray),
                ];
                if image {
                    r.extend([opt(v.rmse), opt(v.p99_abs), opt(v.flip_share)]);
                } else {
                    r.push(match v.answers_equal {
                        Some(true) => "equal".into(),
                        Some(false) => "DIFFER".into(),
                        None => "-".into(),
                    });
                }
                r
            })
            .collect();
        Table {
            title: format!("{} ({} knob)", self.knob.name, self.knob.kind.name()),
            note: format!(
                "Trades {}. Varied from `{}`.\n\n![{}](plots/{}.png)",
                self.knob.trades, self.base, self.knob.name, self.knob.name
            ),
            header,
            rows,
            folded: false,
        }
    }
}

/// Writes trade.csv, the plots and trade.md into `out`.
pub fn write(out: &Path, info: &RunInfo, reports: &[KnobReport], rows: &[TradeRow]) -> Result<()> {
    let plots = out.join("plots");
    std::fs::create_dir_all(&plots).with_context(|| format!("creating {}", plots.display()))?;
    write_bytes_atomic(&out.join("trade.csv"), to_csv(rows).as_bytes())?;
    for r in reports {
        r.plot(&plots)?;
    }
    write_bytes_atomic(&out.join("trade.md"), markdown(info, reports).as_bytes())?;
    Ok(())
}

/// The recommendation table: one line per knob.
pub fn recommendations(reports: &[KnobReport]) -> Table {
    let rows = reports
        .iter()
        .map(|r| {
            let default = r
                .values
                .iter()
                .find(|v| v.is_default)
                .map_or("-".into(), |v| v.value.clone());
            let (value, reason) = recommend(r.knob.kind, &r.values)
                .map_or(("-".into(), "no values".into()), |rec| {
                    (rec.value, rec.reason)
                });
            vec![r.knob.name.to_string(), default, value, reason]
        })
        .collect();
    Table {
        title: "Recommendations".into(),
        note: format!(
            "Work knobs: the fastest value; a value slower than it by no more than the \
             measured spread (the larger of the two values' mean max - min over the timed \
             passes) ties with it, and a tie goes to the value with the fewest box and \
             triangle tests per ray, then to the default. Image knobs: the fastest value whose \
             mean RMSE against the reference (spp {REFERENCE_SPP}, full resolution) is at most \
             {RMSE_BOUND}, else the most accurate."
        ),
        header: ["knob", "default", "recommended", "why"]
            .map(String::from)
            .to_vec(),
        rows,
        folded: false,
    }
}

fn markdown(info: &RunInfo, reports: &[KnobReport]) -> String {
    let mut s = format!("# Trade: {}\n\n", info.scene);
    let _ = writeln!(
        s,
        "Frames {}, {}, {} timed passes per value and frame (interleaved), shared settings: {}. \
         Times are means over frames of the per-frame medians; tests/ray is box plus triangle \
         tests per ray over every ray (primary and shadow). Image knobs: per light and frame, \
         RMSE, 99th-percentile absolute error and the share of pixels whose class flips (lit \
         when the mask is at least {LIT_THRESHOLD}) against the reference, lower resolutions \
         upsampled bilinearly first.\n",
        info.frames,
        info.size,
        info.repeat,
        if info.common.is_empty() {
            "none"
        } else {
            &info.common
        }
    );
    s += &recommendations(reports).markdown();
    for r in reports {
        s += "\n";
        s += &r.table().markdown();
    }
    s
}
