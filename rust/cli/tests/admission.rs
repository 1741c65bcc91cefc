//! `antumbra render`, `compare` and `trade` admit a run as the daemon admits a request (issue
//! 33): a memory budget over every method, knob value and prepass together, repeat counts and
//! frame ranges bounded, and a bound on the method passes of a run; each refusal is an error
//! naming the limit, within a second, before anything is rendered or allocated.

mod common;

use std::process::{Child, Output, Stdio};
use std::time::{Duration, Instant};

use antumbra_core::compare::DEFAULT_METHODS;
use common::antumbra;
use tempfile::TempDir;

/// A small city, one frame.
const SCENE: [&str; 6] = ["--scene", "city", "--triangles", "2000", "--frames", "1"];

/// Waits for `child` at most `limit`; kills it (and fails) if it is still running.
fn within(mut child: Child, limit: Duration, what: &str) -> Output {
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > limit {
            child.kill().unwrap();
            let out = child.wait_with_output().unwrap();
            panic!(
                "{what}: still running after {limit:?} ({})",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// Runs `antumbra COMMAND SCENE ARGS --out TMP`, which must fail cleanly within 10 s (a
/// debug build opening the scene); its stderr.
fn refused(command: &str, scene: &[&str], args: &[&str]) -> String {
    let tmp = TempDir::new().unwrap();
    let child = antumbra()
        .arg(command)
        .args(scene)
        .args(args)
        .arg("--out")
        .arg(tmp.path().join("out"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let what = format!("{command} {args:?}");
    let run = within(child, Duration::from_secs(10), &what);
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    // Exit code 1 is the CLI's error path; an abort is a signal, a panic exit code 101.
    assert_eq!(
        run.status.code(),
        Some(1),
        "{what}: {:?}: {stderr}",
        run.status
    );
    assert!(
        stderr.starts_with("antumbra: error: ") && !stderr.contains("panicked"),
        "{what}: {stderr}"
    );
    assert!(
        !tmp.path().join("out/frames").exists(),
        "{what}: a frame was recorded"
    );
    stderr
}

#[test]
fn compare_and_trade_check_the_render_memory_budget() {
    let e = refused(
        "compare",
        &SCENE,
        &["--size", "2048x2048", "--render-memory-mb", "64"],
    );
    assert!(
        e.contains(&format!("comparing {} methods", DEFAULT_METHODS.len()))
            && e.contains("render memory budget of 64.0 MiB"),
        "{e}"
    );
    assert!(e.contains("--render-memory-mb"), "{e}");
    let e = refused(
        "trade",
        &SCENE,
        &[
            "--knob",
            "spp",
            "--size",
            "2048x2048",
            "--render-memory-mb",
            "64",
        ],
    );
    assert!(
        e.contains("knob values") && e.contains("render memory budget of 64.0 MiB"),
        "{e}"
    );
    // The default budget (8 GiB) as the daemon's: 8192x8192 was 7 GB and an abort.
    let e = refused("compare", &SCENE, &["--size", "8192x8192"]);
    assert!(e.contains("render memory budget of 8.0 GiB"), "{e}");
}

#[test]
fn a_prepass_counts_in_the_render_estimate() {
    // Peaked at 828 MB with an estimate of 41 MiB.
    let e = refused(
        "render",
        &SCENE,
        &[
            "--size",
            "64x48",
            "--build",
            "osah",
            "--visibility",
            "prepass:4096x4096",
            "--render-memory-mb",
            "64",
        ],
    );
    assert!(e.contains("render memory budget of 64.0 MiB"), "{e}");
}

#[test]
fn repeat_counts_and_frame_ranges_are_bounded() {
    for command in ["compare", "trade"] {
        let e = refused(
            command,
            &SCENE,
            &["--size", "32x24", "--repeat", "99999999999"],
        );
        assert!(
            e.contains("repeat: 99999999999") && e.contains("max_compare_repeat"),
            "{command}: {e}"
        );
    }
    // 650 GB asked for at once (every frame's scene), and an abort.
    let frames = [
        "--scene",
        "city",
        "--triangles",
        "2000",
        "--frames",
        "1-2147483647",
    ];
    for (command, args) in [
        ("render", &["--size", "32x24"][..]),
        ("compare", &["--size", "32x24", "--repeat", "1"][..]),
        ("trade", &["--size", "32x24", "--repeat", "1"][..]),
    ] {
        let e = refused(command, &frames, args);
        assert!(
            e.contains("2147483647 frames") && e.contains("max_request_passes"),
            "{command}: {e}"
        );
    }
}
