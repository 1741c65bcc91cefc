//! Per-frame statistics: one row per frame, method and pass (the primary pass, and the shadow
//! pass of each light), with the columns defined once here and written as CSV and JSON.
//!
//! | column | meaning |
//! |---|---|
//! | scene, frame | what was rendered |
//! | method | builder / BVH width / shadow-ray child order, e.g. `sah/bin8/sato` |
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
//! | sort_ms | shadow: per-light preparation: logging + sorting of the sorted order; for `srdh`, ray selection + hit lists + SRDH build (0 for other orders) |
//! | references | triangle references in the structure's leaves (> triangles with spatial splits) |
//! | visible_input | triangles of the structure's set the build was told are visible (ABVH/OSAH/VSAH) |
//! | visibility_ms | time to get that set this frame (exact mode or first-frame prepass; else 0) |
//! | nts_per_ray | N_TS, the OSAH paper's traversal steps: nodes entered, N_B + N_L |
//!
//! The paper's N_IT (ray/triangle intersection tests) is `nt_per_ray`.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::output::write_bytes_atomic;
use crate::trace::TraversalStats;
use crate::{Error, Result};

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
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
    #[serde(default)]
    pub sort_ms: f64,
    #[serde(default)]
    pub references: u64,
    #[serde(default)]
    pub visible_input: u64,
    #[serde(default)]
    pub visibility_ms: f64,
    #[serde(default)]
    pub nts_per_ray: f64,
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

pub const CSV_COLUMNS: &[&str] = &[
    "scene",
    "frame",
    "method",
    "pass",
    "light",
    "rebuilt",
    "build_ms",
    "bvh_nodes",
    "bvh_bytes",
    "triangles",
    "rays",
    "trace_ms",
    "mrays_per_s",
    "timed_without_counters",
    "occluded_fraction",
    "nb_per_ray",
    "nl_per_ray",
    "nt_per_ray",
    "nbox_per_ray",
    "back_facing",
    "unreached",
    "sort_ms",
    "references",
    "visible_input",
    "visibility_ms",
    "nts_per_ray",
];

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The rows as CSV text with a header line.
pub fn to_csv(rows: &[StatsRow]) -> String {
    let mut out = CSV_COLUMNS.join(",");
    out.push('\n');
    for r in rows {
        let fields = [
            csv_field(&r.scene),
            r.frame.to_string(),
            csv_field(&r.method),
            csv_field(&r.pass),
            csv_field(&r.light),
            r.rebuilt.to_string(),
            format!("{:.4}", r.build_ms),
            r.bvh_nodes.to_string(),
            r.bvh_bytes.to_string(),
            r.triangles.to_string(),
            r.rays.to_string(),
            format!("{:.4}", r.trace_ms),
            format!("{:.4}", r.mrays_per_s),
            r.timed_without_counters.to_string(),
            format!("{:.6}", r.occluded_fraction),
            format!("{:.6}", r.nb_per_ray),
            format!("{:.6}", r.nl_per_ray),
            format!("{:.6}", r.nt_per_ray),
            format!("{:.6}", r.nbox_per_ray),
            r.back_facing.to_string(),
            r.unreached.to_string(),
            format!("{:.4}", r.sort_ms),
            r.references.to_string(),
            r.visible_input.to_string(),
            format!("{:.4}", r.visibility_ms),
            format!("{:.6}", r.nts_per_ray),
        ];
        out.push_str(&fields.join(","));
        out.push('\n');
    }
    out
}

pub fn write_csv(path: &Path, rows: &[StatsRow]) -> Result<()> {
    write_bytes_atomic(path, to_csv(rows).as_bytes())
}

pub fn write_json(path: &Path, rows: &[StatsRow]) -> Result<()> {
    let text = serde_json::to_string_pretty(rows).map_err(|e| Error::io(path, e))?;
    write_bytes_atomic(path, text.as_bytes())
}

#[cfg(test)]
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
        assert_eq!(lines.next().unwrap().split(',').count(), CSV_COLUMNS.len());
        assert!(lines.next().unwrap().starts_with("\"a,b\",0,"));
    }

    #[test]
    fn json_round_trips() {
        let dir = std::env::temp_dir().join(format!("antumbra-stats-{}", std::process::id()));
        let path = dir.join("s.json");
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
        std::fs::remove_dir_all(dir).unwrap();
    }
}
