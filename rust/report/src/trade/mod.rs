//! The trade's folder (`docs/trade.md`): each frame recorded as it comes ([`TradeFolder`],
//! resumable), then `trade.csv`, `plots/KNOB.svg`/`.png` and `trade.md` from every recorded
//! frame. Used by `antumbra trade` and the Python client alike.

mod write;

use std::path::{Path, PathBuf};

use antumbra_core::settings::NamedSettings;
use antumbra_core::trade::{knob_choices, Trade, TradeFrame, TradeMismatch, TradeRow};
use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};

use crate::frame_records::{self, settings_text, FrameRecords, Layout};

pub use write::{recommendations, KnobReport, RunInfo};

const LAYOUT: Layout = Layout {
    setup_file: "trade.json",
    folder: "trade folder",
    run: "trade",
    pretty_frames: false,
};

/// What a trade measures; a folder is resumed only with the same setup.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TradeSetup {
    pub scene: String,
    /// Each knob as `NAME` or `NAME=V1,V2,...` (its values as given), in order.
    pub knobs: Vec<String>,
    pub repeat: usize,
}

impl TradeSetup {
    /// Checked as a trade checks them: known knobs, each once (none: every knob), and at
    /// least one timed pass.
    pub fn new<S: AsRef<str>>(scene: &str, knobs: &[S], repeat: usize) -> Result<Self> {
        if repeat == 0 {
            bail!("repeat: must be at least 1");
        }
        Ok(TradeSetup {
            scene: scene.to_string(),
            knobs: knob_texts(knobs)?,
            repeat,
        })
    }

    /// What differs from `other`, in words (`recorded` names this one, `given` the other).
    fn differences(&self, other: &TradeSetup, recorded: &str, given: &str) -> Vec<String> {
        let mut out = Vec::new();
        let mut differ = |what: &str, a: String, b: String| {
            if a != b {
                out.push(format!("{what}: {recorded} {a}, {given} {b}"));
            }
        };
        differ(
            "scene",
            format!("'{}'", self.scene),
            format!("'{}'", other.scene),
        );
        differ("knobs", self.knobs.join(" "), other.knobs.join(" "));
        differ("repeat", self.repeat.to_string(), other.repeat.to_string());
        out
    }
}

/// Each knob's text as a trade reads it, `NAME` or `NAME=V1,V2,...` (none: every knob).
pub fn knob_texts<S: AsRef<str>>(knobs: &[S]) -> Result<Vec<String>> {
    Ok(knob_choices(knobs)?
        .into_iter()
        .map(|(k, values)| match values {
            None => k.name.to_string(),
            Some(v) => format!("{}={}", k.name, v.join(",")),
        })
        .collect())
}

/// One traded frame, as `frames/frame_NNNN.json` records it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TradeRecord {
    pub frame: i32,
    /// Each knob as [`TradeSetup::knobs`] spells it, and the timed passes.
    pub knobs: Vec<String>,
    pub repeat: usize,
    /// The settings every value shared.
    pub settings: NamedSettings,
    pub rows: Vec<TradeRow>,
    pub mismatches: Vec<TradeMismatch>,
}

impl TradeRecord {
    /// `frame` as `trade` gave it; `knobs` as the trade was asked for.
    pub fn of(trade: &Trade, knobs: Vec<String>, frame: TradeFrame) -> Self {
        TradeRecord {
            frame: frame.frame,
            knobs,
            repeat: trade.repeat(),
            settings: trade.common().clone(),
            rows: frame.rows,
            mismatches: frame.mismatches,
        }
    }
}

impl frame_records::Setup for TradeSetup {
    fn differences(&self, other: &Self, recorded: &str, given: &str) -> Vec<String> {
        TradeSetup::differences(self, other, recorded, given)
    }
}

impl frame_records::Frame for TradeRecord {
    fn frame(&self) -> i32 {
        self.frame
    }

    fn settings(&self) -> &NamedSettings {
        &self.settings
    }
}

/// A trade folder: its setup, the frames recorded so far, and the files written from them.
pub struct TradeFolder {
    records: FrameRecords<TradeSetup, TradeRecord>,
}

impl TradeFolder {
    /// Opens `out` (made if missing) for `setup`, resuming the frames recorded there before; a
    /// folder recorded with another scene, other knobs or repeat is an error naming what
    /// differs.
    pub fn open(out: &Path, setup: TradeSetup) -> Result<Self> {
        let records = FrameRecords::open(out, &LAYOUT, setup)?;
        Ok(TradeFolder { records })
    }

