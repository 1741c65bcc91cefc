//! The report's files: `compare.csv` (long form), `compare.json`, `summary.md`, `plots/*.svg`
//! and `report.html`. The summary tables are made once ([`Table`]) and printed as Markdown,
//! HTML and on the terminal.

use std::path::{Path, PathBuf};

use antumbra_core::atomic_file::write_bytes_atomic;
use antumbra_core::compare::{
    hindsight, pass_summaries, recommend, time_summaries, to_csv, CompareRow, Figures, Hindsight,
    JsonRow, MethodSpec, Mismatch, PassSummary, Recommendation, TimeSummary,
};
use antumbra_core::render::RenderSettings;
use anyhow::{Context, Result};
use serde::Serialize;

use crate::diff_maps::DiffMap;
use crate::html;
use crate::plots::{LinePlot, ParetoPlot, StackedBars};
use crate::table::Table;

/// Everything a comparison produced, over every recorded frame.
pub struct Report<'a> {
    pub scene: &'a str,
    pub specs: Vec<MethodSpec>,
    /// Each method's settings, resolved over the shared ones.
    pub settings: Vec<RenderSettings>,
    pub baseline: &'a str,
    pub repeat: usize,
    pub rows: Vec<CompareRow>,
    pub mismatches: Vec<Mismatch>,
    pub diffs: Vec<DiffMap>,
}

fn f2(x: f64) -> String {
    format!("{x:.2}")
}

fn f3(x: f64) -> String {
    format!("{x:.3}")
}

#[derive(Serialize)]
struct JsonMethod<'a> {
    label: &'a str,
    spec: String,
    method: String,
    settings: antumbra_core::settings::NamedSettings,
}

#[derive(Serialize)]
struct JsonMismatch<'a> {
    frame: i32,
    label: &'a str,
    what: &'a str,
    pixels: usize,
    /// An edge difference across scene structures, not a wrong answer.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    across_structures: bool,
}

#[derive(Serialize)]
struct JsonReport<'a> {
    scene: &'a str,
    baseline: &'a str,
    repeat: usize,
    methods: Vec<JsonMethod<'a>>,
    mismatches: Vec<JsonMismatch<'a>>,
    passes: &'a [PassSummary],
    times: &'a [TimeSummary],
    hindsight: Option<&'a Hindsight>,
    recommendation: Option<&'a Recommendation>,
    rows: Vec<JsonRow<'a>>,
}

