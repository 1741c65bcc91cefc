//! [`FrameRecords`]: a run recorded frame by frame in `frames/` (its setup's file, then one
//! `frame_NNNN.json` per frame, each written atomically), resumed, and refused when it was
//! recorded for another setup. The record keeping of compare's and trade's folders alike.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use antumbra_core::atomic_file::write_bytes_atomic;
use antumbra_core::output::frame_stem;
use antumbra_core::settings::NamedSettings;
use anyhow::{bail, Context, Result};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// Where the records live, inside the folder.
const FRAMES_DIR: &str = "frames";

/// How one kind of folder spells its files and names itself when it refuses another setup.
pub(crate) struct Layout {
    /// The setup's file in `frames/`.
    pub setup_file: &'static str,
    /// The folder and what it records, as in "the report folder X was recorded for another
    /// comparison".
    pub folder: &'static str,
    pub run: &'static str,
    /// Frame records pretty-printed or on one line: each folder keeps the bytes it always wrote.
    pub pretty_frames: bool,
}

/// What a run is recorded for; a folder is resumed only with the same setup.
pub(crate) trait Setup: Serialize + DeserializeOwned {
    /// What differs from `other`, in words (`recorded` names this one, `given` the other).
    fn differences(&self, other: &Self, recorded: &str, given: &str) -> Vec<String>;
}

/// One recorded frame, as `frames/frame_NNNN.json` holds it.
pub(crate) trait Frame: Serialize + DeserializeOwned {
    fn frame(&self) -> i32;
    /// The settings the frame's run shared; every frame of a folder shares the same.
    fn settings(&self) -> &NamedSettings;
}

/// A folder's setup and the frames recorded so far, in frame order.
pub(crate) struct FrameRecords<S, F> {
    out: PathBuf,
    layout: &'static Layout,
    setup: S,
    frames: BTreeMap<i32, F>,
}

impl<S: Setup, F: Frame> FrameRecords<S, F> {
    /// Opens `out` (made if missing) for `setup`, resuming the frames recorded there before. A
    /// folder recorded for another setup is an error naming what differs.
    pub fn open(out: &Path, layout: &'static Layout, setup: S) -> Result<Self> {
        let mut records = FrameRecords {
            out: out.to_path_buf(),
            layout,
            setup,
            frames: BTreeMap::new(),
        };
        records.refuse_another_setup()?;
        records.start()?;
        for (frame, path) in records.record_files()? {
            let record: F = read_json(&path)?;
            if record.frame() != frame {
                bail!("{} holds frame {}", path.display(), record.frame());
            }
            records.frames.insert(frame, record);
        }
        Ok(records)
    }

    /// Opens `out` afresh for `setup`: frames recorded there before are forgotten (their
    /// records removed), whatever setup recorded them.
    pub fn create(out: &Path, layout: &'static Layout, setup: S) -> Result<Self> {
        let mut records = FrameRecords {
            out: out.to_path_buf(),
            layout,
            setup,
            frames: BTreeMap::new(),
        };
        // Removed before the new setup is written, so no other setup's frame is left under it.
        for (_, path) in records.record_files()? {
            std::fs::remove_file(&path).with_context(|| format!("removing {}", path.display()))?;
        }
        records.start()?;
        Ok(records)
    }

    fn dir(&self) -> PathBuf {
        self.out.join(FRAMES_DIR)
    }

    fn refuse_another_setup(&self) -> Result<()> {
        let path = self.dir().join(self.layout.setup_file);
        if !path.exists() {
            return Ok(());
        }
        let recorded: S = read_json(&path)?;
        let differ = recorded.differences(&self.setup, "recorded", "now");
        if !differ.is_empty() {
            bail!(
                "the {} {} was recorded for another {}: {} (use another folder, or remove {})",
                self.layout.folder,
                self.out.display(),
                self.layout.run,
                differ.join("; "),
                self.dir().display()
            );
        }
        Ok(())
    }

    /// The folders and the setup's file.
    fn start(&mut self) -> Result<()> {
        let dir = self.dir();
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let text = serde_json::to_string_pretty(&self.setup)?;
        write_bytes_atomic(&dir.join(self.layout.setup_file), text.as_bytes())?;
        Ok(())
    }

    /// `(frame, path)` of every record file in the folder, in frame order.
    fn record_files(&self) -> Result<Vec<(i32, PathBuf)>> {
        let dir = self.dir();
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

    pub fn setup(&self) -> &S {
        &self.setup
    }

    /// The frames recorded so far, in order.
    pub fn frames(&self) -> Vec<i32> {
        self.frames.keys().copied().collect()
    }

    /// The records, in frame order.
    pub fn records(&self) -> impl Iterator<Item = &F> + Clone {
        self.frames.values()
    }

    /// A recorded frame other than `frame` whose shared settings are not `settings`, if any:
    /// a frame run with those settings does not belong with the others.
    pub fn other_settings(&self, frame: i32, settings: &NamedSettings) -> Option<&F> {
        self.frames
            .values()
            .find(|r| r.frame() != frame && r.settings() != settings)
    }

    /// Writes `record` atomically (replacing an earlier record of its frame) and keeps it.
    pub fn add(&mut self, record: F) -> Result<()> {
        let path = self
            .dir()
            .join(format!("{}.json", frame_stem(record.frame())));
        let text = if self.layout.pretty_frames {
            serde_json::to_string_pretty(&record)?
        } else {
            serde_json::to_string(&record)?
        };
        write_bytes_atomic(&path, text.as_bytes())?;
        self.frames.insert(record.frame(), record);
        Ok(())
    }
}

/// `s` as `NAME=VALUE` pairs joined by `separator` (compare and trade each keep their own), or
/// `none`.
pub(crate) fn settings_text(s: &NamedSettings, separator: &str) -> String {
    if s.0.is_empty() {
        return "none".into();
    }
    s.0.iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(separator)
}

fn read_json<T: DeserializeOwned>(path: &Path) -> Result<T> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("reading {}", path.display()))
}
