//! The trade's long-form table (`trade.csv`): one row per knob, value, frame and pass (primary,
//! or one light's shadow pass), with the work, the times and, for image knobs, the error.

use serde::{Deserialize, Serialize};

use super::error::MaskError;
use super::knobs::KnobKind;
use crate::compare::CompareRow;
use crate::stats::Cell;

/// One pass of one knob value on one frame (also the protocol's wire form and the report
/// folder's record).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TradeRow {
    pub knob: String,
    pub kind: KnobKind,
    pub value: String,
    pub is_default: bool,
    /// The value's method, `LABEL=NAME=VALUE,...`.
    pub settings: String,
    /// The rendered image size.
    pub width: u32,
    pub height: u32,
    /// Counters of the counted pass, times of the timed passes (medians and spread).
    pub row: CompareRow,
    /// Work knobs: whether every answer of the frame equals the default value's bit for bit.
    pub answers_equal: Option<bool>,
    /// Image knobs, shadow passes: the light's mask against the reference's.
    pub error: Option<MaskError>,
}

impl TradeRow {
    /// Box tests plus triangle tests per ray: the two tests a ray pays for, fair across widths
    /// (one 8-wide node visit is eight box tests).
    pub fn work_per_ray(&self) -> f64 {
        self.row.stats.nbox_per_ray + self.row.stats.nt_per_ray
    }
}

/// One row's cells by column, in `trade.csv`'s order: the one list the CSV header, its cells
/// and the Python client's dicts are made from. `None`: no value (an empty cell, Python's None).
pub fn cells(r: &TradeRow) -> Vec<(&'static str, Option<Cell<'_>>)> {
    use Cell::*;
    let s = &r.row.stats;
    let error = |f: fn(&MaskError) -> f64| r.error.as_ref().map(|e| Real(f(e)));
    vec![
        ("knob", Some(Text(&r.knob))),
        ("kind", Some(Text(r.kind.name()))),
        ("value", Some(Text(&r.value))),
        ("default", Some(Flag(r.is_default))),
        ("settings", Some(Text(&r.settings))),
        ("frame", Some(Int(i64::from(s.frame)))),
        ("pass", Some(Text(&s.pass))),
        ("light", Some(Text(&s.light))),
        ("width", Some(Count(u64::from(r.width)))),
        ("height", Some(Count(u64::from(r.height)))),
        ("rays", Some(Count(s.rays))),
        ("occluded_fraction", Some(Real(s.occluded_fraction))),
        ("nb_per_ray", Some(Real(s.nb_per_ray))),
        ("nl_per_ray", Some(Real(s.nl_per_ray))),
        ("nt_per_ray", Some(Real(s.nt_per_ray))),
        ("nbox_per_ray", Some(Real(s.nbox_per_ray))),
        ("work_per_ray", Some(Real(r.work_per_ray()))),
        ("build_ms", Some(Real(r.row.build_ms.median))),
        ("prepare_ms", Some(Real(r.row.prepare_ms.median))),
        ("trace_ms", Some(Real(r.row.trace_ms.median))),
        ("frame_ms", Some(Real(r.row.frame_ms.median))),
        ("frame_ms_min", Some(Real(r.row.frame_ms.min))),
        ("frame_ms_max", Some(Real(r.row.frame_ms.max))),
        (
            "answers",
            r.answers_equal
                .map(|equal| Text(if equal { "equal" } else { "differ" })),
        ),
        ("rmse", error(|e| e.rmse)),
        ("p99_abs_error", error(|e| e.p99_abs)),
        ("flip_share", error(|e| e.flip_share)),
    ]
}

/// Every column of `trade.csv`, in order.
pub fn columns() -> Vec<&'static str> {
    let row = TradeRow {
        knob: String::new(),
        kind: KnobKind::Work,
        value: String::new(),
        is_default: false,
        settings: String::new(),
        width: 0,
        height: 0,
        row: CompareRow {
            label: String::new(),
            stats: crate::stats::StatsRow::default(),
            build_ms: Default::default(),
            prepare_ms: Default::default(),
            trace_ms: Default::default(),
            frame_ms: Default::default(),
        },
        answers_equal: None,
        error: None,
    };
    cells(&row).into_iter().map(|(name, _)| name).collect()
}

#[cfg(feature = "files")]
fn text(c: Option<Cell>) -> String {
    match c {
        None => String::new(),
        Some(Cell::Text(t)) => t.to_string(),
        Some(Cell::Int(i)) => i.to_string(),
        Some(Cell::Count(n)) => n.to_string(),
        Some(Cell::Flag(b)) => b.to_string(),
        Some(Cell::Real(x)) => x.to_string(),
    }
}

#[cfg(feature = "files")]
/// `rows` as CSV text (missing values are empty cells, which pandas reads as NaN).
pub fn to_csv(rows: &[TradeRow]) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(columns()).expect("writing to memory");
    for r in rows {
        let record: Vec<String> = cells(r).into_iter().map(|(_, c)| text(c)).collect();
        w.write_record(record).expect("writing to memory");
    }
    String::from_utf8(w.into_inner().expect("writing to memory")).expect("CSV of UTF-8 cells")
}

#[cfg(all(test, feature = "files"))]
mod tests {
    use super::*;
    use crate::compare::Timing;
    use crate::stats::StatsRow;

    #[test]
    fn header_and_cells_line_up() {
        let row = TradeRow {
            knob: "spp".into(),
            kind: KnobKind::Image,
            value: "16".into(),
            is_default: false,
            settings: "16=width=8,order=sorted,spp=16".into(),
            width: 40,
            height: 30,
            row: CompareRow {
                label: "16".into(),
                stats: StatsRow {
                    light: "Sun, key".into(),
                    nbox_per_ray: 2.0,
                    nt_per_ray: 0.5,
                    ..StatsRow::default()
                },
                build_ms: Timing::default(),
                prepare_ms: Timing::default(),
                trace_ms: Timing::default(),
                frame_ms: Timing::of(&[3.0, 4.0, 5.0]),
            },
            answers_equal: None,
            error: Some(MaskError {
                rmse: 0.25,
                p99_abs: 0.5,
                flip_share: 0.125,
            }),
        };
        let text = to_csv(std::slice::from_ref(&row));
        let mut r = csv::Reader::from_reader(text.as_bytes());
        let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
        assert_eq!(header, columns());
        assert_eq!(header.len(), 27);
        assert_eq!(
            (header[0].as_str(), header[26].as_str()),
            ("knob", "flip_share")
        );
        let rec = r.records().next().unwrap().unwrap();
        let get = |name: &str| rec[header.iter().position(|h| h == name).unwrap()].to_string();
        assert_eq!(get("light"), "Sun, key");
        assert_eq!(get("work_per_ray"), "2.5");
        assert_eq!(get("frame_ms_max"), "5");
        assert_eq!(get("answers"), "");
        assert_eq!(get("flip_share"), "0.125");
    }
}
