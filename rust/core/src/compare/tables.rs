//! The comparison's long-form table: one row per frame, method, pass and light, every
//! statistics column (timings are the medians of the timed passes) and their spread.

use serde::Serialize;

use super::run::CompareRow;
use crate::stats::{Cell, StatsRow};

/// Columns before the statistics' own.
const LEAD: [&str; 2] = ["label", "settings"];
/// Columns after them: the spread of each timing over the timed passes, and the frame total.
const SPREAD: [&str; 9] = [
    "build_ms_min",
    "build_ms_max",
    "prepare_ms_min",
    "prepare_ms_max",
    "trace_ms_min",
    "trace_ms_max",
    "frame_ms",
    "frame_ms_min",
    "frame_ms_max",
];

/// Every column of `compare.csv`, in order.
pub fn columns() -> Vec<&'static str> {
    LEAD.iter()
        .copied()
        .chain(StatsRow::default().cells().into_iter().map(|(n, _)| n))
        .chain(SPREAD.iter().copied())
        .collect()
}

#[cfg(feature = "files")]
fn cell_text(c: Cell) -> String {
    match c {
        Cell::Text(t) => t.to_string(),
        Cell::Int(i) => i.to_string(),
        Cell::Count(n) => n.to_string(),
        Cell::Flag(b) => b.to_string(),
        Cell::Real(x) => x.to_string(),
    }
}

/// One row's cells by column, in the order of [`columns`]; `settings` is its method's spec.
pub fn cells<'a>(r: &'a CompareRow, settings: &'a str) -> Vec<(&'static str, Cell<'a>)> {
    let mut out = vec![
        (LEAD[0], Cell::Text(&r.label)),
        (LEAD[1], Cell::Text(settings)),
    ];
    out.extend(r.stats.cells());
    let spread = [
        r.build_ms.min,
        r.build_ms.max,
        r.prepare_ms.min,
        r.prepare_ms.max,
        r.trace_ms.min,
        r.trace_ms.max,
        r.frame_ms.median,
        r.frame_ms.min,
        r.frame_ms.max,
    ];
    out.extend(SPREAD.iter().zip(spread).map(|(n, x)| (*n, Cell::Real(x))));
    out
}

#[cfg(feature = "files")]
/// `rows` as CSV text; `settings` gives each label's method spec as typed.
pub fn to_csv(rows: &[CompareRow], settings: &dyn Fn(&str) -> String) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(columns()).expect("writing to memory");
    for r in rows {
        let spec = settings(&r.label);
        let record: Vec<String> = cells(r, &spec)
            .into_iter()
            .map(|(_, c)| cell_text(c))
            .collect();
        w.write_record(&record).expect("writing to memory");
    }
    String::from_utf8(w.into_inner().expect("writing to memory")).expect("CSV of UTF-8 cells")
}

/// A row as `compare.json` holds it: the statistics' columns flattened beside the label.
#[derive(Serialize)]
pub struct JsonRow<'a> {
    pub label: &'a str,
    #[serde(flatten)]
    pub stats: &'a StatsRow,
    pub build_ms_spread: [f64; 2],
    pub prepare_ms_spread: [f64; 2],
    pub trace_ms_spread: [f64; 2],
    pub frame_ms: [f64; 3],
}

impl<'a> From<&'a CompareRow> for JsonRow<'a> {
    fn from(r: &'a CompareRow) -> Self {
        JsonRow {
            label: &r.label,
            stats: &r.stats,
            build_ms_spread: [r.build_ms.min, r.build_ms.max],
            prepare_ms_spread: [r.prepare_ms.min, r.prepare_ms.max],
            trace_ms_spread: [r.trace_ms.min, r.trace_ms.max],
            frame_ms: [r.frame_ms.median, r.frame_ms.min, r.frame_ms.max],
        }
    }
}

#[cfg(all(test, feature = "files"))]
mod tests {
    use super::*;
    use crate::compare::Timing;

    #[test]
    fn header_and_cells_line_up() {
        let row = CompareRow {
            label: "a".into(),
            stats: StatsRow {
                light: "Sun, key".into(),
                rays: 7,
                ..StatsRow::default()
            },
            build_ms: Timing::of(&[1.0, 2.0]),
            prepare_ms: Timing::default(),
            trace_ms: Timing::of(&[0.5]),
            frame_ms: Timing::of(&[3.0, 4.0, 5.0]),
        };
        let text = to_csv(std::slice::from_ref(&row), &|l| {
            format!("{l}=width=2,order=fbto")
        });
        let mut r = csv::Reader::from_reader(text.as_bytes());
        let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
        assert_eq!(header, columns());
        let rec = r.records().next().unwrap().unwrap();
        assert_eq!(rec.len(), header.len());
        let get = |name: &str| rec[header.iter().position(|h| h == name).unwrap()].to_string();
        assert_eq!(get("settings"), "a=width=2,order=fbto");
        assert_eq!(get("light"), "Sun, key");
        assert_eq!(get("rays"), "7");
        assert_eq!(get("build_ms_max"), "2");
        assert_eq!(get("frame_ms"), "4");
        let names: Vec<&str> = cells(&row, "").iter().map(|(n, _)| *n).collect();
        assert_eq!(names, columns());
    }
}