impl Report<'_> {
    fn figures(&self) -> Figures {
        Figures::new(&self.rows)
    }

    /// What a per-frame or per-pass choice among the fixed methods could gain at most.
    fn hindsight(&self) -> Option<Hindsight> {
        let fixed: Vec<&str> = self
            .specs
            .iter()
            .zip(&self.settings)
            .filter(|(_, s)| !s.chooses())
            .map(|(spec, _)| spec.label.as_str())
            .collect();
        hindsight(&self.rows, &fixed)
    }

    /// Which method to use and why, in sentences (none without frame times).
    fn recommendation(&self, hindsight: Option<&Hindsight>) -> Option<Recommendation> {
        let labels: Vec<&str> = self.specs.iter().map(|s| s.label.as_str()).collect();
        recommend(
            &self.rows,
            &labels,
            self.baseline,
            &self.mismatches,
            hindsight,
        )
    }

    fn frame_span(&self) -> String {
        let first = self.rows.iter().map(|r| r.stats.frame).min().unwrap_or(0);
        let last = self.rows.iter().map(|r| r.stats.frame).max().unwrap_or(0);
        if first == last {
            format!("frame {first}")
        } else {
            format!("frames {first}-{last}")
        }
    }

    /// Writes every file into `out`; returns report.html's path.
    pub fn write(&self, out: &Path) -> Result<PathBuf> {
        let specs = &self.specs;
        let spec_of = |label: &str| {
            specs
                .iter()
                .find(|s| s.label == label)
                .map(|s| s.to_string())
                .unwrap_or_default()
        };
        write_bytes_atomic(
            &out.join("compare.csv"),
            to_csv(&self.rows, &spec_of).as_bytes(),
        )?;
        let figures = self.figures();
        let baseline = self.baseline;
        let passes = pass_summaries(&figures, baseline);
        let times = time_summaries(&figures, baseline);
        let hindsight = self.hindsight();
        let recommendation = self.recommendation(hindsight.as_ref());
        let json = JsonReport {
            scene: self.scene,
            baseline,
            repeat: self.repeat,
            methods: specs
                .iter()
                .zip(&self.settings)
                .map(|(s, settings)| JsonMethod {
                    label: &s.label,
                    spec: s.to_string(),
                    method: settings.method_name(),
                    settings: settings.to_named(),
                })
                .collect(),
            mismatches: self
                .mismatches
                .iter()
                .map(|m| JsonMismatch {
                    frame: m.frame,
                    label: &m.label,
                    what: &m.what,
                    pixels: m.pixels,
                    across_structures: m.across_structures,
                })
                .collect(),
            passes: &passes,
            times: &times,
            hindsight: hindsight.as_ref(),
            recommendation: recommendation.as_ref(),
            rows: self.rows.iter().map(JsonRow::from).collect(),
        };
        let text = serde_json::to_string_pretty(&json)?;
        write_bytes_atomic(&out.join("compare.json"), text.as_bytes())?;
        let tables = self.tables(&passes, &times, hindsight.as_ref(), recommendation.as_ref());
        let answer = answer(recommendation.as_ref());
        let mut md = format!("# {}\n\n", self.heading());
        if !answer.is_empty() {
            md += &format!("**What to use.** {}\n\n", answer.join(" "));
        }
        md += &format!("{}\n\n", self.verdict());
        for t in &tables {
            md += &t.markdown();
            md += "\n";
        }
        write_bytes_atomic(&out.join("summary.md"), md.as_bytes())?;
        let plots = self.plots(&figures, &times)?;
        let dir = out.join("plots");
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        for (name, _, svg) in &plots {
            write_bytes_atomic(&dir.join(format!("{name}.svg")), svg.as_bytes())?;
        }
        let page = html::page(
            &self.heading(),
            &answer,
            &self.verdict(),
            &tables,
            &plots,
            &self.diffs,
            out,
        )?;
        let path = out.join("report.html");
        write_bytes_atomic(&path, page.as_bytes())?;
        Ok(path)
    }

    fn heading(&self) -> String {
        format!(
            "antumbra compare: {}, {}, {} timed pass{} per method and frame",
            self.scene,
            self.frame_span(),
            self.repeat,
            if self.repeat == 1 { "" } else { "es" }
        )
    }

    fn verdict(&self) -> String {
        let (wrong, edges): (Vec<&Mismatch>, Vec<&Mismatch>) =
            self.mismatches.iter().partition(|m| m.is_wrong());
        let list = |ms: &[&Mismatch]| {
            ms.iter()
                .take(5)
                .map(|m| m.to_string())
                .collect::<Vec<_>>()
                .join("; ")
        };
        let mut verdict = if wrong.is_empty() {
            format!(
                "Every method's shadow masks and primary hits equal the baseline's ('{}') bit for \
                 bit on every frame{}.",
                self.baseline,
                if edges.is_empty() {
                    ""
                } else {
                    " where they trace the same scene structure"
                }
            )
        } else {
            format!(
                "{} answers differ from the baseline ('{}'): {}",
                wrong.len(),
                self.baseline,
                list(&wrong)
            )
        };
        if !edges.is_empty() {
            let pixels: usize = edges.iter().map(|m| m.pixels).sum();
            verdict += &format!(
                " Across scene structures (flat against two levels, whose instance transforms \
                 round differently), {pixels} pixels differ where rounding does (triangle \
                 edges, alpha lookups at hit points): {}.",
                list(&edges)
            );
        }
        verdict
    }

    /// The summary tables: methods, work per pass kind, time per frame, and the hindsight
    /// bounds when there are two fixed methods or more.
    pub fn tables(
        &self,
        passes: &[PassSummary],
        times: &[TimeSummary],
        hindsight: Option<&Hindsight>,
        recommendation: Option<&Recommendation>,
    ) -> Vec<Table> {
        let mut tables: Vec<Table> = recommendation.map(glance_table).into_iter().collect();
        tables.push(Table {
            title: "Methods".into(),
            note: "Settings not named take their defaults (docs/settings.md).".into(),
            header: vec!["label".into(), "settings".into(), "method".into()],
            rows: self
                .specs
                .iter()
                .zip(&self.settings)
                .map(|(s, st)| vec![s.label.clone(), format!("`{s}`"), st.method_name()])
                .collect(),
            folded: false,
        });
        for pass in ["shadow", "primary"] {
            let rows: Vec<Vec<String>> = passes
                .iter()
                .filter(|p| p.pass == pass)
                .map(|p| {
                    let mut r = vec![p.label.clone(), p.rays.to_string()];
                    r.extend(p.per_ray.iter().map(|v| f2(*v)));
                    r.extend(p.ratio.iter().map(|v| f3(*v)));
                    r.extend(p.mean_frame_ratio.iter().map(|v| f3(*v)));
                    r.push(f2(p.trace_ms));
                    r.push(f2(p.mrays_per_s));
                    r
                })
                .collect();
            if rows.is_empty() {
                continue;
            }
            let mut header: Vec<String> = vec!["method".into(), "rays".into()];
            for group in ["", " ratio", " mean ratio"] {
                for n in ["N_B", "N_L", "N_T", "N_box"] {
                    header.push(format!("{n}{group}"));
                }
            }
            header.push("trace ms".into());
            header.push("Mrays/s".into());
            tables.push(Table {
                title: format!(
                    "{} rays",
                    if pass == "shadow" {
                        "Shadow"
                    } else {
                        "Primary"
                    }
                ),
                note: "Work per ray over every frame (and every light); ratio: to the \
                       baseline's over all rays; mean ratio: the mean of the per-frame ratios. \
                       Trace ms: per frame, the median of the timed passes."
                    .into(),
                header,
                rows,
                folded: true,
            });
        }
        tables.push(Table {
            title: "Time per frame".into(),
            note: "Means over frames of the medians of the timed passes (counters compiled \
                   out, interleaved across methods). Build and rest: the frame less per-light \
                   preparation and tracing (BVH build or reuse, visible sets, combining)."
                .into(),
            header: [
                "method",
                "build and rest ms",
                "preparation ms",
                "trace ms",
                "frame ms",
                "frame ratio",
            ]
            .map(String::from)
            .to_vec(),
            rows: times
                .iter()
                .map(|t| {
                    vec![
                        t.label.clone(),
                        f2(t.build_ms),
                        f2(t.prep_ms),
                        f2(t.trace_ms),
                        f2(t.frame_ms),
                        f3(t.frame_ratio),
                    ]
                })
                .collect(),
            folded: false,
        });
        tables.extend(hindsight.map(hindsight_table));
        tables
    }

    /// The time table and the shadow work ratios, for the terminal.
    pub fn terminal_table(&self) -> String {
        let figures = self.figures();
        let passes = pass_summaries(&figures, self.baseline);
        let times = time_summaries(&figures, self.baseline);
        let hindsight = self.hindsight();
        let recommendation = self.recommendation(hindsight.as_ref());
        let tables = self.tables(&passes, &times, hindsight.as_ref(), recommendation.as_ref());
        let mut s = format!("{}\n", self.heading());
        for sentence in answer(recommendation.as_ref()) {
            s += &format!("{sentence}\n");
        }
        s += &format!("{}\n\n", self.verdict());
        for t in tables
            .iter()
            .filter(|t| !matches!(t.title.as_str(), "Methods" | "Primary rays" | GLANCE))
        {
            s += &t.plain();
            s += "\n";
        }
        s
    }

    /// `(file stem, caption, svg)` of every plot.
    fn plots(
        &self,
        figures: &Figures,
        times: &[TimeSummary],
    ) -> Result<Vec<(String, String, String)>> {
        let labels: Vec<&str> = figures.labels.iter().map(|(l, _)| l.as_str()).collect();
        let first = self.rows.iter().map(|r| r.stats.frame).min().unwrap_or(0);
        let curve = |f: &dyn Fn(&antumbra_core::compare::FrameFigures) -> f64| {
            labels
                .iter()
                .map(|l| (l.to_string(), figures.of(l).map(|(_, x)| f(x)).collect()))
                .collect::<Vec<(String, Vec<f64>)>>()
        };
        let shadow_nb = curve(&|x| x.work.get("shadow").map_or(0.0, |w| w.per_ray()[0]));
        let frame_ms = curve(&|x| x.frame_ms);
        // Each frame's fastest and slowest timed pass, per method, in the curves' order.
        let mut range: std::collections::BTreeMap<(&str, i32), (f64, f64)> = Default::default();
        for r in &self.rows {
            range.insert((&r.label, r.stats.frame), (r.frame_ms.min, r.frame_ms.max));
        }
        let frame_ranges: Vec<Vec<(f64, f64)>> = labels
            .iter()
            .map(|l| {
                figures
                    .of(l)
                    .map(|(f, x)| {
                        range
                            .get(&(*l, f))
                            .copied()
                            .unwrap_or((x.frame_ms, x.frame_ms))
                    })
                    .collect()
            })
            .collect();
        let mut plots = vec![
            (
                "shadow_nb".to_string(),
                "Shadow rays: interior nodes entered per ray (N_B), per frame".to_string(),
                LinePlot {
                    title: "shadow N_B per ray",
                    y_label: "N_B per ray",
                    first_frame: first,
                    series: &shadow_nb,
                    ranges: None,
                }
                .svg(900, 420)?,
            ),
            (
                "frame_ms".to_string(),
                "Frame time per method, per frame: the median of the timed passes (interleaved \
                 across methods), a bar from the fastest to the slowest of them"
                    .to_string(),
                LinePlot {
                    title: "frame time",
                    y_label: "ms",
                    first_frame: first,
                    series: &frame_ms,
                    ranges: Some(&frame_ranges),
                }
                .svg(900, 420)?,
            ),
        ];
        let bars: Vec<(String, Vec<f64>)> = times
            .iter()
            .map(|t| (t.label.clone(), vec![t.build_ms, t.prep_ms, t.trace_ms]))
            .collect();
        plots.push((
            "time_parts".into(),
            "Mean frame time split into build (and the rest), per-light preparation and trace"
                .into(),
            StackedBars {
                title: "time per frame",
                y_label: "ms",
                parts: &["build and rest", "preparation", "trace"],
                bars: &bars,
            }
            .svg(900, 420)?,
        ));
        // Work: nodes entered (N_B + N_L) per ray over every ray of every pass.
        let points: Vec<(String, (f64, f64))> = times
            .iter()
            .map(|t| {
                let (mut visits, mut rays) = (0.0, 0u64);
                for (_, f) in figures.of(&t.label) {
                    for w in f.work.values() {
                        visits += w.nb + w.nl;
                        rays += w.rays;
                    }
                }
                (t.label.clone(), (visits / rays.max(1) as f64, t.frame_ms))
            })
            .collect();
        plots.push((
            "pareto".into(),
            "Frame time against work (nodes entered per ray, all rays); filled: the Pareto front"
                .into(),
            ParetoPlot {
                title: "time against work",
                x_label: "nodes entered per ray",
                y_label: "ms per frame",
                points: &points,
            }
            .svg(900, 420)?,
        ));
        Ok(plots)
    }
}

