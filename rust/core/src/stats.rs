//! Per-frame statistics: one row per frame, method and pass (the primary pass, and the shadow
//! pass of each light), with the columns defined once here and written as CSV and JSON (both
//! through serde: every number at full precision, so the two files hold the same values).
//!
//! | column | meaning |
//! |---|---|
//! | scene, frame | what was rendered |
//! | method | builder (with `:leafK` for a smallest leaf K > 1) / BVH width / shadow-ray child order, e.g. `sah/bin8/sato`, `osah-previous:leaf8/bin2/fbto` |
//! | pass | `primary` (closest hit) or `shadow` (any hit) |
//! | light | the light's name (empty for the primary pass) |
//! | rebuilt | whether this frame built its BVH (false: the geometry did not change) |
//! | build_ms | wall-clock BVH build time of this frame (0 when not rebuilt) |
//! | bvh_nodes, bvh_bytes | size of the structure the pass traversed (`srdh`: the light's SRDH tree with its kernel bits, when it has one) |
//! | triangles | triangles in that structure |
//! | rays | rays traced |
//! | trace_ms | wall-clock time of the pass, ray generation included |
//! | mrays_per_s | rays / trace time, in millions per second |
//! | timed_without_counters | true if trace_ms comes from the uncounted traversal |
//! | occluded_fraction | shadow: occluded rays / rays; primary: rays that hit / rays |
//! | nb_per_ray | N_B: interior nodes entered per ray |
//! | nl_per_ray | N_L: leaves entered per ray |
//! | nt_per_ray | N_T: ray/triangle tests per ray |
//! | nbox_per_ray | N_box: ray/box tests per ray |
//! | back_facing | shadow samples behind the surface's own plane (shadowed, no ray) |
//! | unreached | shadow samples of points outside a spot cone or behind an area light |
//! | prepare_ms | shadow: per-light preparation: choosing the representative rays, logging and sorting of the sorted order; for `srdh`, ray selection + hit lists + SRDH build; for `sato`, `rtsah`, `random` (made once per tree and shared by the lights), the preparation on the first shadow row of the frame that made it (0 elsewhere and for other orders) |
//! | references | triangle references in the structure's leaves (> triangles with spatial splits) |
//! | visible_input | triangles of the structure's set the build was told are visible (ABVH/OSAH/VSAH) |
//! | visibility_ms | time to get that set this frame (exact mode or first-frame prepass; else 0) |
//! | nts_per_ray | N_TS, the OSAH paper's traversal steps: nodes entered, N_B + N_L |
//! | auto_choice | what `auto` chose for this pass (empty for fixed methods): primary `sah`, `osah` or `keep` (the build); shadow `fbto`, `sato`, `sorted` or `srdh` (the light's order), then `;sample=ORDER` when another order was measured on a sample of its rays; `explore:` first for a build taken to measure it (docs/auto.md) |
//! | auto_estimate_ms | the cost model's estimate behind that choice, ms (0 when it was never measured) |
//! | trees_refit | two levels: mesh trees this frame refit (a deforming mesh's tree keeping its topology, new boxes) rather than built; their time is in build_ms (0 when not rebuilt, and on a flat frame) |
//! | alpha_lookups_per_ray | alpha evaluations per ray: candidate hits on alpha-textured triangles (camera rays' closest-hit candidates, shadow rays' distinct transparent hits; 0 for a frame without alpha or a pass timed without counters) |
//! | packets | packets of neighbouring rays traced together (`rays=packet`; 0 for single rays) |
//! | steps_per_packet | interior nodes a packet took together, per packet (a node counts one step whatever its active lanes; the per-ray columns count it once per active lane) |
//! | handoffs_per_ray | per ray, lane hand-offs from a packet to the single-ray traversal (at a subtree where few lanes stayed active; a lane may be handed off at several) |
//!
//! The paper's N_IT (ray/triangle intersection tests) is `nt_per_ray`.

#[cfg(feature = "files")]
use std::path::Path;

use serde::{Deserialize, Serialize};

#[cfg(feature = "files")]
use crate::atomic_file::write_bytes_atomic;
use crate::trace::TraversalStats;
#[cfg(feature = "files")]
use crate::{Error, Result};

/// One pass of one frame (the primary pass, or the shadow pass of one light). This struct is
/// also the protocol's wire form (`StatsRowState`); `#[serde(default)]` lets a newer reader
/// take rows without the columns added since. A new column goes here and in [`StatsRow::cells`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct StatsRow {
    pub scene: String,
    pub frame: i32,
    pub method: String,
    pub pass: String,
    pub light: String,
    pub rebuilt: bool,
    pub build_ms: f64,
    pub bvh_nodes: u64,
    pub bvh_bytes: u64,
    pub triangles: u64,
    pub rays: u64,
    pub trace_ms: f64,
    pub mrays_per_s: f64,
    pub timed_without_counters: bool,
    pub occluded_fraction: f64,
    pub nb_per_ray: f64,
    pub nl_per_ray: f64,
    pub nt_per_ray: f64,
    pub nbox_per_ray: f64,
    pub back_facing: u64,
    pub unreached: u64,
    pub prepare_ms: f64,
    pub references: u64,
    pub visible_input: u64,
    pub visibility_ms: f64,
    pub nts_per_ray: f64,
    pub auto_choice: String,
    pub auto_estimate_ms: f64,
    pub alpha_lookups_per_ray: f64,
    pub trees_refit: u64,
    pub packets: u64,
    pub steps_per_packet: f64,
    pub handoffs_per_ray: f64,
}

