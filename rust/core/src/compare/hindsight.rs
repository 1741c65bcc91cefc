//! What choosing a method per frame, or per pass, could gain at most on the compared frames:
//! the fastest of the fixed methods picked after the fact, against the best fixed method over
//! the whole run. A method that chooses as it goes (`auto`) is judged against these bounds.

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use super::run::CompareRow;

/// Totals over the frames every fixed method rendered, ms (sums of per-frame medians).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Hindsight {
    /// The fixed method of least total time, and that total.
    pub best_label: String,
    pub best_ms: f64,
    /// Each frame's fastest fixed method, summed.
    pub per_frame_ms: f64,
    /// Each frame's least camera part (the frame less its lights' preparation and tracing:
    /// build, visible sets, camera rays, combining) plus each light's least preparation and
    /// trace. It may pair one method's tree with another's order for a light, so it bounds
    /// rather than names what a per-pass choice could do.
    pub per_pass_ms: f64,
    /// The other methods (those that choose as they go), each with its total.
    pub choosers: Vec<(String, f64)>,
    pub frames: usize,
}

/// One method's frame: its total and each light's preparation plus trace.
#[derive(Default)]
struct Frame {
    frame_ms: f64,
    lights: BTreeMap<String, f64>,
}

/// The bounds over `fixed` methods (labels of methods that keep one build and one order),
/// on the frames that every method rendered; `None` with fewer than two such methods or
/// without frame times.
pub fn hindsight(rows: &[CompareRow], fixed: &[&str]) -> Option<Hindsight> {
    let mut frames: BTreeMap<(&str, i32), Frame> = BTreeMap::new();
    let mut labels: Vec<&str> = Vec::new();
    for r in rows {
        if !labels.contains(&r.label.as_str()) {
            labels.push(&r.label);
        }
        let f = frames.entry((&r.label, r.stats.frame)).or_default();
        f.frame_ms = r.frame_ms.median;
        if r.stats.pass == "shadow" {
            *f.lights.entry(r.stats.light.clone()).or_default() +=
                r.trace_ms.median + r.prepare_ms.median;
        }
    }
    let fixed: Vec<&str> = labels
        .iter()
        .copied()
        .filter(|l| fixed.contains(l))
        .collect();
    if fixed.len() < 2 {
        return None;
    }
    let numbers: Vec<i32> = frames
        .keys()
        .map(|(_, n)| *n)
        .collect::<BTreeSet<i32>>()
        .into_iter()
        .filter(|n| labels.iter().all(|l| frames.contains_key(&(*l, *n))))
        .collect();
    let total =
        |label: &str| -> f64 { numbers.iter().map(|n| frames[&(label, *n)].frame_ms).sum() };
    let best_label = fixed
        .iter()
        .copied()
        .min_by(|a, b| total(a).total_cmp(&total(b)))?;
    let least = |f: &dyn Fn(&Frame) -> f64, n: i32| {
        fixed
            .iter()
            .map(|l| f(&frames[&(*l, n)]))
            .fold(f64::INFINITY, f64::min)
    };
    let best_ms = total(best_label);
    // Frames recorded without their totals (older records) give nothing to compare.
    if best_ms <= 0.0 {
        return None;
    }
    let mut per_frame_ms = 0.0;
    let mut per_pass_ms = 0.0;
    for &n in &numbers {
        per_frame_ms += least(&|f| f.frame_ms, n);
        per_pass_ms += least(&|f| f.frame_ms - f.lights.values().sum::<f64>(), n);
        for light in frames[&(best_label, n)].lights.keys() {
            per_pass_ms += least(
                &|f| f.lights.get(light).copied().unwrap_or(f64::INFINITY),
                n,
            );
        }
    }
    Some(Hindsight {
        best_label: best_label.to_string(),
        best_ms,
        per_frame_ms,
        per_pass_ms,
        choosers: labels
            .iter()
            .filter(|l| !fixed.contains(l))
            .map(|l| (l.to_string(), total(l)))
            .collect(),
        frames: numbers.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::Timing;
    use crate::stats::StatsRow;

    fn ms(x: f64) -> Timing {
        Timing {
            median: x,
            min: x,
            max: x,
        }
    }

    /// A frame of `label`: its total, and the trace and preparation of each light.
    fn frame(label: &str, n: i32, total: f64, lights: &[(&str, f64, f64)]) -> Vec<CompareRow> {
        let row = |pass: &str, light: &str, trace: f64, sort: f64| CompareRow {
            label: label.into(),
            stats: StatsRow {
                frame: n,
                pass: pass.into(),
                light: light.into(),
                ..StatsRow::default()
            },
            build_ms: ms(0.0),
            prepare_ms: ms(sort),
            trace_ms: ms(trace),
            frame_ms: ms(total),
        };
        let mut out = vec![row("primary", "", 5.0, 0.0)];
        out.extend(lights.iter().map(|(l, t, s)| row("shadow", l, *t, *s)));
        out
    }

    #[test]
    fn bounds_take_the_least_frame_and_the_least_pass() {
        // a is best over both frames; b wins frame 2; per pass, b's sun on frame 1 and a's
        // camera part there are cheaper than either whole frame.
        let rows: Vec<CompareRow> = [
            frame("a", 1, 100.0, &[("sun", 40.0, 0.0), ("lamp", 30.0, 0.0)]),
            frame("b", 1, 110.0, &[("sun", 30.0, 5.0), ("lamp", 40.0, 0.0)]),
            frame("auto", 1, 104.0, &[("sun", 35.0, 0.0), ("lamp", 30.0, 0.0)]),
            frame("a", 2, 100.0, &[("sun", 40.0, 0.0), ("lamp", 30.0, 0.0)]),
            frame("b", 2, 95.0, &[("sun", 40.0, 0.0), ("lamp", 25.0, 0.0)]),
            frame("auto", 2, 97.0, &[("sun", 40.0, 0.0), ("lamp", 25.0, 0.0)]),
        ]
        .concat();
        let h = hindsight(&rows, &["a", "b"]).expect("two fixed methods");
        assert_eq!(h.best_label, "a");
        assert_eq!(h.best_ms, 200.0);
        assert_eq!(h.per_frame_ms, 195.0);
        // Frame 1: camera parts a 30, b 35; sun min(40, 35) = 35; lamp min(30, 40) = 30 -> 95.
        // Frame 2: camera parts a 30, b 30; sun 40; lamp 25 -> 95.
        assert_eq!(h.per_pass_ms, 190.0);
        assert_eq!(h.choosers, vec![("auto".to_string(), 201.0)]);
        assert_eq!(h.frames, 2);
    }

    #[test]
    fn frames_some_method_lacks_are_left_out_and_one_fixed_method_or_no_times_give_none() {
        let rows: Vec<CompareRow> = [
            frame("a", 1, 100.0, &[("sun", 40.0, 0.0)]),
            frame("b", 1, 90.0, &[("sun", 40.0, 0.0)]),
            frame("a", 2, 100.0, &[("sun", 40.0, 0.0)]),
        ]
        .concat();
        let h = hindsight(&rows, &["a", "b"]).expect("two fixed methods");
        assert_eq!((h.frames, h.best_label.as_str(), h.best_ms), (1, "b", 90.0));
        assert!(hindsight(&rows, &["a"]).is_none());
        let untimed: Vec<CompareRow> = [
            frame("a", 1, 0.0, &[("sun", 0.0, 0.0)]),
            frame("b", 1, 0.0, &[("sun", 0.0, 0.0)]),
        ]
        .concat();
        assert!(hindsight(&untimed, &["a", "b"]).is_none());
    }
}
