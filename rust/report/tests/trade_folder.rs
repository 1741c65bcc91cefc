//! The trade folder's records: the setup pretty-printed in `frames/trade.json`, each frame on
//! one line in `frames/frame_NNNN.json`, resumed on reopening, forgotten on creating afresh,
//! and another trade or other shared settings refused naming what differs.

use std::path::Path;

use antumbra_core::settings::NamedSettings;
use antumbra_report::trade::{TradeFolder, TradeRecord, TradeSetup};
use tempfile::TempDir;

fn setup(repeat: usize) -> TradeSetup {
    TradeSetup::new("bedroom", &["spp=1,4"], repeat).unwrap()
}

fn record(frame: i32, settings: NamedSettings) -> TradeRecord {
    TradeRecord {
        frame,
        knobs: setup(2).knobs,
        repeat: 2,
        settings,
        rows: Vec::new(),
        mismatches: Vec::new(),
    }
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn frames_recorded_resumed_and_forgotten() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("trade");
    let mut folder = TradeFolder::create(&out, setup(2)).unwrap();
    let shared = NamedSettings::new().with("min_leaf_size", 2_i64);
    for frame in [2, 1] {
        folder.add(record(frame, shared.clone())).unwrap();
    }
    let frames = out.join("frames");
    assert_eq!(
        read(&frames.join("trade.json")),
        serde_json::to_string_pretty(&setup(2)).unwrap()
    );
    assert_eq!(
        read(&frames.join("frame_0001.json")),
        serde_json::to_string(&record(1, shared.clone())).unwrap()
    );

    let folder = TradeFolder::open(&out, setup(2)).unwrap();
    assert_eq!(folder.frames(), vec![1, 2]);

    let folder = TradeFolder::create(&out, setup(2)).unwrap();
    assert!(folder.frames().is_empty());
    assert!(!frames.join("frame_0001.json").exists());
    assert!(frames.join("trade.json").exists());
}

#[test]
fn another_trade_or_other_shared_settings_are_refused() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("trade");
    let mut folder = TradeFolder::open(&out, setup(2)).unwrap();
    folder.add(record(1, NamedSettings::new())).unwrap();

    let err = folder
        .add(record(2, NamedSettings::new().with("min_leaf_size", 2_i64)))
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "frame 2 was traded with other shared settings than frame 1 of the folder: \
         min_leaf_size=2 against none"
    );

    let err = TradeFolder::open(&out, setup(3)).err().unwrap();
    assert_eq!(
        err.to_string(),
        format!(
            "the trade folder {} was recorded for another trade: repeat: recorded 2, now 3 \
             (use another folder, or remove {})",
            out.display(),
            out.join("frames").display()
        )
    );
}