impl StatsRow {
    /// Fills the per-ray work columns from exact totals.
    pub fn set_work(&mut self, totals: &TraversalStats) {
        let r = self.rays.max(1) as f64;
        self.nb_per_ray = totals.inner as f64 / r;
        self.nl_per_ray = totals.leaves as f64 / r;
        self.nt_per_ray = totals.triangles as f64 / r;
        self.nbox_per_ray = totals.boxes as f64 / r;
        self.nts_per_ray = (totals.inner + totals.leaves) as f64 / r;
        self.packets = totals.packets;
        self.steps_per_packet = totals.packet_steps as f64 / totals.packets.max(1) as f64;
        self.handoffs_per_ray = totals.handoffs as f64 / r;
    }

    /// The row with its wall-clock columns zeroed (build, trace, Mrays/s, preparation and
    /// visibility times): what two runs of the same frames must agree on exactly.
    pub fn untimed(&self) -> StatsRow {
        StatsRow {
            build_ms: 0.0,
            trace_ms: 0.0,
            mrays_per_s: 0.0,
            prepare_ms: 0.0,
            visibility_ms: 0.0,
            ..self.clone()
        }
    }

    pub fn set_timing(&mut self, trace_ms: f64, without_counters: bool) {
        self.trace_ms = trace_ms;
        self.timed_without_counters = without_counters;
        self.mrays_per_s = if trace_ms > 0.0 {
            self.rays as f64 / (trace_ms * 1e3)
        } else {
            0.0
        };
    }
}

/// One column's value, as the Python client's dicts of a row need it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cell<'a> {
    Text(&'a str),
    Int(i64),
    Count(u64),
    Flag(bool),
    Real(f64),
}

impl StatsRow {
    /// Every column, named and in order: the one list the Python client's dicts and the CSV
    /// header are made from (tests check it against the struct's fields and their order).
    pub fn cells(&self) -> Vec<(&'static str, Cell<'_>)> {
        use Cell::*;
        vec![
            ("scene", Text(&self.scene)),
            ("frame", Int(self.frame as i64)),
            ("method", Text(&self.method)),
            ("pass", Text(&self.pass)),
            ("light", Text(&self.light)),
            ("rebuilt", Flag(self.rebuilt)),
            ("build_ms", Real(self.build_ms)),
            ("bvh_nodes", Count(self.bvh_nodes)),
            ("bvh_bytes", Count(self.bvh_bytes)),
            ("triangles", Count(self.triangles)),
            ("rays", Count(self.rays)),
            ("trace_ms", Real(self.trace_ms)),
            ("mrays_per_s", Real(self.mrays_per_s)),
            ("timed_without_counters", Flag(self.timed_without_counters)),
            ("occluded_fraction", Real(self.occluded_fraction)),
            ("nb_per_ray", Real(self.nb_per_ray)),
            ("nl_per_ray", Real(self.nl_per_ray)),
            ("nt_per_ray", Real(self.nt_per_ray)),
            ("nbox_per_ray", Real(self.nbox_per_ray)),
            ("back_facing", Count(self.back_facing)),
            ("unreached", Count(self.unreached)),
            ("prepare_ms", Real(self.prepare_ms)),
            ("references", Count(self.references)),
            ("visible_input", Count(self.visible_input)),
            ("visibility_ms", Real(self.visibility_ms)),
            ("nts_per_ray", Real(self.nts_per_ray)),
            ("auto_choice", Text(&self.auto_choice)),
            ("auto_estimate_ms", Real(self.auto_estimate_ms)),
            ("alpha_lookups_per_ray", Real(self.alpha_lookups_per_ray)),
            ("trees_refit", Count(self.trees_refit)),
            ("packets", Count(self.packets)),
            ("steps_per_packet", Real(self.steps_per_packet)),
            ("handoffs_per_ray", Real(self.handoffs_per_ray)),
        ]
    }

    /// The column names, in CSV order.
    pub fn columns() -> Vec<&'static str> {
        StatsRow::default()
            .cells()
            .into_iter()
            .map(|(name, _)| name)
            .collect()
    }
}

