//! The comparison in the papers' forms: per method and pass kind, the work per ray (N_B, N_L,
//! N_T, N_box) as a ratio to the baseline over all rays and as the mean of per-frame ratios, and
//! the time of a frame split into build, per-light preparation and trace.

use std::collections::BTreeMap;

use serde::Serialize;

use super::run::CompareRow;

/// Work of one pass kind: totals over frames and lights (per-ray values times rays).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Work {
    pub rays: u64,
    pub nb: f64,
    pub nl: f64,
    pub nt: f64,
    pub nbox: f64,
    /// Trace time (medians of the timed passes), summed.
    pub trace_ms: f64,
}

impl Work {
    fn add(&mut self, r: &CompareRow) {
        let rays = r.stats.rays as f64;
        self.trace_ms += r.trace_ms.median;
        self.rays += r.stats.rays;
        self.nb += r.stats.nb_per_ray * rays;
        self.nl += r.stats.nl_per_ray * rays;
        self.nt += r.stats.nt_per_ray * rays;
        self.nbox += r.stats.nbox_per_ray * rays;
    }

    /// Per ray: N_B, N_L, N_T, N_box.
    pub fn per_ray(&self) -> [f64; 4] {
        let r = self.rays.max(1) as f64;
        [self.nb / r, self.nl / r, self.nt / r, self.nbox / r]
    }
}

/// One method's figures for one pass kind (`primary` or `shadow`, all lights together).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PassSummary {
    pub label: String,
    pub method: String,
    pub pass: String,
    pub rays: u64,
    /// N_B, N_L, N_T, N_box per ray over every frame.
    pub per_ray: [f64; 4],
    /// The same as ratios to the baseline's (all rays together).
    pub ratio: [f64; 4],
    /// The mean over frames of each frame's ratio to the baseline.
    pub mean_frame_ratio: [f64; 4],
    /// Mean trace time of this pass kind per frame (medians of the timed passes), and Mrays/s.
    pub trace_ms: f64,
    pub mrays_per_s: f64,
}

/// One method's time per frame, split up (means over frames of the per-frame medians).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct TimeSummary {
    pub label: String,
    pub method: String,
    /// The frame less preparation and tracing: BVH build (or reuse), visible-set work, combine.
    pub build_ms: f64,
    /// Per-light preparation (sorting, SRDH).
    pub prep_ms: f64,
    pub trace_ms: f64,
    pub frame_ms: f64,
    /// The frame total as a ratio to the baseline's.
    pub frame_ratio: f64,
}

/// Per frame of one method: work per pass kind, and time parts.
#[derive(Clone, Debug, Default)]
pub struct FrameFigures {
    pub work: BTreeMap<String, Work>,
    pub prep_ms: f64,
    pub trace_ms: f64,
    pub frame_ms: f64,
}

impl FrameFigures {
    pub fn build_ms(&self) -> f64 {
        (self.frame_ms - self.prep_ms - self.trace_ms).max(0.0)
    }
}

/// `(label, frame)` to that frame's figures, and the methods' labels and names in order.
pub struct Figures {
    pub labels: Vec<(String, String)>,
    pub frames: BTreeMap<(String, i32), FrameFigures>,
}

impl Figures {
    pub fn new(rows: &[CompareRow]) -> Figures {
        let mut labels: Vec<(String, String)> = Vec::new();
        let mut frames: BTreeMap<(String, i32), FrameFigures> = BTreeMap::new();
        for r in rows {
            if !labels.iter().any(|(l, _)| *l == r.label) {
                labels.push((r.label.clone(), r.stats.method.clone()));
            }
            let f = frames.entry((r.label.clone(), r.stats.frame)).or_default();
            f.work.entry(r.stats.pass.clone()).or_default().add(r);
            f.prep_ms += r.prepare_ms.median;
            f.trace_ms += r.trace_ms.median;
            f.frame_ms = r.frame_ms.median;
        }
        Figures { labels, frames }
    }

    /// The frames of `label`, in order.
    pub fn of<'a>(&'a self, label: &'a str) -> impl Iterator<Item = (i32, &'a FrameFigures)> + 'a {
        self.frames
            .iter()
            .filter(move |((l, _), _)| l == label)
            .map(|((_, f), v)| (*f, v))
    }
}

fn ratio(a: f64, b: f64) -> f64 {
    if b > 0.0 {
        a / b
    } else if a == 0.0 {
        1.0
    } else {
        f64::INFINITY
    }
}

/// The work table: per method and pass kind, against `baseline`.
pub fn pass_summaries(figures: &Figures, baseline: &str) -> Vec<PassSummary> {
    let mut out = Vec::new();
    for pass in ["primary", "shadow"] {
        let total = |label: &str| {
            let mut w = Work::default();
            let mut trace_ms = 0.0;
            let mut frames = 0;
            for (_, f) in figures.of(label) {
                if let Some(x) = f.work.get(pass) {
                    w.rays += x.rays;
                    w.nb += x.nb;
                    w.nl += x.nl;
                    w.nt += x.nt;
                    w.nbox += x.nbox;
                    trace_ms += x.trace_ms;
                }
                frames += 1;
            }
            (w, trace_ms, frames)
        };
        let (base, _, _) = total(baseline);
        if base.rays == 0 {
            continue;
        }
        for (label, method) in &figures.labels {
            let (w, trace_ms, frames) = total(label);
            let per_ray = w.per_ray();
            let b = base.per_ray();
            let mut mean = [0.0; 4];
            let mut n = 0;
            for ((_, f), (_, fb)) in figures.of(label).zip(figures.of(baseline)) {
                let (Some(x), Some(y)) = (f.work.get(pass), fb.work.get(pass)) else {
                    continue;
                };
                let (x, y) = (x.per_ray(), y.per_ray());
                for k in 0..4 {
                    mean[k] += ratio(x[k], y[k]);
                }
                n += 1;
            }
            out.push(PassSummary {
                label: label.clone(),
                method: method.clone(),
                pass: pass.to_string(),
                rays: w.rays,
                per_ray,
                ratio: std::array::from_fn(|k| ratio(per_ray[k], b[k])),
                mean_frame_ratio: mean.map(|m| m / n.max(1) as f64),
                trace_ms: trace_ms / frames.max(1) as f64,
                mrays_per_s: if trace_ms > 0.0 {
                    w.rays as f64 / (trace_ms * 1e3)
                } else {
                    0.0
                },
            });
        }
    }
    out
}

/// The time table: per method, the mean frame split up, against `baseline`.
pub fn time_summaries(figures: &Figures, baseline: &str) -> Vec<TimeSummary> {
    let mean = |label: &str, f: fn(&FrameFigures) -> f64| {
        let v: Vec<f64> = figures.of(label).map(|(_, x)| f(x)).collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let base_frame = mean(baseline, |f| f.frame_ms);
    figures
        .labels
        .iter()
        .map(|(label, method)| {
            let frame_ms = mean(label, |f| f.frame_ms);
            TimeSummary {
                label: label.clone(),
                method: method.clone(),
                build_ms: mean(label, FrameFigures::build_ms),
                prep_ms: mean(label, |f| f.prep_ms),
                trace_ms: mean(label, |f| f.trace_ms),
                frame_ms,
                frame_ratio: ratio(frame_ms, base_frame),
            }
        })
        .collect()
}