/// The hindsight bounds and the choosing methods against the best fixed method.
fn hindsight_table(h: &Hindsight) -> Table {
    let row = |what: String, ms: f64| vec![what, f2(ms), f3(ms / h.best_ms)];
    let mut rows = vec![
        row(format!("best fixed method ({})", h.best_label), h.best_ms),
        row("each frame's fastest fixed method".into(), h.per_frame_ms),
        row(
            "each frame's fastest camera part and light passes".into(),
            h.per_pass_ms,
        ),
    ];
    rows.extend(h.choosers.iter().map(|(l, ms)| row(l.clone(), *ms)));
    Table {
        title: "Choosing per frame, in hindsight".into(),
        note: format!(
            "Totals over the {} frames every method rendered (sums of the per-frame medians). \
             The two hindsight rows pick among the fixed methods after the fact: the most any \
             choice per frame, or per light and frame, among them could save; the second may \
             pair one method's tree with another's order, so it is a bound, not a method. Noise \
             favours them: each takes the least of several noisy times.",
            h.frames
        ),
        header: ["what", "total ms", "ratio to the best fixed"]
            .map(String::from)
            .to_vec(),
        rows,
        folded: false,
    }
}

/// The answer's sentences (none without a recommendation).
fn answer(recommendation: Option<&Recommendation>) -> Vec<String> {
    recommendation.map_or_else(Vec::new, |r| r.sentences.clone())
}

