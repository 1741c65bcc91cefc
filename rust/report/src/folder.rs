//! [`ReportFolder`]: a report folder recorded frame by frame (each frame's record written
//! atomically after its difference images), resumable, and its report written from every
//! recorded frame in frame order.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use antumbra_core::atomic_file::write_bytes_atomic;
use antumbra_core::compare::Mismatch;
use antumbra_core::output::frame_stem;
use antumbra_core::settings::NamedSettings;
use anyhow::{bail, Context, Result};

use crate::diff_maps::write_diff_maps;
use crate::record::{ComparedFrame, FrameRecord, ReportSetup};
use crate::report::Report;

/// Where the records live, inside the report folder.
const FRAMES_DIR: &str = "frames";
const SETUP_FILE: &str = "setup.json";

/// A report folder: its setup, the frames recorded so far, and the report written from them.
pub struct ReportFolder {
    out: PathBuf,
    setup: ReportSetup,
    frames: BTreeMap<i32, FrameRecord>,
}

impl ReportFolder {
    /// Opens `out` (made if missing) for `setup`, resuming the frames recorded there before. A
    /// folder recorded with another scene, other methods, baseline or repeat is an error
    /// naming what differs.
    pub fn open(out: &Path, setup: ReportSetup) -> Result<Self> {
        let dir = out.join(FRAMES_DIR);
        let setup_path = dir.join(SETUP_FILE);
        if setup_path.exists() {
            let recorded: ReportSetup = read_json(&setup_path)?;
            let differ = recorded.differences(&setup, "recorded", "now");
            if !differ.is_empty() {
                bail!(
                    "the report folder {} was recorded for another comparison: {} (use another \
                     folder, or remove {})",
                    out.display(),
                    differ.join("; "),
                    dir.display()
                );
            }
        }
        let mut folder = ReportFolder {
            out: out.to_path_buf(),
            setup,
            frames: BTreeMap::new(),
        };
        folder.start()?;
        for (frame, path) in folder.record_files()? {
            let record: FrameRecord = read_json(&path)?;
            if record.frame != frame {
                bail!("{} holds frame {}", path.display(), record.frame);
            }
            folder.frames.insert(frame, record);
        }
        Ok(folder)
    }

    /// Opens `out` afresh for `setup`: frames recorded there before are forgotten (their
    /// records removed), whatever comparison recorded them.
    pub fn create(out: &Path, setup: ReportSetup) -> Result<Self> {
        let mut folder = ReportFolder {
            out: out.to_path_buf(),
            setup,
            frames: BTreeMap::new(),
        };
        for (_, path) in folder.record_files()? {
            std::fs::remove_file(&path).with_context(|| format!("removing {}", path.display()))?;
        }
        folder.start()?;
        Ok(folder)
    }

    /// The folders and the setup file.
    fn start(&mut self) -> Result<()> {
        let dir = self.out.join(FRAMES_DIR);
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let text = serde_json::to_string_pretty(&self.setup)?;
        write_bytes_atomic(&dir.join(SETUP_FILE), text.as_bytes())?;
        Ok(())
    }

    /// `(frame, path)` of every record file in the folder.
    fn record_files(&self) -> Result<Vec<(i32, PathBuf)>> {
        let dir = self.out.join(FRAMES_DIR);
        let entries = match std::fs::read_dir(&dir) {
            Ok(e) => e,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
            Err(e) => return Err(e).with_context(|| format!("reading {}", dir.display())),
        };
        let mut out = Vec::new();
        for entry in entries {
            let entry = entry.with_context(|| format!("reading {}", dir.display()))?;
            let name = entry.file_name();
            let frame = name
                .to_str()
                .and_then(|n| n.strip_prefix("frame_"))
                .and_then(|n| n.strip_suffix(".json"))
                .and_then(|n| n.parse::<i32>().ok());
            if let Some(frame) = frame {
                out.push((frame, entry.path()));
            }
        }
        out.sort();
        Ok(out)
    }

    pub fn out(&self) -> &Path {
        &self.out
    }

    pub fn setup(&self) -> &ReportSetup {
        &self.setup
    }

    /// The frames recorded so far, in order.
    pub fn frames(&self) -> Vec<i32> {
        self.frames.keys().copied().collect()
    }

    /// Every recorded mismatch, in frame order.
    pub fn mismatches(&self) -> impl Iterator<Item = &Mismatch> {
        self.frames.values().flat_map(|f| &f.mismatches)
    }

    /// Records one frame (replacing an earlier record of it): its difference images, then its
    /// record. A frame of another comparison, or of other shared settings than the frames
    /// recorded before, is refused.
    pub fn add(&mut self, frame: ComparedFrame) -> Result<()> {
        frame.check(&self.setup)?;
        if let Some(other) = self
            .frames
            .values()
            .find(|r| r.frame != frame.frame && r.settings != frame.settings)
        {
            bail!(
                "frame {} was compared with other shared settings than frame {} of the report: \
                 {} against {}",
                frame.frame,
                other.frame,
                settings_text(&frame.settings),
                settings_text(&other.settings)
            );
        }
        let diffs = write_diff_maps(&self.out, frame.frame, &self.setup.baseline, &frame.heat)?;
        let record = FrameRecord {
            frame: frame.frame,
            settings: frame.settings,
            rows: frame.rows,
            mismatches: frame.mismatches,
            diffs,
        };
        let path = self
            .out
            .join(FRAMES_DIR)
            .join(format!("{}.json", frame_stem(record.frame)));
        let text = serde_json::to_string_pretty(&record)?;
        write_bytes_atomic(&path, text.as_bytes())?;
        self.frames.insert(record.frame, record);
        Ok(())
    }

    /// The report of every recorded frame, in frame order.
    fn report(&self) -> Result<Report<'_>> {
        let specs = self.setup.specs()?;
        let common = self
            .frames
            .values()
            .next()
            .map(|r| r.settings.clone())
            .unwrap_or_default();
        let settings = specs
            .iter()
            .map(|s| Ok(s.resolve(&common)?))
            .collect::<Result<Vec<_>>>()?;
        let records = self.frames.values();
        Ok(Report {
            scene: &self.setup.scene,
            specs,
            settings,
            baseline: &self.setup.baseline,
            repeat: self.setup.repeat,
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
        self.report()?.write(&self.out)
    }

    /// The time table and the shadow work ratios, for the terminal.
    pub fn terminal_table(&self) -> Result<String> {
        Ok(self.report()?.terminal_table())
    }
}

fn settings_text(s: &NamedSettings) -> String {
    if s.0.is_empty() {
        return "none".into();
    }
    s.0.iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(",")
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("reading {}", path.display()))
}
