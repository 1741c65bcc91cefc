//! The trade's long-form table (`trade.csv`): one row per knob, value, frame and pass (primary,
//! or one light's shadow pass), with the work, the times and, for image knobs, the error.

use super::error::MaskError;
use super::knobs::KnobKind;
use crate::compare::CompareRow;

/// One pass of one knob value on one frame.
#[derive(Clone, Debug)]
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

/// Every column of `trade.csv`, in order.
pub const COLUMNS: &[&str] = &[
    "knob",
    "kind",
    "value",
    "default",
    "settings",
    "frame",
    "pass",
    "light",
    "width",
    "height",
    "rays",
    "occluded_fraction",
    "nb_per_ray",
    "nl_per_ray",
    "nt_per_ray",
    "nbox_per_ray",
    "work_per_ray",
    "build_ms",
    "sort_ms",
    "trace_ms",
    "frame_ms",
    "frame_ms_min",
    "frame_ms_max",
    "answers",
    "rmse",
    "p99_abs_error",
    "flip_share",
];

fn cells(r: &TradeRow) -> Vec<String> {
    let s = &r.row.stats;
    let real = |x: f64| x.to_string();
    let error = |f: fn(&MaskError) -> f64| r.error.as_ref().map(f).map(real).unwrap_or_default();
    vec![
        r.knob.clone(),
        r.kind.name().into(),
        r.value.clone(),
        r.is_default.to_string(),
        r.settings.clone(),
        s.frame.to_string(),
        s.pass.clone(),
        s.light.clone(),
        r.width.to_string(),
        r.height.to_string(),
        s.rays.to_string(),
        real(s.occluded_fraction),
        real(s.nb_per_ray),
        real(s.nl_per_ray),
        real(s.nt_per_ray),
        real(s.nbox_per_ray),
        real(r.work_per_ray()),
        real(r.row.build_ms.median),
        real(r.row.sort_ms.median),
        real(r.row.trace_ms.median),
        real(r.row.frame_ms.median),
        real(r.row.frame_ms.min),
        real(r.row.frame_ms.max),
        match r.answers_equal {
            Some(true) => "equal".into(),
            Some(false) => "differ".into(),
            None => String::new(),
        },
        error(|e| e.rmse),
        error(|e| e.p99_abs),
        error(|e| e.flip_share),
    ]
}

/// `rows` as CSV text (missing values are empty cells, which pandas reads as NaN).
pub fn to_csv(rows: &[TradeRow]) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(COLUMNS).expect("writing to memory");
    for r in rows {
        w.write_record(cells(r)).expect("writing to memory");
    }
    String::from_utf8(w.into_inner().expect("writing to memory")).expect("CSV of UTF-8 cells")
}

#[cfg(test)]
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
                sort_ms: Timing::default(),
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
        assert_eq!(header, COLUMNS);
        let rec = r.records().next().unwrap().unwrap();
        let get = |name: &str| rec[header.iter().position(|h| h == name).unwrap()].to_string();
        assert_eq!(get("light"), "Sun, key");
        assert_eq!(get("work_per_ray"), "2.5");
        assert_eq!(get("frame_ms_max"), "5");
        assert_eq!(get("answers"), "");
        assert_eq!(get("flip_share"), "0.125");
    }
}
