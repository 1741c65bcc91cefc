//! Each knob value's figures over the frames (time split up, its spread, work per ray, error)
//! and the one rule that recommends a value per knob.

use super::knobs::KnobKind;
use super::table::TradeRow;
use crate::compare::{CompareRow, Figures};

/// Image knobs: the cheapest value whose mean RMSE against the reference is at most this.
pub const RMSE_BOUND: f64 = 0.05;

/// One value of one knob, over every frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ValueSummary {
    pub value: String,
    pub is_default: bool,
    pub frames: usize,
    /// Means over frames of the per-frame medians of the timed passes.
    pub build_ms: f64,
    pub prep_ms: f64,
    pub trace_ms: f64,
    pub frame_ms: f64,
    /// Mean over frames of the spread (max - min) of the frame time over the timed passes.
    pub spread_ms: f64,
    /// Box plus triangle tests per ray, over every ray of every frame.
    pub work_per_ray: f64,
    /// Image knobs: means over frames and lights.
    pub rmse: Option<f64>,
    pub p99_abs: Option<f64>,
    pub flip_share: Option<f64>,
    /// Work knobs: whether every answer equalled the default value's.
    pub answers_equal: Option<bool>,
}

fn mean(v: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// The values of one knob's rows, in the order they first appear.
pub fn summarise(rows: &[&TradeRow]) -> Vec<ValueSummary> {
    let compare: Vec<CompareRow> = rows.iter().map(|r| r.row.clone()).collect();
    let figures = Figures::new(&compare);
    let mut out = Vec::new();
    for (label, _) in &figures.labels {
        let mine: Vec<&&TradeRow> = rows.iter().filter(|r| &r.row.label == label).collect();
        let frames: Vec<_> = figures.of(label).map(|(_, f)| f).collect();
        let frame_mean = |f: &dyn Fn(&crate::compare::FrameFigures) -> f64| {
            mean(frames.iter().map(|x| f(x))).unwrap_or(0.0)
        };
        // Each frame's spread once (every row of a frame carries the frame's timing).
        let mut spread = std::collections::BTreeMap::new();
        for r in &mine {
            spread.insert(r.row.stats.frame, r.row.frame_ms.max - r.row.frame_ms.min);
        }
        let (rays, tests) = mine.iter().fold((0.0, 0.0), |(n, t), r| {
            let rays = r.row.stats.rays as f64;
            (n + rays, t + rays * r.work_per_ray())
        });
        let errors: Vec<_> = mine.iter().filter_map(|r| r.error).collect();
        let error_mean = |f: fn(&super::MaskError) -> f64| mean(errors.iter().map(f));
        let answers: Vec<bool> = mine.iter().filter_map(|r| r.answers_equal).collect();
        out.push(ValueSummary {
            value: mine[0].value.clone(),
            is_default: mine[0].is_default,
            frames: frames.len(),
            build_ms: frame_mean(&|f| f.build_ms()),
            prep_ms: frame_mean(&|f| f.prep_ms),
            trace_ms: frame_mean(&|f| f.trace_ms),
            frame_ms: frame_mean(&|f| f.frame_ms),
            spread_ms: mean(spread.values().copied()).unwrap_or(0.0),
            work_per_ray: if rays > 0.0 { tests / rays } else { 0.0 },
            rmse: error_mean(|e| e.rmse),
            p99_abs: error_mean(|e| e.p99_abs),
            flip_share: error_mean(|e| e.flip_share),
            answers_equal: (!answers.is_empty()).then(|| answers.iter().all(|&a| a)),
        });
    }
    out
}

/// The value recommended for a knob and why, in one line.
#[derive(Clone, Debug, PartialEq)]
pub struct Recommendation {
    pub value: String,
    pub reason: String,
}

fn fastest<'a>(it: impl Iterator<Item = &'a ValueSummary>) -> Option<&'a ValueSummary> {
    it.min_by(|a, b| a.frame_ms.total_cmp(&b.frame_ms))
}

