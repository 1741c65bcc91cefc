//! [`ReportFolder`]: a report folder recorded frame by frame (each frame's record written
//! atomically after its difference images), resumable, and its report written from every
//! recorded frame in frame order.

use std::path::{Path, PathBuf};

use antumbra_core::compare::Mismatch;
use antumbra_core::settings::NamedSettings;
use anyhow::{bail, Result};

use crate::diff_maps::write_diff_maps;
use crate::frame_records::{self, settings_text, FrameRecords, Layout};
use crate::record::{ComparedFrame, FrameRecord, ReportSetup};
use crate::report::Report;

const LAYOUT: Layout = Layout {
    setup_file: "setup.json",
    folder: "report folder",
    run: "comparison",
    pretty_frames: true,
};

impl frame_records::Setup for ReportSetup {
    fn differences(&self, other: &Self, recorded: &str, given: &str) -> Vec<String> {
        ReportSetup::differences(self, other, recorded, given)
    }
}

impl frame_records::Frame for FrameRecord {
    fn frame(&self) -> i32 {
        self.frame
    }

    fn settings(&self) -> &NamedSettings {
        &self.settings
    }
}

/// A report folder: its setup, the frames recorded so far, and the report written from them.
pub struct ReportFolder {
    records: FrameRecords<ReportSetup, FrameRecord>,
}

impl ReportFolder {
    /// Opens `out` (made if missing) for `setup`, resuming the frames recorded there before. A
    /// folder recorded with another scene, other methods, baseline or repeat is an error
    /// naming what differs.
    pub fn open(out: &Path, setup: ReportSetup) -> Result<Self> {
        let records = FrameRecords::open(out, &LAYOUT, setup)?;
        Ok(ReportFolder { records })
    }

    /// Opens `out` afresh for `setup`: frames recorded there before are forgotten (their
    /// records removed), whatever comparison recorded them.
    pub fn create(out: &Path, setup: ReportSetup) -> Result<Self> {
        let records = FrameRecords::create(out, &LAYOUT, setup)?;
        Ok(ReportFolder { records })
    }

    pub fn out(&self) -> &Path {
        self.records.out()
    }

    pub fn setup(&self) -> &ReportSetup {
        self.records.setup()
    }

    /// The frames recorded so far, in order.
    pub fn frames(&self) -> Vec<i32> {
        self.records.frames()
    }

    /// Every recorded mismatch, in frame order.
    pub fn mismatches(&self) -> impl Iterator<Item = &Mismatch> {
        self.records.records().flat_map(|f| &f.mismatches)
    }

    /// Records one frame (replacing an earlier record of it): its difference images, then its
    /// record. A frame of another comparison, or of other shared settings than the frames
    /// recorded before, is refused.
    pub fn add(&mut self, frame: ComparedFrame) -> Result<()> {
        frame.check(self.setup())?;
        if let Some(other) = self.records.other_settings(frame.frame, &frame.settings) {
            bail!(
                "frame {} was compared with other shared settings than frame {} of the report: \
                 {} against {}",
                frame.frame,
                other.frame,
                settings_text(&frame.settings, ","),
                settings_text(&other.settings, ",")
            );
        }
        let diffs = write_diff_maps(self.out(), frame.frame, &self.setup().baseline, &frame.heat)?;
        self.records.add(FrameRecord {
            frame: frame.frame,
            settings: frame.settings,
            rows: frame.rows,
            mismatches: frame.mismatches,
            diffs,
        })
    }

    /// The report of every recorded frame, in frame order.
    fn report(&self) -> Result<Report<'_>> {
        let setup = self.setup();
        let specs = setup.specs()?;
        let records = self.records.records();
        let common = records
            .clone()
            .next()
            .map(|r| r.settings.clone())
            .unwrap_or_default();
        let settings = specs
            .iter()
            .map(|s| Ok(s.resolve(&common)?))
            .collect::<Result<Vec<_>>>()?;
        Ok(Report {
            scene: &setup.scene,
            specs,
            settings,
            baseline: &setup.baseline,
            repeat: setup.repeat,
            rows: records
                .clone()
                .flat_map(|r| r.rows.iter().cloned())
                .collect(),
            mismatches: self.mismatches().cloned().collect(),
            diffs: records.flat_map(|r| r.diffs.iter().cloned()).collect(),
        })
    }

    /// Writes compare.csv, compare.json, summary.md, plots/ and report.html from every
    /// recorded frame; returns report.html's path.
    pub fn write(&self) -> Result<PathBuf> {
        self.report()?.write(self.out())
    }

    /// The time table and the shadow work ratios, for the terminal.
    pub fn terminal_table(&self) -> Result<String> {
        Ok(self.report()?.terminal_table())
    }
}
