//! Helpers the CLI's report tests share: the binary, a run that must succeed, and a CSV read
//! into rows keyed by column.

#![allow(dead_code)] // each test binary uses its own subset

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Output};

pub fn antumbra() -> Command {
    Command::new(env!("CARGO_BIN_EXE_antumbra"))
}

/// `out`, after asserting that the command succeeded (its output in the message otherwise).
pub fn ok(out: Output) -> Output {
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

pub type Rows = Vec<BTreeMap<String, String>>;

pub fn read_csv(path: &Path) -> Rows {
    let mut r = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    r.records()
        .map(|rec| {
            header
                .iter()
                .cloned()
                .zip(rec.unwrap().iter().map(String::from))
                .collect()
        })
        .collect()
}