#[cfg(feature = "files")]
/// The rows as CSV text with a header line: the one writer of `stats.csv` (the CLI, the spool and
/// the Python client's `write_stats_csv` all call it). Columns in field order; text is quoted
/// only where it must be; reals print as the shortest text that reads back to the same value.
pub fn to_csv(rows: &[StatsRow]) -> String {
    let mut w = csv::WriterBuilder::new()
        .has_headers(false)
        .from_writer(Vec::new());
    // Written by hand so that no rows still give the header.
    let header = w.write_record(StatsRow::columns());
    let body = rows.iter().try_for_each(|r| w.serialize(r));
    // Writing plain fields into memory cannot fail.
    header.and(body).expect("CSV of a stats row");
    let bytes = w.into_inner().expect("CSV in memory");
    String::from_utf8(bytes).expect("CSV of UTF-8 fields")
}

#[cfg(feature = "files")]
pub fn write_csv(path: &Path, rows: &[StatsRow]) -> Result<()> {
    write_bytes_atomic(path, to_csv(rows).as_bytes())
}

#[cfg(feature = "files")]
pub fn write_json(path: &Path, rows: &[StatsRow]) -> Result<()> {
    let text = serde_json::to_string_pretty(rows).map_err(|e| Error::io(path, e))?;
    write_bytes_atomic(path, text.as_bytes())
}

#[cfg(all(test, feature = "files"))]
mod tests {
    use super::*;

    #[test]
    fn csv_has_every_column_and_quotes_commas() {
        let row = StatsRow {
            scene: "a,b".into(),
            rays: 10,
            ..StatsRow::default()
        };
        let csv = to_csv(&[row]);
        let mut lines = csv.lines();
        assert_eq!(
            lines.next().unwrap().split(',').count(),
            StatsRow::columns().len()
        );
        assert!(lines.next().unwrap().starts_with("\"a,b\",0,"));
        assert_eq!(to_csv(&[]), StatsRow::columns().join(",") + "\n");
    }

    /// serde's field order (the CSV's columns) is the order of `cells`, the header's.
    #[test]
    fn csv_columns_follow_the_fields() {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(StatsRow::default()).unwrap();
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        assert_eq!(text.lines().next().unwrap(), StatsRow::columns().join(","));
    }

    /// Reals keep every digit, so the CSV reads back to the JSON's values.
    #[test]
    fn csv_reals_read_back_exactly() {
        let row = StatsRow {
            trace_ms: 0.1 + 0.2,
            nb_per_ray: 1.0 / 3.0,
            occluded_fraction: 1e-7,
            ..StatsRow::default()
        };
        let csv = to_csv(std::slice::from_ref(&row));
        let back: StatsRow = csv::Reader::from_reader(csv.as_bytes())
            .deserialize()
            .next()
            .unwrap()
            .unwrap();
        assert_eq!(back, row);
    }

    #[test]
    fn json_round_trips() {
        let dir = tempfile::TempDir::new().unwrap();
        let path = dir.path().join("s.json");
        let row = StatsRow {
            scene: "x".into(),
            frame: 3,
            nb_per_ray: 1.5,
            ..StatsRow::default()
        };
        write_json(&path, std::slice::from_ref(&row)).unwrap();
        let back: Vec<StatsRow> =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(back, vec![row]);
    }

    /// `cells` must name every field once, with the field's own value: compared with what
    /// serde writes.
    #[test]
    fn cells_are_the_fields() {
        let row = StatsRow {
            scene: "s".into(),
            frame: -2,
            method: "m".into(),
            pass: "p".into(),
            light: "l".into(),
            rebuilt: true,
            build_ms: 1.5,
            bvh_nodes: 2,
            bvh_bytes: 3,
            triangles: 4,
            rays: 5,
            trace_ms: 6.5,
            mrays_per_s: 7.5,
            timed_without_counters: true,
            occluded_fraction: 0.25,
            nb_per_ray: 8.5,
            nl_per_ray: 9.5,
            nt_per_ray: 10.5,
            nbox_per_ray: 11.5,
            back_facing: 12,
            unreached: 13,
            prepare_ms: 14.5,
            references: 15,
            visible_input: 16,
            visibility_ms: 17.5,
            nts_per_ray: 18.5,
            auto_choice: "explore:srdh".into(),
            auto_estimate_ms: 19.5,
            alpha_lookups_per_ray: 20.5,
            trees_refit: 21,
            packets: 22,
            steps_per_packet: 23.5,
            handoffs_per_ray: 24.5,
        };
        let serde_json::Value::Object(fields) = serde_json::to_value(&row).unwrap() else {
            panic!("a row serialises to a map");
        };
        let cells = row.cells();
        let mut names: Vec<&str> = cells.iter().map(|(n, _)| *n).collect();
        names.sort_unstable();
        let keys: Vec<&str> = fields.keys().map(String::as_str).collect();
        assert_eq!(names, keys, "one cell per field, none twice");
        for (name, cell) in &cells {
            let value = &fields[*name];
            let as_json = match *cell {
                Cell::Text(s) => serde_json::json!(s),
                Cell::Int(v) => serde_json::json!(v),
                Cell::Count(v) => serde_json::json!(v),
                Cell::Flag(v) => serde_json::json!(v),
                Cell::Real(v) => serde_json::json!(v),
            };
            assert_eq!(&as_json, value, "column {name}");
        }
    }
}
