//! What a report folder records: its setup (`frames/setup.json`: scene, methods, baseline,
//! repeat) and one record per frame (`frames/frame_NNNN.json`: rows, mismatches, diff images).

use antumbra_core::compare::{CompareRow, Comparison, FrameComparison, MethodSpec, Mismatch};
use antumbra_core::image::ImagePlane;
use antumbra_core::settings::NamedSettings;
use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};

use crate::diff_maps::DiffMap;

/// What a report compares; a folder is resumed only with the same setup.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReportSetup {
    pub scene: String,
    /// Each method as `LABEL=NAME=VALUE,...` (`MethodSpec`'s own spelling), in order.
    pub methods: Vec<String>,
    /// The baseline's label.
    pub baseline: String,
    pub repeat: usize,
}

impl ReportSetup {
    /// Checked as a comparison checks them: methods that parse with unique labels, a baseline
    /// among them (None: the first), at least one timed pass.
    pub fn new(
        scene: &str,
        methods: &[MethodSpec],
        baseline: Option<&str>,
        repeat: usize,
    ) -> Result<Self> {
        // The comparison's own checks, with no render state made.
        let comparison = Comparison::new(methods, &NamedSettings::new(), baseline, repeat)?;
        Ok(ReportSetup {
            scene: scene.to_string(),
            methods: methods.iter().map(|m| m.to_string()).collect(),
            baseline: comparison.baseline().to_string(),
            repeat,
        })
    }

    /// The setup of `comparison` on `scene`.
    pub fn of(scene: &str, comparison: &Comparison) -> Self {
        ReportSetup {
            scene: scene.to_string(),
            methods: comparison.specs().iter().map(|m| m.to_string()).collect(),
            baseline: comparison.baseline().to_string(),
            repeat: comparison.repeat(),
        }
    }

    pub fn specs(&self) -> Result<Vec<MethodSpec>> {
        self.methods
            .iter()
            .map(|m| Ok(m.parse::<MethodSpec>()?))
            .collect()
    }

    /// What differs from `other` (`recorded` names this one, `given` the other), in words.
    pub fn differences(&self, other: &ReportSetup, recorded: &str, given: &str) -> Vec<String> {
        let mut out = Vec::new();
        let mut differ = |what: &str, a: String, b: String| {
            if a != b {
                out.push(format!("{what}: {recorded} {a}, {given} {b}"));
            }
        };
        differ("scene", quoted(&self.scene), quoted(&other.scene));
        differ("methods", self.methods.join(" "), other.methods.join(" "));
        differ("baseline", quoted(&self.baseline), quoted(&other.baseline));
        differ("repeat", self.repeat.to_string(), other.repeat.to_string());
        out
    }
}

fn quoted(s: &str) -> String {
    format!("'{s}'")
}

/// One frame as a comparison gave it, ready to be recorded: the Python client builds it from a
/// `CompareResult` reply, `antumbra compare` from its [`FrameComparison`].
#[derive(Clone, Debug)]
pub struct ComparedFrame {
    pub frame: i32,
    pub methods: Vec<String>,
    pub baseline: String,
    pub repeat: usize,
    /// The settings every method shared.
    pub settings: NamedSettings,
    pub rows: Vec<CompareRow>,
    pub mismatches: Vec<Mismatch>,
    /// Each method's shadow N_B plane by label, in method order (empty: no difference images).
    pub heat: Vec<(String, ImagePlane)>,
}

impl ComparedFrame {
    /// `result` of `comparison`, its heat planes moved out of the methods' results.
    pub fn of(comparison: &Comparison, result: FrameComparison) -> Self {
        let mut rows = Vec::new();
        let mut heat = Vec::new();
        for mut m in result.methods {
            if let Some(h) = m.result.heat.take() {
                let [nb, _, _] = h.shadow;
                heat.push((m.label.clone(), nb));
            }
            rows.append(&mut m.rows);
        }
        ComparedFrame {
            frame: result.frame,
            methods: comparison.specs().iter().map(|m| m.to_string()).collect(),
            baseline: comparison.baseline().to_string(),
            repeat: comparison.repeat(),
            settings: comparison.common().clone(),
            rows,
            mismatches: result.mismatches,
            heat,
        }
    }

    /// Refuses a frame of another comparison than `setup`'s.
    pub fn check(&self, setup: &ReportSetup) -> Result<()> {
        let mine = ReportSetup {
            scene: setup.scene.clone(),
            methods: self.methods.clone(),
            baseline: self.baseline.clone(),
            repeat: self.repeat,
        };
        let differ = setup.differences(&mine, "the report has", "the frame has");
        if !differ.is_empty() {
            bail!(
                "frame {} comes from another comparison than the report's: {}",
                self.frame,
                differ.join("; ")
            );
        }
        Ok(())
    }
}

/// A recorded frame, as `frames/frame_NNNN.json` holds it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameRecord {
    pub frame: i32,
    /// The settings every method shared (so `compare.json` resolves each method's settings).
    pub settings: NamedSettings,
    pub rows: Vec<CompareRow>,
    pub mismatches: Vec<Mismatch>,
    pub diffs: Vec<DiffMap>,
}
