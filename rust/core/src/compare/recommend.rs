//! The comparison's answer in plain words: which method to use for these frames and why. The
//! fastest method whose answers equal the baseline's, by how much, which methods tie with it
//! within the spread of the timings, what doing the least work did not buy, and what choosing
//! per frame or per light could have saved (the hindsight bounds).

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use super::hindsight::Hindsight;
use super::run::{CompareRow, Mismatch};
use super::summary::{Figures, FrameFigures};

/// One method over the frames every candidate rendered: means per frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MethodTime {
    pub label: String,
    /// Mean over frames of the median frame time of the timed passes.
    pub frame_ms: f64,
    /// Mean over frames of the spread (slowest less fastest timed pass) of the frame time.
    pub spread_ms: f64,
    /// Per-light preparation and trace, means per frame (medians of the timed passes).
    pub prep_ms: f64,
    pub trace_ms: f64,
    /// Nodes entered (N_B + N_L) per ray over every ray of every pass.
    pub nodes_per_ray: f64,
}

/// What the report recommends.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Recommendation {
    /// The fastest method whose answers equal the baseline's.
    pub label: String,
    pub frames: usize,
    /// Every candidate, fastest first.
    pub methods: Vec<MethodTime>,
    /// Methods no slower than the recommended one by more than the larger of the two spreads.
    pub ties: Vec<String>,
    /// The method entering the fewest nodes per ray, when that is another one.
    pub least_work: Option<String>,
    /// The sentences, in order: the choice, the least work, the hindsight.
    pub sentences: Vec<String>,
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

fn percent(a: f64, b: f64) -> f64 {
    if b > 0.0 {
        100.0 * (a - b) / b
    } else {
        0.0
    }
}

/// The methods' times and work over the frames all of them rendered, fastest first.
fn method_times(rows: &[CompareRow], labels: &[&str]) -> (Vec<MethodTime>, usize) {
    let figures = Figures::new(rows);
    // Each frame's spread of the timed passes (every row of a frame carries the frame's timing).
    let spread: BTreeMap<(&str, i32), f64> = rows
        .iter()
        .map(|r| {
            (
                (r.label.as_str(), r.stats.frame),
                r.frame_ms.max - r.frame_ms.min,
            )
        })
        .collect();
    let common: BTreeSet<i32> = labels
        .iter()
        .map(|l| figures.of(l).map(|(f, _)| f).collect::<BTreeSet<i32>>())
        .reduce(|a, b| &a & &b)
        .unwrap_or_default();
    let mut out: Vec<MethodTime> = labels
        .iter()
        .map(|&label| {
            let frames: Vec<(i32, &FrameFigures)> = figures
                .of(label)
                .filter(|(f, _)| common.contains(f))
                .collect();
            let column = |k: &dyn Fn(i32, &FrameFigures) -> f64| {
                mean(&frames.iter().map(|&(f, x)| k(f, x)).collect::<Vec<_>>())
            };
            let (nodes, rays) = frames
                .iter()
                .flat_map(|(_, x)| x.work.values())
                .fold((0.0, 0u64), |(n, r), w| (n + w.nb + w.nl, r + w.rays));
            MethodTime {
                label: label.to_string(),
                frame_ms: column(&|_, x| x.frame_ms),
                spread_ms: column(&|f, _| spread.get(&(label, f)).copied().unwrap_or(0.0)),
                prep_ms: column(&|_, x| x.prep_ms),
                trace_ms: column(&|_, x| x.trace_ms),
                nodes_per_ray: if rays > 0 { nodes / rays as f64 } else { 0.0 },
            }
        })
        .collect();
    out.sort_by(|a, b| a.frame_ms.total_cmp(&b.frame_ms));
    (out, common.len())
}

