//! `antumbra trade` as a user runs it: every value of every knob on every frame in trade.csv, a
//! work knob's answers checked, spp's error falling toward the reference and zero at its own
//! spp, the plots written, and a bad knob named with the list of knobs.

mod common;

use std::collections::BTreeSet;

use common::{antumbra, ok, read_csv, Rows};
use tempfile::TempDir;

/// Two frames of the bedroom (a sun of 0.02 rad and an area portal: both soft), small.
const SCENE: [&str; 8] = [
    "--scene",
    "bedroom",
    "--triangles",
    "3000",
    "--frames",
    "1-2",
    "--size",
    "40x30",
];

/// Mean of `column` over the shadow rows of `knob`'s `value`.
fn mean(rows: &Rows, knob: &str, value: &str, column: &str) -> f64 {
    let v: Vec<f64> = rows
        .iter()
        .filter(|r| r["knob"] == knob && r["value"] == value && r["pass"] == "shadow")
        .map(|r| r[column].parse().unwrap())
        .collect();
    assert!(!v.is_empty(), "{knob}={value}: no shadow rows");
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn sweeps_a_work_knob_spp_and_resolution() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("trade");
    ok(antumbra()
        .arg("trade")
        .args(SCENE)
        .args([
            "--knob",
            "min_leaf_size=1,4",
            "--knob",
            "spp=1,4,16,256",
            "--knob",
            "resolution=50",
            "--repeat",
            "2",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap());
    let rows = read_csv(&out.join("trade.csv"));
    // Every value x frame, each with the primary pass and both lights' shadow passes.
    let expected: [(&str, &[&str]); 3] = [
        ("min_leaf_size", &["1", "4"]),
        ("spp", &["1", "4", "16", "256"]),
        ("resolution", &["50", "100"]),
    ];
    for (knob, values) in expected {
        for value in values {
            for frame in ["1", "2"] {
                let passes: Vec<&str> = rows
                    .iter()
                    .filter(|r| r["knob"] == knob && r["value"] == *value && r["frame"] == frame)
                    .map(|r| r["pass"].as_str())
                    .collect();
                assert_eq!(
                    passes,
                    ["primary", "shadow", "shadow"],
                    "{knob}={value}, frame {frame}"
                );
            }
        }
        let defaults: BTreeSet<&str> = rows
            .iter()
            .filter(|r| r["knob"] == knob && r["default"] == "true")
            .map(|r| r["value"].as_str())
            .collect();
        assert_eq!(defaults.len(), 1, "{knob}: {defaults:?}");
    }
    // The work knob's answers were checked against the default's and are equal; its rows have
    // no error, and their work is counted.
    for r in rows.iter().filter(|r| r["knob"] == "min_leaf_size") {
        assert_eq!(r["answers"], "equal");
        assert_eq!(r["rmse"], "");
        assert!(r["work_per_ray"].parse::<f64>().unwrap() > 0.0);
        assert!(r["frame_ms"].parse::<f64>().unwrap() > 0.0);
    }
    // spp's error falls as spp rises toward the reference (256) and is 0 at 256.
    let rmse: Vec<f64> = ["1", "4", "16", "256"]
        .iter()
        .map(|v| mean(&rows, "spp", v, "rmse"))
        .collect();
    assert!(rmse.windows(2).all(|w| w[0] > w[1]), "{rmse:?}");
    assert!(rmse[0] > 0.0);
    for column in ["rmse", "p99_abs_error", "flip_share"] {
        assert_eq!(mean(&rows, "spp", "256", column), 0.0, "{column}");
    }
    // Half the resolution renders half the pixels across and is compared after upsampling.
    for r in rows.iter().filter(|r| r["knob"] == "resolution") {
        let w = if r["value"] == "50" { "20" } else { "40" };
        assert_eq!(r["width"], w);
    }
    assert!(mean(&rows, "resolution", "50", "rmse") > 0.0);
    // The plots exist and decode as what they claim.
    for knob in ["min_leaf_size", "spp", "resolution"] {
        let png = std::fs::read(out.join(format!("plots/{knob}.png"))).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{knob}.png");
        let svg = std::fs::read_to_string(out.join(format!("plots/{knob}.svg"))).unwrap();
        assert!(
            svg.starts_with("<svg") && svg.contains("Pareto front"),
            "{knob}.svg"
        );
    }
    let md = std::fs::read_to_string(out.join("trade.md")).unwrap();
    assert!(md.contains("## Recommendations"), "{md}");
    for knob in ["min_leaf_size", "spp", "resolution"] {
        assert!(md.contains(&format!("## {knob} (")), "{knob}");
        assert!(md.contains(&format!("plots/{knob}.png")), "{knob}");
    }
}

#[test]
fn a_bad_knob_is_an_error_listing_the_knobs() {
    let tmp = TempDir::new().unwrap();
    let out = antumbra()
        .arg("trade")
        .args(SCENE)
        .args(["--knob", "osah_x", "--out"])
        .arg(tmp.path().join("t"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("'osah_x' is not a knob"), "{err}");
    for knob in ["spp", "resolution", "sort_budget", "osah_w", "collapse"] {
        assert!(err.contains(knob), "{knob} missing from: {err}");
    }
    assert!(!tmp.path().join("t").exists());
}
