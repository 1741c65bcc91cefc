//! `antumbra bench` on a recording and on an OBJ file, as a user runs it: every frame asked for
//! is measured, the work counters are those `render` reports for the same rays, `--methods`
//! measures a file's frames, and what cannot work fails naming the file and the problem.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;
use tempfile::TempDir;

fn antumbra() -> Command {
    Command::new(env!("CARGO_BIN_EXE_antumbra"))
}

fn ok(out: Output) -> Output {
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

const SIZE: [&str; 2] = ["--size", "40x30"];
/// The settings both commands get (bench's own default is one sample per pixel).
const SETTINGS: [&str; 2] = ["--spp", "1"];
const WORK: [&str; 4] = ["nb_per_ray", "nl_per_ray", "nt_per_ray", "nbox_per_ray"];

/// Three frames of the bedroom (two soft lights), recorded.
fn recording(dir: &Path) -> PathBuf {
    let rec = dir.join("bedroom.antrec");
    ok(antumbra()
        .args(["record", "--scene", "bedroom", "--frames", "1-3"])
        .args(["--triangles", "3000"])
        .args(SIZE)
        .arg("--out")
        .arg(&rec)
        .output()
        .unwrap());
    rec
}

/// A ground quad and a box above it (the importer adds a framing camera and a sun).
fn obj_file(dir: &Path) -> PathBuf {
    let path = dir.join("box.obj");
    let mut text = String::from("v -4 -4 0\nv 4 -4 0\nv 4 4 0\nv -4 4 0\nf 1 2 3\nf 1 3 4\n");
    for z in [0.5, 2.5] {
        for (x, y) in [(-1, -1), (1, -1), (1, 1), (-1, 1)] {
            text += &format!("v {x} {y} {z}\n");
        }
    }
    for f in [
        [5, 7, 6],
        [5, 8, 7],
        [9, 10, 11],
        [9, 11, 12],
        [5, 6, 10],
        [5, 10, 9],
        [6, 7, 11],
        [6, 11, 10],
        [7, 8, 12],
        [7, 12, 11],
        [8, 5, 9],
        [8, 9, 12],
    ] {
        text += &format!("f {} {} {}\n", f[0], f[1], f[2]);
    }
    std::fs::write(&path, text).unwrap();
    path
}

fn json_of(out: Output) -> Vec<Value> {
    serde_json::from_slice::<Value>(&out.stdout)
        .unwrap()
        .as_array()
        .unwrap()
        .clone()
}

fn bench_json(scene: &Path, extra: &[&str]) -> Vec<Value> {
    json_of(ok(antumbra()
        .arg("bench")
        .arg("--scene")
        .arg(scene)
        .args(SIZE)
        .args(SETTINGS)
        .args(["--repeat", "1", "--json"])
        .args(extra)
        .output()
        .unwrap()))
}

/// `render`'s statistics rows of `scene` with `extra` settings, and bench's own method defaults
/// where `extra` names none (SAH, front to back: bench times one fixed method).
fn render_stats(scene: &Path, out: &Path, extra: &[&str]) -> Vec<Value> {
    let order = (!extra.contains(&"--order")).then_some(["--order", "fbto"]);
    ok(antumbra()
        .arg("render")
        .arg("--scene")
        .arg(scene)
        .args(SIZE)
        .args(SETTINGS)
        .args(["--build", "sah"])
        .args(order.into_iter().flatten())
        .args(extra)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap());
    let text = std::fs::read_to_string(out.join("stats.json")).unwrap();
    serde_json::from_str::<Value>(&text)
        .unwrap()
        .as_array()
        .unwrap()
        .clone()
}

fn frames_of(rows: &[Value]) -> Vec<i64> {
    let mut f: Vec<i64> = rows.iter().map(|r| r["frame"].as_i64().unwrap()).collect();
    f.dedup();
    f
}

/// A pass kind's rays and exact work totals (N_B, N_L, N_T, N_box) over `render`'s rows of
/// that kind in `frame` (a row holds per ray x rays).
fn render_totals(stats: &[Value], frame: i64, pass: &str) -> (u64, Vec<u64>) {
    let rows: Vec<&Value> = stats
        .iter()
        .filter(|r| r["frame"] == frame && r["pass"] == pass)
        .collect();
    assert!(!rows.is_empty(), "no {pass} row of frame {frame}");
    let rays: u64 = rows.iter().map(|r| r["rays"].as_u64().unwrap()).sum();
    let totals = WORK
        .iter()
        .map(|k| {
            rows.iter()
                .map(|r| (r[k].as_f64().unwrap() * r["rays"].as_f64().unwrap()).round() as u64)
                .sum()
        })
        .collect();
    (rays, totals)
}

/// Work per ray as the statistics rows divide it, through JSON as bench's output went (serde_json
/// reads some reals one bit off; the same text reads the same).
fn per_ray(total: u64, rays: u64) -> f64 {
    let x = total as f64 / rays.max(1) as f64;
    serde_json::from_str(&serde_json::to_string(&x).unwrap()).unwrap()
}

const TOTALS: [&str; 4] = ["inner", "leaves", "triangles", "boxes"];

/// Every bench row's counters equal `render`'s for the same frame, rays and method.
fn assert_counters_equal_render(bench: &[Value], stats: &[Value]) {
    for row in bench {
        let frame = row["frame"].as_i64().unwrap();
        for (pass, work, rays) in [
            ("primary", "primary_work", "primary_rays"),
            ("shadow", "shadow_work", "shadow_rays"),
        ] {
            let (n, totals) = render_totals(stats, frame, pass);
            assert_eq!(row[rays].as_u64().unwrap(), n, "frame {frame} {pass} rays");
            let counted: Vec<u64> = TOTALS
                .iter()
                .map(|k| row[work]["totals"][k].as_u64().unwrap())
                .collect();
            assert_eq!(counted, totals, "frame {frame} {pass} {TOTALS:?}");
            let expected: Vec<f64> = totals.iter().map(|t| per_ray(*t, n)).collect();
            let got: Vec<f64> = WORK
                .iter()
                .map(|k| row[work][k].as_f64().unwrap())
                .collect();
            assert_eq!(got, expected, "frame {frame} {pass} {WORK:?}");
            assert!(got[0] > 0.0, "frame {frame} {pass}: no work counted");
        }
        let method = stats.iter().find(|r| r["frame"] == frame).unwrap();
        assert_eq!(row["method"], method["method"]);
    }
}

#[test]
fn bench_measures_every_frame_of_a_recording_with_render_s_counters() {
    let tmp = TempDir::new().unwrap();
    let rec = recording(tmp.path());
    let bench = bench_json(&rec, &[]);
    // Every recorded frame, on one thread and on all.
    assert_eq!(frames_of(&bench), [1, 2, 3]);
    assert_eq!(bench.len(), 6);
    let stats = render_stats(&rec, &tmp.path().join("render"), &[]);
    assert_counters_equal_render(&bench, &stats);
    // A wide tree with a per-light order: counted on the trees bench times, as render counts.
    let wide = ["--width", "8", "--order", "sorted"];
    let mut flags = vec!["--frames", "2"];
    flags.extend(wide);
    let bench = bench_json(&rec, &flags);
    assert_eq!(frames_of(&bench), [2]);
    let stats = render_stats(&rec, &tmp.path().join("wide"), &flags);
    assert_counters_equal_render(&bench, &stats);
    // The table prints the counters next to the times.
    let table = ok(antumbra()
        .arg("bench")
        .arg("--scene")
        .arg(&rec)
        .args(SIZE)
        .args(["--repeat", "1", "--frames", "3"])
        .output()
        .unwrap());
    let table = String::from_utf8_lossy(&table.stdout);
    let header = table.lines().next().unwrap();
    for column in ["frame", "prim N_B", "prim N_box", "shad N_T", "shad N_box"] {
        assert!(header.contains(column), "{column}: {table}");
    }
    let rows: Vec<&str> = table
        .lines()
        .filter(|l| l.starts_with("bedroom "))
        .collect();
    assert_eq!(rows.len(), 2, "{table}");
    assert!(rows
        .iter()
        .all(|r| r.split_whitespace().nth(1) == Some("3")));
}

#[test]
fn bench_measures_an_obj_file_s_first_frame_or_the_frames_asked_for() {
    let tmp = TempDir::new().unwrap();
    let obj = obj_file(tmp.path());
    let bench = bench_json(&obj, &[]);
    assert_eq!(frames_of(&bench), [1]);
    assert_eq!(bench[0]["scene"], "box");
    assert_eq!(bench[0]["triangles"], 14);
    let stats = render_stats(&obj, &tmp.path().join("render"), &["--frames", "1"]);
    assert_counters_equal_render(&bench, &stats);
    assert_eq!(frames_of(&bench_json(&obj, &["--frames", "2-3"])), [2, 3]);
}

/// `bench --methods sah,osah` on a scene's frames: one row per frame and method, named
/// "frame N", SAH's work equal to `render`'s binary SAH front to back.
fn methods_on_frames(scene: &Path, frames: &[i64], dir: &Path) {
    let run = |json: bool| {
        ok(antumbra()
            .args(["bench", "--methods", "sah,osah", "--scene"])
            .arg(scene)
            .args(SIZE)
            .args(SETTINGS)
            .args(["--repeat", "1"])
            .args(json.then_some("--json"))
            .output()
            .unwrap())
    };
    let rows = json_of(run(true));
    let cameras: Vec<String> = frames.iter().map(|f| format!("frame {f}")).collect();
    for method in ["sah", "osah"] {
        let mine: Vec<&Value> = rows.iter().filter(|r| r["method"] == method).collect();
        let named: Vec<&str> = mine.iter().map(|r| r["camera"].as_str().unwrap()).collect();
        assert_eq!(named, cameras, "{method}");
        assert!(mine
            .iter()
            .all(|r| r["primary_nit"].as_f64().unwrap() > 0.0));
    }
    let range = format!("{}-{}", frames[0], frames[frames.len() - 1]);
    // The build methods' table measures binary trees.
    let binary = ["--frames", &range, "--width", "2"];
    let stats = render_stats(scene, &dir.join("sah"), &binary);
    for row in rows.iter().filter(|r| r["method"] == "sah") {
        let frame: i64 = row["camera"].as_str().unwrap()[6..].parse().unwrap();
        let primary = stats
            .iter()
            .find(|r| r["frame"] == frame && r["pass"] == "primary")
            .unwrap();
        assert_eq!(row["primary_nit"], primary["nt_per_ray"], "frame {frame}");
        assert_eq!(row["primary_nts"], primary["nts_per_ray"], "frame {frame}");
        let (rays, shadow) = render_totals(&stats, frame, "shadow");
        let nit = per_ray(shadow[2], rays);
        let nts = per_ray(shadow[0] + shadow[1], rays);
        assert_eq!(row["shadow_nit"].as_f64().unwrap(), nit, "frame {frame}");
        assert_eq!(row["shadow_nts"].as_f64().unwrap(), nts, "frame {frame}");
    }
    let tables = run(false);
    let tables = String::from_utf8_lossy(&tables.stdout);
    let name = scene.file_stem().unwrap().to_str().unwrap();
    for c in &cameras {
        assert!(tables.contains(&format!("| {name} / {c} |")), "{tables}");
    }
}

#[test]
fn bench_methods_measure_a_recording_s_and_an_obj_file_s_frames() {
    let tmp = TempDir::new().unwrap();
    methods_on_frames(&recording(tmp.path()), &[1, 2, 3], tmp.path());
    methods_on_frames(&obj_file(tmp.path()), &[1], &tmp.path().join("obj"));
}

#[test]
fn what_cannot_be_measured_fails_naming_the_file_and_the_problem() {
    let tmp = TempDir::new().unwrap();
    let dir = tmp.path();
    let no_frames = dir.join("empty.antrec");
    std::fs::write(&no_frames, b"ANTREC1\n").unwrap();
    let rec = recording(dir);
    let rec = rec.to_str().unwrap();
    let missing = dir.join("missing.obj");
    let cases: [(Vec<&str>, &str); 3] = [
        (
            vec![missing.to_str().unwrap()],
            "missing.obj: No such file or directory",
        ),
        (
            vec![no_frames.to_str().unwrap()],
            "empty.antrec: the recording holds no FrameUpdate",
        ),
        (
            vec![rec, "--frames", "2-5"],
            "bedroom.antrec: --frames 2-5 asks for frames it does not hold (it recorded frames 1-3)",
        ),
    ];
    for (args, expected) in cases {
        for methods in [&[][..], &["--methods", "sah"]] {
            let run = antumbra()
                .args(["bench", "--size", "8x8", "--repeat", "1", "--scene"])
                .args(&args)
                .args(methods)
                .output()
                .unwrap();
            assert!(!run.status.success(), "{args:?} {methods:?}");
            let err = String::from_utf8_lossy(&run.stderr);
            assert!(err.contains(expected), "{args:?} {methods:?}: {err}");
            // Said once, not once per error in the chain.
            assert_eq!(err.matches(expected).count(), 1, "{err}");
        }
    }
}
