//! `antumbra compare` as a user runs it: each method's rows equal that method rendered alone
//! (counters exact), the answer check fires on a real difference, and the report folder holds
//! every file it promises.

mod common;

use antumbra_core::compare::DEFAULT_METHODS;
use common::{antumbra, ok, read_csv, Rows};
use tempfile::TempDir;

/// A small animated scene with soft lights: three frames of the bedroom.
const SCENE: [&str; 10] = [
    "--scene",
    "bedroom",
    "--triangles",
    "3000",
    "--frames",
    "1-3",
    "--size",
    "40x30",
    "--spp",
    "2",
];

/// Columns that are measured times (or derived from them), not counts.
const TIMING: [&str; 6] = [
    "build_ms",
    "trace_ms",
    "mrays_per_s",
    "timed_without_counters",
    "prepare_ms",
    "visibility_ms",
];

#[test]
fn each_methods_rows_equal_that_method_rendered_alone() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("cmp");
    ok(antumbra()
        .arg("compare")
        .args(SCENE)
        .args(["--repeat", "1", "--out"])
        .arg(&out)
        .output()
        .unwrap());
    for file in [
        "compare.csv",
        "compare.json",
        "summary.md",
        "report.html",
        "plots/shadow_nb.svg",
        "plots/frame_ms.svg",
        "plots/time_parts.svg",
        "plots/pareto.svg",
        "diff/osah8/frame_0002.png",
    ] {
        assert!(out.join(file).is_file(), "{file} missing");
    }
    let compared = read_csv(&out.join("compare.csv"));
    let labels: Vec<&str> = DEFAULT_METHODS
        .iter()
        .map(|m| m.split_once('=').unwrap().0)
        .collect();
    for (spec, label) in DEFAULT_METHODS.iter().zip(&labels) {
        // The method alone: its settings as `render` flags.
        let mut flags = Vec::new();
        for kv in spec.split_once('=').unwrap().1.split(',') {
            let (k, v) = kv.split_once('=').unwrap();
            flags.push(format!("--{}={v}", k.replace('_', "-")));
        }
        let alone = tmp.path().join(label);
        ok(antumbra()
            .arg("render")
            .args(SCENE)
            .args(&flags)
            .arg("--out")
            .arg(&alone)
            .output()
            .unwrap());
        let alone = read_csv(&alone.join("stats.csv"));
        let mine: Rows = compared
            .iter()
            .filter(|r| r["label"] == *label)
            .cloned()
            .collect();
        assert_eq!(mine.len(), alone.len(), "{label}: row count");
        assert!(!mine.is_empty());
        for (c, a) in mine.iter().zip(&alone) {
            for (column, value) in a {
                if TIMING.contains(&column.as_str()) {
                    continue;
                }
                // The same value: stats.csv writes a zero real as 0.0, compare.csv as 0.
                let same = match (c[column].parse::<f64>(), value.parse::<f64>()) {
                    (Ok(x), Ok(y)) => x.to_bits() == y.to_bits(),
                    _ => &c[column] == value,
                };
                assert!(
                    same,
                    "{label}: frame {} {} {}: column {column}: {} != {value}",
                    a["frame"], a["pass"], a["light"], c[column]
                );
            }
            assert_eq!(c["timed_without_counters"], "true");
        }
    }
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("bit for bit on every frame"), "{summary}");
    for label in &labels {
        assert!(
            summary.contains(&format!("| {label} |")),
            "{label} in summary"
        );
    }
}

#[test]
fn a_real_difference_fails_naming_frame_light_method_and_pixels() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("cmp");
    // Another seed draws other soft-shadow samples: the masks really differ.
    let run = antumbra()
        .arg("compare")
        .args(SCENE)
        .args(["--method", "a=seed=0", "--method", "b=seed=7"])
        .args(["--repeat", "1", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("differ from the baseline 'a'"), "{err}");
    let line = err
        .lines()
        .find(|l| l.contains("method 'b'"))
        .unwrap_or_else(|| panic!("no line names method b: {err}"));
    assert!(line.contains("frame 1:"), "{line}");
    assert!(line.contains("light '"), "{line}");
    assert!(line.contains(" pixels"), "{line}");
    let pixels: usize = line
        .rsplit(": ")
        .next()
        .unwrap()
        .trim_end_matches(" pixels")
        .parse()
        .unwrap();
    assert!(pixels > 0 && pixels <= 40 * 30, "{line}");
    // The report is still written, and says so.
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("answers differ"), "{summary}");
}

#[test]
fn bad_methods_are_refused_before_any_work() {
    let tmp = TempDir::new().unwrap();
    for (args, expected) in [
        (vec!["--method", "x=widht=8"], "'widht' is not a setting"),
        (
            vec!["--method", "x=width=8", "--method", "x=width=4"],
            "used twice",
        ),
        (
            vec!["--method", "x=width=8", "--baseline", "y"],
            "'y' is not the label",
        ),
    ] {
        let run = antumbra()
            .arg("compare")
            .args(SCENE)
            .args(&args)
            .arg("--out")
            .arg(tmp.path())
            .output()
            .unwrap();
        assert!(!run.status.success());
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(err.contains(expected), "{args:?}: {err}");
    }
}

#[test]
fn the_report_opens_with_the_fastest_method_as_measured() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("cmp");
    ok(antumbra()
        .arg("compare")
        .args(SCENE)
        .args(["--repeat", "3", "--out"])
        .arg(&out)
        .output()
        .unwrap());
    // The fastest method recomputed from compare.csv: the least mean over frames of the
    // frame's median time (every row of a frame carries it).
    let mut frames: std::collections::BTreeMap<(String, String), f64> = Default::default();
    for r in read_csv(&out.join("compare.csv")) {
        frames.insert(
            (r["label"].clone(), r["frame"].clone()),
            r["frame_ms"].parse().unwrap(),
        );
    }
    let mut totals: std::collections::BTreeMap<String, f64> = Default::default();
    for ((label, _), ms) in &frames {
        *totals.entry(label.clone()).or_default() += ms;
    }
    let fastest = totals
        .iter()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map(|(l, _)| l.clone())
        .unwrap();
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    let first_paragraph = summary.split("\n\n").nth(1).unwrap();
    assert!(
        first_paragraph.starts_with(&format!(
            "**What to use.** Use {fastest} for this animation: the fastest on these 3 frames"
        )),
        "{summary}"
    );
    assert!(
        first_paragraph.contains("its timed passes spread by"),
        "{first_paragraph}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("compare.json")).unwrap()).unwrap();
    assert_eq!(json["recommendation"]["label"], fastest.as_str());
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let answer = html
        .find("<section id=\"answer\">")
        .expect("the answer section");
    assert!(
        answer < html.find("id=\"verdict\"").unwrap(),
        "the answer opens the page"
    );
    assert!(html.contains("<details class=\"table\"><summary><h2>Shadow rays</h2>"));
}