/// The recommendation among `labels` (in the comparison's order), leaving out methods whose
/// answers differ from the baseline's; `None` without frame times or a candidate.
pub fn recommend(
    rows: &[CompareRow],
    labels: &[&str],
    baseline: &str,
    mismatches: &[Mismatch],
    hindsight: Option<&Hindsight>,
) -> Option<Recommendation> {
    let wrong: BTreeSet<&str> = mismatches
        .iter()
        .filter(|m| m.is_wrong())
        .map(|m| m.label.as_str())
        .collect();
    let candidates: Vec<&str> = labels
        .iter()
        .copied()
        .filter(|l| !wrong.contains(l))
        .collect();
    let (methods, frames) = method_times(rows, &candidates);
    let best = methods.first().filter(|m| m.frame_ms > 0.0)?.clone();
    let tied = |m: &MethodTime| m.frame_ms - best.frame_ms <= m.spread_ms.max(best.spread_ms);
    let ties: Vec<String> = methods[1..]
        .iter()
        .filter(|m| tied(m))
        .map(|m| m.label.clone())
        .collect();
    let frames_text = if frames == 1 {
        "this frame".to_string()
    } else {
        format!("these {frames} frames")
    };
    let mut first = format!(
        "Use {} for this animation: the fastest on {frames_text}, {:.2} ms a frame",
        best.label, best.frame_ms
    );
    if let Some(base) = methods
        .iter()
        .find(|m| m.label == baseline && m.label != best.label)
    {
        first += &format!(
            ", {:.1}% less than the baseline {} ({:.2} ms)",
            -percent(best.frame_ms, base.frame_ms),
            base.label,
            base.frame_ms
        );
    }
    first += &if best.spread_ms > 0.0 {
        format!(
            "; its timed passes spread by {:.2} ms a frame ({:.1}%).",
            best.spread_ms,
            100.0 * best.spread_ms / best.frame_ms
        )
    } else {
        "; one timed pass each, so no spread was measured (--repeat 3 or more measures it)."
            .to_string()
    };
    if !ties.is_empty() {
        first += &format!(
            " {} {} within that spread: a tie, so choose among them by what else matters.",
            ties.join(", "),
            if ties.len() == 1 { "is" } else { "are" }
        );
    }
    let mut sentences = vec![first];
    let least = methods
        .iter()
        .min_by(|a, b| a.nodes_per_ray.total_cmp(&b.nodes_per_ray))?;
    let least_work =
        (least.label != best.label && least.nodes_per_ray < best.nodes_per_ray).then(|| {
            let tie = if ties.contains(&least.label) {
                " (a tie in time)".to_string()
            } else {
                String::new()
            };
            sentences.push(format!(
                "{} does the least work, {:.1}% fewer nodes entered per ray than {}, yet takes \
                 {:.1}% longer a frame{tie}: its per-light preparation costs {:.2} ms a frame \
                 against {:.2} ms, its traversal {:.2} ms against {:.2} ms.",
                least.label,
                -percent(least.nodes_per_ray, best.nodes_per_ray),
                best.label,
                percent(least.frame_ms, best.frame_ms),
                least.prep_ms,
                best.prep_ms,
                least.trace_ms,
                best.trace_ms
            ));
            least.label.clone()
        });
    if let Some(h) = hindsight.filter(|h| h.best_ms > 0.0) {
        sentences.push(format!(
            "Choosing the fastest fixed method for each frame, after the fact, would have saved \
             at most {:.1}% of {}'s time; each light's fastest pass and each frame's fastest \
             camera part, at most {:.1}%.",
            -percent(h.per_frame_ms, h.best_ms),
            h.best_label,
            -percent(h.per_pass_ms, h.best_ms)
        ));
    }
    Some(Recommendation {
        label: best.label,
        frames,
        methods,
        ties,
        least_work,
        sentences,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::Timing;
    use crate::stats::StatsRow;

    /// One pass row of `label` at `frame`: the frame's time (median, spread) and the pass's
    /// preparation, trace and nodes per ray.
    fn row(
        label: &str,
        frame: i32,
        frame_ms: (f64, f64),
        prep_trace: (f64, f64),
        nb: f64,
    ) -> CompareRow {
        let timing = |median: f64, spread: f64| Timing {
            median,
            min: median - spread / 2.0,
            max: median + spread / 2.0,
        };
        CompareRow {
            label: label.into(),
            stats: StatsRow {
                frame,
                pass: "shadow".into(),
                light: "Sun".into(),
                rays: 1000,
                nb_per_ray: nb,
                ..StatsRow::default()
            },
            build_ms: Timing::default(),
            prepare_ms: timing(prep_trace.0, 0.0),
            trace_ms: timing(prep_trace.1, 0.0),
            frame_ms: timing(frame_ms.0, frame_ms.1),
        }
    }

    /// A method's label, frame time and spread, (preparation, trace) and N_B per ray.
    type Method<'a> = (&'a str, f64, f64, (f64, f64), f64);

    fn rows(methods: &[Method]) -> Vec<CompareRow> {
        (1..=4)
            .flat_map(|f| {
                methods
                    .iter()
                    .map(move |&(l, ms, spread, pt, nb)| row(l, f, (ms, spread), pt, nb))
            })
            .collect()
    }

    #[test]
    fn the_fastest_is_named_where_least_work_is_not_least_time() {
        // sorted enters the fewest nodes but its preparation makes it the slowest.
        let rows = rows(&[
            ("base", 20.0, 0.2, (0.0, 15.0), 40.0),
            ("sato", 12.0, 0.2, (0.0, 8.0), 30.0),
            ("sorted", 13.0, 0.2, (2.0, 7.0), 21.0),
        ]);
        let r = recommend(&rows, &["base", "sato", "sorted"], "base", &[], None).unwrap();
        assert_eq!(r.label, "sato");
        assert_eq!(r.least_work.as_deref(), Some("sorted"));
        assert!(r.ties.is_empty(), "{:?}", r.ties);
        assert!(
            r.sentences[0].starts_with("Use sato for this animation"),
            "{}",
            r.sentences[0]
        );
        assert!(
            r.sentences[0].contains("40.0% less than the baseline base"),
            "{}",
            r.sentences[0]
        );
        assert!(
            r.sentences[1].starts_with("sorted does the least work, 30.0% fewer"),
            "{}",
            r.sentences[1]
        );
        assert!(r.sentences[1].contains("8.3% longer"), "{}", r.sentences[1]);
    }

    #[test]
    fn a_difference_within_the_spread_is_a_tie_and_wrong_answers_are_never_recommended() {
        let rows = rows(&[
            ("a", 10.0, 0.5, (0.0, 5.0), 30.0),
            ("b", 10.3, 0.5, (0.0, 5.0), 30.0),
            ("c", 11.0, 0.5, (0.0, 5.0), 30.0),
            ("broken", 1.0, 0.1, (0.0, 0.5), 1.0),
        ]);
        let broken = Mismatch {
            frame: 2,
            label: "broken".into(),
            what: "light 'Sun'".into(),
            pixels: 3,
            across_structures: false,
        };
        // The same difference across scene structures is an edge difference, not an error.
        let edge = Mismatch {
            across_structures: true,
            ..broken.clone()
        };
        let r = recommend(&rows, &["a", "b", "c", "broken"], "a", &[edge], None).unwrap();
        assert_eq!(r.label, "broken");
        let r = recommend(&rows, &["a", "b", "c", "broken"], "a", &[broken], None).unwrap();
        assert_eq!(r.label, "a");
        assert_eq!(r.ties, vec!["b".to_string()]);
        assert!(
            r.sentences[0].contains("b is within that spread: a tie"),
            "{}",
            r.sentences[0]
        );
        assert!(r.methods.iter().all(|m| m.label != "broken"));
        assert_eq!(r.least_work, None);
    }

    #[test]
    fn one_timed_pass_says_no_spread_was_measured_and_hindsight_is_one_sentence() {
        let rows = rows(&[
            ("a", 10.0, 0.0, (0.0, 5.0), 30.0),
            ("b", 12.0, 0.0, (0.0, 5.0), 30.0),
        ]);
        let h = Hindsight {
            best_label: "a".into(),
            best_ms: 40.0,
            per_frame_ms: 38.0,
            per_pass_ms: 36.0,
            choosers: vec![],
            frames: 4,
        };
        let r = recommend(&rows, &["a", "b"], "a", &[], Some(&h)).unwrap();
        assert!(
            r.sentences[0].contains("no spread was measured"),
            "{}",
            r.sentences[0]
        );
        assert_eq!(r.sentences.len(), 2);
        assert!(
            r.sentences[1].contains("at most 5.0% of a's time"),
            "{}",
            r.sentences[1]
        );
        assert!(
            r.sentences[1].contains("at most 10.0%."),
            "{}",
            r.sentences[1]
        );
    }
}
