//! Memory as a process sees it: a replayed recording too big to render is a clear error (not an
//! abort on a huge allocation), and `antumbra serve` gives back the memory of frames that were
//! never finished and of sessions that ended (its RSS returns near the baseline).

use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use antumbra_core::scene::Resolution;
use antumbra_protocol::client::Client;
use antumbra_protocol::{RecordingWriter, Reply, Request};
use antumbra_scenes::{builtin, SceneParams};
use tempfile::TempDir;

fn antumbra() -> Command {
    Command::new(env!("CARGO_BIN_EXE_antumbra"))
}

/// A one-frame recording of a small city at `width` x `height`.
fn recording(path: &Path, width: u32, height: u32) {
    let anim = builtin(
        "city",
        &SceneParams {
            triangles: 2000,
            frames: 1,
            ..SceneParams::default()
        },
    )
    .unwrap();
    let mut scene = anim.frame(1);
    scene.resolution = Resolution::new(width, height);
    let mut w = RecordingWriter::create(path).unwrap();
    w.append_scene(&scene).unwrap();
    w.finish().unwrap();
}

/// Runs `antumbra render --scene REC --out DIR ARGS`, expecting a clean failure; its stderr.
fn render_fails(rec: &Path, out: &Path, args: &[&str]) -> String {
    let run = antumbra()
        .args(["render", "--scene"])
        .arg(rec)
        .arg("--out")
        .arg(out)
        .args(args)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    // Exit code 1 is the CLI's error path; an abort is a signal, a panic exit code 101.
    assert_eq!(run.status.code(), Some(1), "{:?}: {stderr}", run.status);
    assert!(
        stderr.starts_with("antumbra: error: ") && !stderr.contains("panicked"),
        "{stderr}"
    );
    stderr
}

#[test]
fn a_replayed_recording_too_big_to_render_is_a_clear_error() {
    let tmp = TempDir::new().unwrap();
    let huge = tmp.path().join("huge.antrec");
    recording(&huge, 100_000, 100_000);
    let e = render_fails(&huge, &tmp.path().join("out-huge"), &[]);
    assert!(
        e.contains("100000x100000") && e.contains("max_image_pixels"),
        "{e}"
    );
    // Within the pixel limit but over the memory budget: refused before it is rendered.
    let big = tmp.path().join("big.antrec");
    recording(&big, 2048, 2048);
    let e = render_fails(
        &big,
        &tmp.path().join("out-big"),
        &["--render-memory-mb", "64"],
    );
    assert!(
        e.contains("frame 1")
            && e.contains("2048x2048 pixels")
            && e.contains("render memory budget of 64.0 MiB")
            && e.contains("--render-memory-mb"),
        "{e}"
    );
    assert!(!tmp.path().join("out-big/frame_0001.exr").exists());
}

/// `antumbra serve` on a socket in `dir`; killed on drop.
struct Served {
    child: Child,
    socket: PathBuf,
}

impl Served {
    fn start(dir: &Path) -> Served {
        let socket = dir.join("d.sock");
        let mut child = antumbra()
            .arg("serve")
            .arg("--socket")
            .arg(&socket)
            .env("RUST_LOG", "warn")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        assert!(line.contains("listening"), "ready line: {line:?}");
        Served { child, socket }
    }

    /// The daemon's resident memory in MiB (`VmRSS`).
    fn rss_mib(&self) -> u64 {
        let status = std::fs::read_to_string(format!("/proc/{}/status", self.child.id())).unwrap();
        let kib: u64 = status
            .lines()
            .find_map(|l| l.strip_prefix("VmRSS:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
            .expect("VmRSS in /proc/PID/status");
        kib >> 10
    }

    /// The daemon's RSS once it is at most `limit_mib`, or the last reading after 20 s: an ended
    /// session's memory goes back when its thread has been joined, a moment after it is counted
    /// as ended.
    fn rss_settled_mib(&self, limit_mib: u64) -> u64 {
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let rss = self.rss_mib();
            if rss <= limit_mib || Instant::now() >= deadline {
                return rss;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Waits until only the asking session is live: every other session has ended.
    fn wait_sessions_ended(&self) {
        let deadline = Instant::now() + Duration::from_secs(60);
        let mut c = Client::connect_unix(&self.socket).unwrap();
        c.hello("rss-probe", None).unwrap();
        loop {
            match c.call(&Request::Stats).unwrap() {
                Reply::DaemonStats(s) if s.sessions == 1 => return,
                Reply::DaemonStats(_) => {}
                other => panic!("expected DaemonStats, got {}", other.kind()),
            }
            assert!(Instant::now() < deadline, "sessions did not end");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn unfinished_frames_and_ended_sessions_give_their_memory_back() {
    const FRAME_MIB: usize = 50;
    const ROUNDS: usize = 3;
    const IDLE_SESSIONS: usize = 100;
    let tmp = TempDir::new().unwrap();
    let d = Served::start(tmp.path());
    d.wait_sessions_ended();
    let baseline = d.rss_mib();
    let chunk = vec![0u8; 1 << 20];
    let hello = antumbra_protocol::encode_message(&Request::Hello {
        version: antumbra_protocol::PROTOCOL_VERSION,
        client: "memory-test".into(),
        token: None,
    })
    .unwrap();
    for _ in 0..ROUNDS {
        // Three clients each say Hello (before it a frame may be only 64 KiB), announce a
        // frame a little larger than what they send, send 50 MB of it and leave: the daemon
        // buffers each body, then the stream ends inside it.
        let mut clients: Vec<UnixStream> = (0..3)
            .map(|_| {
                let mut s = UnixStream::connect(&d.socket).unwrap();
                s.write_all(&hello).unwrap();
                let len = ((FRAME_MIB + 1) << 20) as u32;
                s.write_all(&len.to_le_bytes()).unwrap();
                s
            })
            .collect();
        for _ in 0..FRAME_MIB {
            for s in &mut clients {
                s.write_all(&chunk).unwrap();
            }
        }
        drop(clients);
        d.wait_sessions_ended();
    }
    let limit = baseline + 100;
    let after_frames = d.rss_settled_mib(limit);
    // Sessions that only connect and leave, many at once.
    let idle: Vec<UnixStream> = (0..IDLE_SESSIONS)
        .map(|_| UnixStream::connect(&d.socket).unwrap())
        .collect();
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut probe = Client::connect_unix(&d.socket).unwrap();
    probe.hello("rss-probe", None).unwrap();
    while !matches!(probe.call(&Request::Stats).unwrap(),
        Reply::DaemonStats(s) if s.sessions as usize > IDLE_SESSIONS)
    {
        assert!(Instant::now() < deadline, "idle sessions did not start");
        std::thread::sleep(Duration::from_millis(20));
    }
    drop(probe);
    drop(idle);
    d.wait_sessions_ended();
    let after_idle = d.rss_settled_mib(limit);
    eprintln!(
        "daemon RSS: baseline {baseline} MiB, after {ROUNDS} rounds of 3 unfinished \
         {FRAME_MIB} MB frames {after_frames} MiB, after {IDLE_SESSIONS} idle sessions \
         {after_idle} MiB"
    );
    // Generous: each round buffers 150 MB; unfixed, 3 rounds left about 350 MiB resident.
    assert!(
        after_frames <= limit && after_idle <= limit,
        "the daemon kept its memory: baseline {baseline} MiB, after the frames {after_frames} \
         MiB, after the idle sessions {after_idle} MiB"
    );
}