    /// Opens `out` afresh for `setup`: frames recorded there before are forgotten.
    pub fn create(out: &Path, setup: TradeSetup) -> Result<Self> {
        let records = FrameRecords::create(out, &LAYOUT, setup)?;
        Ok(TradeFolder { records })
    }

    pub fn out(&self) -> &Path {
        self.records.out()
    }

    pub fn setup(&self) -> &TradeSetup {
        self.records.setup()
    }

    /// The frames recorded so far, in order.
    pub fn frames(&self) -> Vec<i32> {
        self.records.frames()
    }

    /// Every recorded mismatch, knob after knob, each in frame order.
    pub fn mismatches(&self) -> Vec<&TradeMismatch> {
        let mut all: Vec<&TradeMismatch> =
            self.records.records().flat_map(|f| &f.mismatches).collect();
        all.sort_by_key(|m| self.knob_index(&m.knob));
        all
    }

    fn knob_index(&self, name: &str) -> usize {
        self.setup()
            .knobs
            .iter()
            .position(|k| k.split('=').next() == Some(name))
            .unwrap_or(usize::MAX)
    }

    /// Records one frame (replacing an earlier record of it). A frame of other knobs or
    /// repeat, or of other shared settings than the frames recorded before, is refused.
    pub fn add(&mut self, record: TradeRecord) -> Result<()> {
        let mine = TradeSetup {
            scene: self.setup().scene.clone(),
            knobs: record.knobs.clone(),
            repeat: record.repeat,
        };
        let differ = self
            .setup()
            .differences(&mine, "the folder has", "the frame has");
        if !differ.is_empty() {
            bail!(
                "frame {} comes from another trade than the folder's: {}",
                record.frame,
                differ.join("; ")
            );
        }
        if let Some(other) = self.records.other_settings(record.frame, &record.settings) {
            bail!(
                "frame {} was traded with other shared settings than frame {} of the folder: \
                 {} against {}",
                record.frame,
                other.frame,
                settings_text(&record.settings, ", "),
                settings_text(&other.settings, ", ")
            );
        }
        self.records.add(record)
    }

    /// Every recorded row, knob after knob, each knob's in frame order (as the sweeps ran).
    pub fn rows(&self) -> Vec<&TradeRow> {
        let mut rows: Vec<&TradeRow> = self.records.records().flat_map(|f| &f.rows).collect();
        rows.sort_by_key(|r| self.knob_index(&r.knob));
        rows
    }

    /// One report per knob, in the setup's order.
    pub fn reports(&self) -> Result<Vec<KnobReport<'static>>> {
        let rows: Vec<TradeRow> = self.rows().into_iter().cloned().collect();
        Ok(knob_choices(&self.setup().knobs)?
            .into_iter()
            .map(|(k, _)| KnobReport::of(k, &rows))
            .collect())
    }

    /// Writes trade.csv, plots/ and trade.md from every recorded frame; returns trade.md's path.
    pub fn write(&self) -> Result<PathBuf> {
        let rows: Vec<TradeRow> = self.rows().into_iter().cloned().collect();
        let reports = self.reports()?;
        let settings = self
            .records
            .records()
            .next()
            .map(|r| settings_text(&r.settings, ", "))
            .unwrap_or_default();
        let info = RunInfo {
            scene: &self.setup().scene,
            frames: frames_text(&self.frames()),
            size: rows
                .iter()
                .map(|r| (r.width, r.height))
                .max()
                .map_or(String::new(), |(w, h)| format!("{w}x{h}")),
            repeat: self.setup().repeat,
            common: if settings == "none" {
                String::new()
            } else {
                settings
            },
        };
        write::write(self.out(), &info, &reports, &rows)?;
        Ok(self.out().join("trade.md"))
    }
}

/// `A-B` for consecutive frames, else the frames one by one.
fn frames_text(frames: &[i32]) -> String {
    match (frames.first(), frames.last()) {
        (Some(a), Some(b)) if (b - a) as usize + 1 == frames.len() => format!("{a}-{b}"),
        _ => frames
            .iter()
            .map(|f| f.to_string())
            .collect::<Vec<_>>()
            .join(","),
    }
}