/// Work knobs: the fastest value, every value judged against it; a value no slower than it by
/// more than the measured spread (the larger of the two values' mean spreads) ties with it,
/// and a tie goes to the cheaper value (fewest box and triangle tests per ray), then to the
/// default. Image knobs: the fastest value whose mean RMSE is at most [`RMSE_BOUND`], else the
/// most accurate.
pub fn recommend(kind: KnobKind, values: &[ValueSummary]) -> Option<Recommendation> {
    let default = values.iter().find(|v| v.is_default)?;
    let pick = |v: &ValueSummary, reason: String| {
        Some(Recommendation {
            value: v.value.clone(),
            reason,
        })
    };
    match kind {
        KnobKind::Work => {
            let best = fastest(values.iter())?;
            // Within the larger of the two values' spreads of the fastest: a tie.
            let tied: Vec<&ValueSummary> = values
                .iter()
                .filter(|v| v.frame_ms - best.frame_ms <= v.spread_ms.max(best.spread_ms))
                .collect();
            // A tie goes to the cheaper value (fewer tests per ray), then to the default.
            let pick_of = tied
                .iter()
                .copied()
                .min_by(|a, b| {
                    a.work_per_ray
                        .total_cmp(&b.work_per_ray)
                        .then(b.is_default.cmp(&a.is_default))
                })
                .unwrap_or(best);
            let versus_default = if pick_of.is_default {
                "the default".to_string()
            } else {
                format!(
                    "{:+.1}% against the default's {:.2} ms",
                    100.0 * (pick_of.frame_ms / default.frame_ms.max(1e-12) - 1.0),
                    default.frame_ms
                )
            };
            let others: Vec<&str> = tied
                .iter()
                .filter(|v| v.value != pick_of.value)
                .map(|v| v.value.as_str())
                .collect();
            let reason = if others.is_empty() {
                format!(
                    "the fastest: {:.2} ms per frame ({versus_default}), beyond the spread of the others",
                    pick_of.frame_ms
                )
            } else {
                format!(
                    "ties with {} within the spread of the timings ({:.2} ms per frame, {versus_default}); the fewest tests per ray among them ({:.1})",
                    others.join(", "),
                    pick_of.frame_ms,
                    pick_of.work_per_ray
                )
            };
            pick(pick_of, reason)
        }
        KnobKind::Image => {
            let under = |v: &&ValueSummary| v.rmse.is_some_and(|e| e <= RMSE_BOUND);
            if let Some(best) = fastest(values.iter().filter(under)) {
                pick(
                    best,
                    format!(
                        "the fastest value with RMSE <= {RMSE_BOUND}: RMSE {:.4}, {:.2} ms per frame (default {:.2} ms)",
                        best.rmse.unwrap_or(0.0),
                        best.frame_ms,
                        default.frame_ms
                    ),
                )
            } else {
                let best = values.iter().min_by(|a, b| {
                    a.rmse
                        .unwrap_or(f64::INFINITY)
                        .total_cmp(&b.rmse.unwrap_or(f64::INFINITY))
                })?;
                pick(
                    best,
                    format!(
                        "no value reaches RMSE <= {RMSE_BOUND}: the most accurate (RMSE {:.4}, {:.2} ms per frame)",
                        best.rmse.unwrap_or(0.0),
                        best.frame_ms
                    ),
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(
        value: &str,
        is_default: bool,
        frame_ms: f64,
        spread_ms: f64,
        rmse: Option<f64>,
    ) -> ValueSummary {
        ValueSummary {
            value: value.into(),
            is_default,
            frame_ms,
            spread_ms,
            rmse,
            ..ValueSummary::default()
        }
    }

    #[test]
    fn work_knobs_leave_the_default_within_the_spread() {
        let values = [v("a", true, 10.0, 0.5, None), v("b", false, 9.0, 0.4, None)];
        assert_eq!(recommend(KnobKind::Work, &values).unwrap().value, "b");
        let values = [v("a", true, 10.0, 1.5, None), v("b", false, 9.0, 0.4, None)];
        let r = recommend(KnobKind::Work, &values).unwrap();
        assert_eq!(r.value, "a");
        assert!(r.reason.contains("the default"), "{}", r.reason);
    }

    #[test]
    fn a_tie_goes_to_the_cheaper_value_and_the_fastest_is_judged_against_all() {
        // Width 8 (the default) a hair faster than width 4, within the spread: width 4 does
        // fewer tests per ray.
        let mut eight = v("8", true, 218.57, 1.2, None);
        let mut four = v("4", false, 218.83, 1.1, None);
        eight.work_per_ray = 52.0;
        four.work_per_ray = 47.5;
        let r = recommend(KnobKind::Work, &[eight.clone(), four.clone()]).unwrap();
        assert_eq!(r.value, "4");
        assert!(
            r.reason.starts_with("ties with 8 within the spread"),
            "{}",
            r.reason
        );
        // Beyond the spread the faster value wins whatever its work.
        four.frame_ms = 225.0;
        assert_eq!(
            recommend(KnobKind::Work, &[eight, four]).unwrap().value,
            "8"
        );
        // Two values beat the default: the fastest of all is taken, not the first found.
        let values = [
            v("a", true, 10.0, 0.1, None),
            v("b", false, 9.0, 0.1, None),
            v("c", false, 8.0, 0.1, None),
        ];
        let r = recommend(KnobKind::Work, &values).unwrap();
        assert_eq!(r.value, "c");
        assert!(r.reason.starts_with("the fastest: 8.00 ms"), "{}", r.reason);
    }

    #[test]
    fn image_knobs_take_the_fastest_under_the_bound() {
        let values = [
            v("1", false, 1.0, 0.0, Some(0.2)),
            v("4", true, 2.0, 0.0, Some(0.04)),
            v("16", false, 5.0, 0.0, Some(0.01)),
        ];
        assert_eq!(recommend(KnobKind::Image, &values).unwrap().value, "4");
        let values = [
            v("1", true, 1.0, 0.0, Some(0.2)),
            v("2", false, 2.0, 0.0, Some(0.1)),
        ];
        let r = recommend(KnobKind::Image, &values).unwrap();
        assert_eq!(r.value, "2");
        assert!(r.reason.contains("no value reaches"), "{}", r.reason);
    }
}
