//! Files as a user expects them on shared storage (issue 33): under umask 022 every file
//! `antumbra render`, `compare` and `trade` write is 0644 (it was 0600), and `record` too; the
//! daemon's socket folder and socket stay owner-only (0700, 0600) even under umask 000.

mod common;

use std::io::{BufRead, BufReader};
use std::os::unix::fs::PermissionsExt;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use common::{antumbra, ok};
use tempfile::TempDir;

const SCENE: [&str; 8] = [
    "--scene",
    "bedroom",
    "--triangles",
    "2000",
    "--frames",
    "1-1",
    "--size",
    "32x24",
];

/// `antumbra ARGS` run under `umask`.
fn antumbra_with_umask(umask: u32) -> Command {
    let mut c = antumbra();
    // SAFETY: umask is async-signal-safe; the closure touches nothing else.
    unsafe {
        c.pre_exec(move || {
            libc::umask(umask as libc::mode_t);
            Ok(())
        });
    }
    c
}

/// Every file under `dir` (recursively) with its mode bits.
fn modes(dir: &Path) -> Vec<(PathBuf, u32)> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let path = e.path();
        let mode = e.metadata().unwrap().permissions().mode() & 0o7777;
        if e.file_type().unwrap().is_dir() {
            assert_eq!(mode, 0o755, "{}: mode {mode:o}", path.display());
            out.extend(modes(&path));
        } else {
            out.push((path, mode));
        }
    }
    out
}

fn assert_all_0644(dir: &Path, at_least: usize) {
    let files = modes(dir);
    assert!(files.len() >= at_least, "{files:?}");
    let wrong: Vec<String> = files
        .iter()
        .filter(|(_, m)| *m != 0o644)
        .map(|(p, m)| format!("{} {m:o}", p.display()))
        .collect();
    assert!(wrong.is_empty(), "not 0644 under umask 022: {wrong:#?}");
}

#[test]
fn render_record_compare_and_trade_files_are_readable_by_others_under_umask_022() {
    let tmp = TempDir::new().unwrap();
    let render = tmp.path().join("render");
    ok(antumbra_with_umask(0o022)
        .arg("render")
        .args(SCENE)
        .arg("--out")
        .arg(&render)
        .output()
        .unwrap());
    // The EXR, the PNGs and the statistics.
    assert_all_0644(&render, 4);
    let record = tmp.path().join("record");
    ok(antumbra_with_umask(0o022)
        .arg("record")
        .args(SCENE)
        .arg("--out")
        .arg(record.join("scene.antrec"))
        .output()
        .unwrap());
    assert_all_0644(&record, 1);
    let compare = tmp.path().join("compare");
    ok(antumbra_with_umask(0o022)
        .arg("compare")
        .args(SCENE)
        .args(["--method", "a=width=2", "--method", "b=width=8"])
        .args(["--repeat", "1", "--out"])
        .arg(&compare)
        .output()
        .unwrap());
    // Tables, report.html, plots and difference images.
    assert!(compare.join("report.html").is_file());
    assert_all_0644(&compare, 5);
    let trade = tmp.path().join("trade");
    ok(antumbra_with_umask(0o022)
        .arg("trade")
        .args(SCENE)
        .args(["--knob", "spp=1,4", "--repeat", "1", "--out"])
        .arg(&trade)
        .output()
        .unwrap());
    assert!(trade.join("trade.csv").is_file());
    assert_all_0644(&trade, 3);
}

/// The socket's folder and the socket are the access control of the Unix socket: owner-only
/// whatever the umask.
#[test]
fn serve_socket_folder_and_socket_stay_owner_only_under_umask_000() {
    let tmp = TempDir::new().unwrap();
    let socket = tmp.path().join("run").join("d.sock");
    let mut child = antumbra_with_umask(0)
        .arg("serve")
        .arg("--socket")
        .arg(&socket)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut ready = String::new();
    let read = BufReader::new(child.stdout.take().unwrap()).read_line(&mut ready);
    let folder = std::fs::metadata(socket.parent().unwrap()).map(|m| m.permissions().mode());
    let sock = std::fs::symlink_metadata(&socket).map(|m| m.permissions().mode());
    let _ = child.kill();
    let _ = child.wait();
    assert!(read.is_ok_and(|n| n > 0), "no ready line");
    assert_eq!(folder.unwrap() & 0o777, 0o700);
    assert_eq!(sock.unwrap() & 0o777, 0o600);
}