const GLANCE: &str = "At a glance";

/// The key columns per method, fastest first: what the recommendation is read from.
fn glance_table(r: &Recommendation) -> Table {
    let fastest = r.methods.first().map_or(0.0, |m| m.frame_ms);
    Table {
        title: GLANCE.into(),
        note: format!(
            "Means per frame over the {} frames every method rendered whose answers equal the \
             baseline's, fastest first. Spread: the slowest timed pass less the fastest, a \
             frame's noise; a method within the spread of the fastest ties with it. Nodes: \
             interior and leaf nodes entered per ray, every ray of every pass.",
            r.frames
        ),
        header: [
            "method",
            "frame ms",
            "spread ms",
            "against the fastest",
            "preparation ms",
            "trace ms",
            "nodes per ray",
        ]
        .map(String::from)
        .to_vec(),
        rows: r
            .methods
            .iter()
            .map(|m| {
                let against = if m.label == r.label {
                    "fastest".to_string()
                } else if r.ties.contains(&m.label) {
                    format!("{:+.1}% (tie)", 100.0 * (m.frame_ms / fastest - 1.0))
                } else {
                    format!("{:+.1}%", 100.0 * (m.frame_ms / fastest - 1.0))
                };
                vec![
                    m.label.clone(),
                    f2(m.frame_ms),
                    f2(m.spread_ms),
                    against,
                    f2(m.prep_ms),
                    f2(m.trace_ms),
                    f2(m.nodes_per_ray),
                ]
            })
            .collect(),
        folded: false,
    }
}
