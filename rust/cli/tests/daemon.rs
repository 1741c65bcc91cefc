//! `antumbra serve` as a real process over a real socket: renders equal the in-process ones,
//! signals stop it cleanly, TCP needs the token, the spool survives `kill -9`, and a bounded load
//! test. Every test kills its daemon when it ends (a guard) and a watchdog kills it after a
//! time limit.

use std::io::{BufRead, BufReader};
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant};

use antumbra_core::output::read_exr;
use antumbra_core::render::{FrameResult, RenderSettings, Renderer};
use antumbra_core::scene::{Resolution, Scene};
use antumbra_daemon::spool::{
    submit_job, JobSpec, Manifest, ATTEMPTS_FILE, DONE_FILE, ERROR_FILE, MANIFEST_FILE,
};
use antumbra_protocol::client::Client;
use antumbra_protocol::{
    planes_from_reply, stats_from_reply, FrameResultReply, NamedSettings, Passes, RecordingWriter,
    Reply, Request,
};
use antumbra_scenes::{builtin, SceneParams};
use tempfile::TempDir;

const REPLY_TIMEOUT: Duration = Duration::from_secs(60);

fn temp_dir(tag: &str) -> TempDir {
    tempfile::Builder::new()
        .prefix(&format!("antumbra-served-{tag}-"))
        .tempdir()
        .unwrap()
}

/// A daemon process; killed (SIGKILL) and reaped on drop, and by a watchdog after its time
/// limit.
struct DaemonProcess {
    child: Arc<Mutex<Child>>,
    pid: i32,
    ready: String,
    socket: PathBuf,
    stderr: PathBuf,
    finished: Arc<AtomicBool>,
}

impl DaemonProcess {
    /// Starts `antumbra serve --socket DIR/d.sock ARGS` and waits for its ready line.
    fn spawn(dir: &Path, args: &[&str], limit: Duration) -> DaemonProcess {
        Self::try_spawn(dir, args, limit).unwrap_or_else(|e| panic!("{e}"))
    }

    fn try_spawn(dir: &Path, args: &[&str], limit: Duration) -> Result<DaemonProcess, String> {
        Self::try_spawn_limited(dir, args, limit, None)
    }

    /// As `try_spawn`, with the process's address space limited to `address_space` bytes
    /// (RLIMIT_AS): an allocation past it fails and aborts the daemon, as running out of
    /// memory does.
    fn try_spawn_limited(
        dir: &Path,
        args: &[&str],
        limit: Duration,
        address_space: Option<u64>,
    ) -> Result<DaemonProcess, String> {
        static N: AtomicU64 = AtomicU64::new(0);
        let socket = dir.join("d.sock");
        let stderr = dir.join(format!("daemon-{}.log", N.fetch_add(1, Ordering::Relaxed)));
        let mut command = Command::new(env!("CARGO_BIN_EXE_antumbra"));
        command
            .arg("serve")
            .arg("--socket")
            .arg(&socket)
            .args(args)
            .env("RUST_LOG", "info")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(&stderr).unwrap());
        let rlimit = address_space.map(|bytes| libc::rlimit {
            rlim_cur: bytes,
            rlim_max: bytes,
        });
        // SAFETY: umask and setrlimit are async-signal-safe; the closure touches nothing else.
        // Umask 022, as a farm's shell has: the files' modes are checked against it.
        unsafe {
            use std::os::unix::process::CommandExt;
            command.pre_exec(move || {
                libc::umask(0o022);
                if let Some(rlimit) = &rlimit {
                    if libc::setrlimit(libc::RLIMIT_AS, rlimit) != 0 {
                        return Err(std::io::Error::last_os_error());
                    }
                }
                Ok(())
            });
        }
        let mut child = command.spawn().unwrap();
        let pid = child.id() as i32;
        let stdout = child.stdout.take().unwrap();
        let child = Arc::new(Mutex::new(child));
        let finished = Arc::new(AtomicBool::new(false));
        {
            let (child, finished) = (child.clone(), finished.clone());
            std::thread::spawn(move || {
                let deadline = Instant::now() + limit;
                while Instant::now() < deadline {
                    if finished.load(Ordering::Relaxed) {
                        return;
                    }
                    std::thread::sleep(Duration::from_millis(50));
                }
                eprintln!("watchdog: killing daemon {pid} after {limit:?}");
                let _ = child.lock().unwrap().kill();
            });
        }
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let mut lines = BufReader::new(stdout).lines();
            if let Some(Ok(line)) = lines.next() {
                let _ = tx.send(line);
            }
            for _ in lines {}
        });
        let mut p = DaemonProcess {
            child,
            pid,
            ready: String::new(),
            socket,
            stderr,
            finished,
        };
        match rx.recv_timeout(Duration::from_secs(30)) {
            Ok(line) => {
                p.ready = line;
                Ok(p)
            }
            Err(_) => Err(format!(
                "the daemon did not say it was listening; status {:?}; stderr:\n{}",
                p.wait(Duration::from_secs(5)),
                p.log()
            )),
        }
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.stderr).unwrap_or_default()
    }

    fn signal(&self, sig: i32) {
        // SAFETY: sending a signal to our own child process by pid.
        unsafe {
            libc::kill(self.pid, sig);
        }
    }

    fn wait(&self, timeout: Duration) -> Option<ExitStatus> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Ok(Some(s)) = self.child.lock().unwrap().try_wait() {
                return Some(s);
            }
            if Instant::now() >= deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    fn kill9(&self) {
        self.signal(libc::SIGKILL);
        self.wait(Duration::from_secs(10))
            .expect("killed daemon exits");
    }

    fn client(&self, name: &str) -> Client {
        let mut c = Client::connect_unix(&self.socket).expect("connect");
        c.set_timeout(Some(REPLY_TIMEOUT)).unwrap();
        c.hello(name, None).expect("hello");
        c
    }
}

impl Drop for DaemonProcess {
    fn drop(&mut self) {
        self.finished.store(true, Ordering::Relaxed);
        let mut c = self.child.lock().unwrap();
        let _ = c.kill();
        let _ = c.wait();
    }
}

fn city(triangles: usize, frames: i32, w: u32, h: u32) -> Vec<Scene> {
    let anim = builtin(
        "city",
        &SceneParams {
            triangles,
            frames,
            ..SceneParams::default()
        },
    )
    .unwrap();
    anim.frame_range()
        .map(|f| {
            let mut s = anim.frame(f);
            s.resolution = Resolution::new(w, h);
            s
        })
        .collect()
}

fn render_in_process(label: &str, scenes: &[Scene]) -> Vec<FrameResult> {
    let mut r = Renderer::new();
    scenes
        .iter()
        .map(|s| r.render(label, s, &RenderSettings::default()).unwrap())
        .collect()
}

/// The planes of a result as `antumbra render` writes them to the EXR.
fn planes(result: &FrameResult) -> Vec<antumbra_core::image::ImagePlane> {
    antumbra_core::output::planes(result)
}

fn same_bits(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// Every image bit for bit, the statistics except wall-clock timings.
fn assert_same_result(reply: &FrameResultReply, expected: &FrameResult) {
    let got = planes_from_reply(reply).unwrap();
    let want = planes(expected);
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g.name, w.name);
        assert!(
            same_bits(&g.data, &w.data),
            "frame {}: plane {} differs",
            reply.frame,
            g.name
        );
    }
    let untimed = antumbra_core::stats::StatsRow::untimed;
    let got = stats_from_reply(reply);
    assert_eq!(got.len(), expected.stats.len());
    for (g, w) in got.iter().zip(&expected.stats) {
        assert_eq!(untimed(g), untimed(w));
    }
}

fn render(c: &mut Client, frame: i32, id: u64) -> FrameResultReply {
    c.render(frame, NamedSettings::default(), Passes::default(), id)
        .expect("render")
        .result
}

#[test]
fn serve_renders_like_in_process_and_stops_on_sigterm() {
    let dir = temp_dir("basic");
    let d = DaemonProcess::spawn(dir.path(), &[], Duration::from_secs(60));
    assert_eq!(
        d.ready,
        format!("antumbra: listening on unix:{}", d.socket.display())
    );
    let mode = std::fs::metadata(&d.socket).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o600, "{mode:o}");
    let scenes = city(10_000, 3, 64, 40);
    let expected = render_in_process("process", &scenes);
    let mut c = d.client("process");
    for (i, (s, want)) in scenes.iter().zip(&expected).enumerate() {
        let sent = c.send_scene(s).unwrap();
        if i > 0 {
            // The city's static meshes are cached; only changed meshes (if any) go up.
            assert!(sent.meshes_uploaded < s.meshes.len(), "{sent:?}");
        }
        assert_same_result(&render(&mut c, s.frame, i as u64), want);
    }
    // A second daemon on the same socket is refused while this one lives.
    let err = DaemonProcess::try_spawn(dir.path(), &[], Duration::from_secs(30))
        .err()
        .expect("second daemon refused");
    assert!(err.contains("already listening"), "{err}");
    d.signal(libc::SIGTERM);
    let status = d
        .wait(Duration::from_secs(15))
        .expect("exits after SIGTERM");
    assert!(status.success(), "{status:?}\n{}", d.log());
    assert!(!d.socket.exists(), "socket removed");
    assert!(d.log().contains("daemon stopped"), "{}", d.log());
}

#[test]
fn serve_tcp_needs_token_and_loopback() {
    let dir = temp_dir("tcp");
    let token = dir.path().join("token");
    std::fs::write(&token, "  tcp-secret-1\n").unwrap();
    std::fs::set_permissions(&token, std::fs::Permissions::from_mode(0o600)).unwrap();
    let token_arg = token.to_str().unwrap();
    let d = DaemonProcess::spawn(
        dir.path(),
        &[
            "--tcp",
            "127.0.0.1:0",
            "--token-file",
            token_arg,
            "--log-format",
            "json",
        ],
        Duration::from_secs(60),
    );
    let addr: std::net::SocketAddr = d
        .ready
        .split_whitespace()
        .find_map(|w| w.strip_prefix("tcp:"))
        .expect("tcp address in the ready line")
        .parse()
        .unwrap();
    assert!(addr.ip().is_loopback());
    let connect = || {
        let c = Client::connect_tcp(addr).unwrap();
        c.set_timeout(Some(REPLY_TIMEOUT)).unwrap();
        c
    };
    let mut bad = connect();
    let err = bad.hello("intruder", Some("tcp-secret-2")).unwrap_err();
    assert!(err.to_string().contains("authentication failed"), "{err}");
    let mut none = connect();
    assert!(none.hello("intruder", None).is_err());
    let mut good = connect();
    good.hello("friend", Some("tcp-secret-1")).unwrap();
    assert!(matches!(
        good.call(&Request::Stats).unwrap(),
        Reply::DaemonStats(_)
    ));
    // The refusal is logged, as JSON lines.
    let deadline = Instant::now() + Duration::from_secs(10);
    while !d.log().contains("authentication failed") {
        assert!(Instant::now() < deadline, "{}", d.log());
        std::thread::sleep(Duration::from_millis(20));
    }
    let line = d
        .log()
        .lines()
        .find(|l| l.contains("authentication failed"))
        .unwrap()
        .to_string();
    assert!(
        serde_json::from_str::<serde_json::Value>(&line).is_ok(),
        "{line}"
    );
    drop(d);

    // Non-loopback addresses are refused before anything is bound.
    let dir2 = temp_dir("tcp-any");
    let err = DaemonProcess::try_spawn(
        dir2.path(),
        &["--tcp", "0.0.0.0:0", "--token-file", token_arg],
        Duration::from_secs(30),
    )
    .err()
    .expect("non-loopback refused");
    assert!(err.contains("loopback"), "{err}");
    assert!(!dir2.path().join("d.sock").exists());
}

fn frame_dirs(results: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(results)
        .map(|r| {
            r.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with("frame_"))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Waits until at least `n` frame folders exist (or the job is done).
fn wait_for_frames(results: &Path, n: usize, d: &DaemonProcess) -> usize {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let k = frame_dirs(results).len();
        if k >= n || results.join(DONE_FILE).exists() {
            return k;
        }
        assert!(Instant::now() < deadline, "no progress: {}", d.log());
        std::thread::sleep(Duration::from_millis(1));
    }
}

#[test]
fn spool_job_survives_kill_9_with_every_frame_exactly_once() {
    let t0 = Instant::now();
    let dir = temp_dir("spool");
    let spool = dir.path().join("spool");
    let spool_arg = spool.to_str().unwrap().to_string();
    let args = ["--spool", spool_arg.as_str(), "--spool-rescan-s", "0.2"];
    let scenes = city(10_000, 20, 96, 60);
    let spec = JobSpec {
        name: Some("killed".into()),
        settings: spool_method().to_named(),
        ..JobSpec::default()
    };
    submit_job(&spool, "shot-020", &spec, |path| {
        let mut w = RecordingWriter::create(path).map_err(|e| e.to_string())?;
        for s in &scenes {
            w.append_scene(s).map_err(|e| e.to_string())?;
        }
        w.finish().map_err(|e| e.to_string())?;
        Ok(())
    })
    .unwrap();
    let results = spool.join("results/shot-020");
    // Kill it six times while it works, at different moments of a frame (rendering, writing
    // the files, renaming, rewriting the manifest).
    let mut kills = 0;
    for target in [2, 5, 8, 11, 14, 17] {
        let d = DaemonProcess::spawn(dir.path(), &args, Duration::from_secs(60));
        let k = wait_for_frames(&results, target, &d);
        if results.join(DONE_FILE).exists() {
            break;
        }
        // Let it get into the next frame's writing, then kill.
        std::thread::sleep(Duration::from_millis((kills * 7 % 40) as u64));
        d.kill9();
        kills += 1;
        let temporaries = std::fs::read_dir(&results)
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with('.'))
            .count();
        eprintln!("killed the daemon with {k}+ of 20 frames finished, {temporaries} temporaries");
    }
    let before_last = frame_dirs(&results).len();
    let d = DaemonProcess::spawn(dir.path(), &args, Duration::from_secs(60));
    wait_for_frames(&results, 20, &d);
    let deadline = Instant::now() + Duration::from_secs(30);
    while !results.join(DONE_FILE).exists() {
        assert!(Instant::now() < deadline, "{}", d.log());
        std::thread::sleep(Duration::from_millis(10));
    }
    // The last daemon rendered exactly the frames that were missing.
    let mut c = d.client("check");
    match c.call(&Request::Stats).unwrap() {
        Reply::DaemonStats(s) => assert_eq!(s.renders_done as usize, 20 - before_last),
        other => panic!("{other:?}"),
    }
    let manifest: Manifest =
        serde_json::from_slice(&std::fs::read(results.join(MANIFEST_FILE)).unwrap()).unwrap();
    assert!(manifest.done);
    let listed: Vec<i32> = manifest.frames.iter().map(|f| f.frame).collect();
    assert_eq!(
        listed,
        (1..=20).collect::<Vec<_>>(),
        "each frame once, in order"
    );
    assert_eq!(frame_dirs(&results).len(), 20);
    let leftovers: Vec<String> = std::fs::read_dir(&results)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    assert_frames_equal_in_process(&results, &manifest, &scenes, "killed");
    eprintln!(
        "spool kill test: {kills} kills, {} frames left for the last run, {:.1} s",
        20 - before_last,
        t0.elapsed().as_secs_f64()
    );
    drop(d);
}

/// The spool's test job: `scenes` recorded as job `id`.
fn submit_scenes(spool: &Path, id: &str, label: &str, scenes: &[Scene]) {
    let spec = JobSpec {
        name: Some(label.into()),
        settings: spool_method().to_named(),
        ..JobSpec::default()
    };
    submit_job(spool, id, &spec, |path| {
        let mut w = RecordingWriter::create(path).map_err(|e| e.to_string())?;
        for s in scenes {
            w.append_scene(s).map_err(|e| e.to_string())?;
        }
        w.finish().map_err(|e| e.to_string())?;
        Ok(())
    })
    .unwrap();
}

/// The frames `attempts.log` says were started, in order.
fn started_frames(results: &Path) -> Vec<String> {
    std::fs::read_to_string(results.join(ATTEMPTS_FILE))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.strip_prefix("start "))
        .filter_map(|l| l.split_whitespace().next().map(String::from))
        .collect()
}

/// `kill -9` from outside, each time the daemon starts a frame (issue 33: five kills in 7 s
/// ended a job in ERROR at frame 3 of 20). The daemon cannot tell these kills from a frame that
/// kills it (the kernel's out-of-memory killer sends SIGKILL too), so the third kill during one
/// frame ends the job like a crash loop, with an ERROR that names the command that resumes it;
/// `antumbra spool resume`, run while the daemon serves, makes it go on from the first missing
/// frame, and every frame ends up rendered once and equal to an in-process render.
#[test]
fn spool_job_killed_during_one_frame_is_resumed_with_every_frame_equal() {
    let dir = temp_dir("spool-resume");
    let spool = dir.path().join("spool");
    let spool_arg = spool.to_str().unwrap().to_string();
    let args = ["--spool", spool_arg.as_str(), "--spool-rescan-s", "0.2"];
    // Frames that take long enough for a kill to land while they render.
    let scenes = city(40_000, 4, 480, 300);
    submit_scenes(&spool, "shot-kill", "resumed", &scenes);
    let results = spool.join("results/shot-kill");
    let error = results.join(ERROR_FILE);
    let mut kills = 0;
    let d = loop {
        assert!(
            kills < 12,
            "no ERROR after {kills} kills: {:?}",
            started_frames(&results)
        );
        let before = started_frames(&results).len();
        let d = DaemonProcess::spawn(dir.path(), &args, Duration::from_secs(120));
        let deadline = Instant::now() + Duration::from_secs(30);
        while started_frames(&results).len() == before && !error.exists() {
            assert!(Instant::now() < deadline, "no frame started:\n{}", d.log());
            std::thread::sleep(Duration::from_millis(1));
        }
        if error.exists() {
            break d;
        }
        d.kill9();
        kills += 1;
    };
    let e = std::fs::read_to_string(&error).unwrap();
    assert!(e.contains("was started 3 times and never finished"), "{e}");
    let resume = format!("antumbra spool resume {} shot-kill", spool.display());
    assert!(e.contains(&resume), "{e}");
    let finished_before = frame_dirs(&results).len();
    assert!(
        finished_before < scenes.len(),
        "{finished_before} frames finished"
    );
    eprintln!("{kills} kills; ERROR with {finished_before} frames finished: {e}");
    // Resumed while the daemon serves: it goes on by itself.
    let out = Command::new(env!("CARGO_BIN_EXE_antumbra"))
        .args(["spool", "resume"])
        .arg(&spool)
        .arg("shot-kill")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("resumed job shot-kill"), "{stdout}");
    let deadline = Instant::now() + Duration::from_secs(60);
    while !results.join(DONE_FILE).exists() {
        assert!(
            Instant::now() < deadline,
            "not done after resume:\n{}",
            d.log()
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(!error.exists());
    let mut c = d.client("check");
    match c.call(&Request::Stats).unwrap() {
        Reply::DaemonStats(s) => {
            assert_eq!(s.renders_done as usize, scenes.len() - finished_before)
        }
        other => panic!("{other:?}"),
    }
    let manifest: Manifest =
        serde_json::from_slice(&std::fs::read(results.join(MANIFEST_FILE)).unwrap()).unwrap();
    let listed: Vec<i32> = manifest.frames.iter().map(|f| f.frame).collect();
    assert_eq!(listed, (1..=scenes.len() as i32).collect::<Vec<_>>());
    assert_frames_equal_in_process(&results, &manifest, &scenes, "resumed");
    // A done job is not resumed again.
    let out = Command::new(env!("CARGO_BIN_EXE_antumbra"))
        .args(["spool", "resume"])
        .arg(&spool)
        .arg("shot-kill")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("the job is done"), "{stderr}");
}

/// The spool tests' method: a fixed one, since a resumed job warms up its trees and visible set
/// but not what `auto` measured, so with `auto` only its masks equal one uninterrupted run's.
fn spool_method() -> RenderSettings {
    RenderSettings::baseline()
}

/// Every frame folder of a finished spool job is complete and right: each EXR equals an
/// in-process render of its scene, every listed file is there, and every file is readable by
/// others (the daemons of these tests run under umask 022).
fn assert_frames_equal_in_process(
    results: &Path,
    manifest: &Manifest,
    scenes: &[Scene],
    label: &str,
) {
    let mut renderer = Renderer::new();
    for (f, s) in manifest.frames.iter().zip(scenes) {
        let want = renderer.render(label, s, &spool_method()).unwrap();
        let folder = results.join(&f.dir);
        let got = read_exr(&folder.join(format!("{}.exr", f.dir))).unwrap();
        let want = planes(&want);
        assert_eq!(got.len(), want.len(), "{}", f.dir);
        for w in &want {
            // EXR channels come back sorted by name.
            let g = got
                .iter()
                .find(|g| g.name == w.name)
                .expect("plane in the EXR");
            assert!(same_bits(&g.data, &w.data), "{} {}", f.dir, g.name);
        }
        for file in &f.files {
            let path = folder.join(file);
            assert!(path.is_file(), "{}/{file}", f.dir);
            let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o644, "{}/{file}: mode {mode:o}", f.dir);
        }
        assert!(f.files.iter().any(|n| n == "stats.json"));
        assert!(f.files.iter().filter(|n| n.ends_with(".png")).count() >= 8);
    }
    for name in [MANIFEST_FILE, DONE_FILE] {
        let mode = std::fs::metadata(results.join(name))
            .unwrap()
            .permissions()
            .mode()
            & 0o777;
        assert_eq!(mode, 0o644, "{name}: mode {mode:o}");
    }
}

/// `clients` concurrent sessions each send and render `frames` frames of a small city; every
/// result is checked against the in-process render. Prints throughput and latency.
/// A frame that needs far more memory than the daemon may map (RLIMIT_AS) kills it each time
/// the frame starts, as running out of memory does. After N starts (3 by default) the job ends
/// in ERROR with the reason and the job queued behind it is rendered.
#[test]
fn spool_job_that_kills_the_daemon_ends_in_error_after_3_starts() {
    const ADDRESS_SPACE: u64 = 512 << 20;
    let dir = temp_dir("spool-oom");
    let spool = dir.path().join("spool");
    let spool_arg = spool.to_str().unwrap().to_string();
    let args = ["--spool", spool_arg.as_str(), "--spool-rescan-s", "0.2"];
    let write = |scenes: Vec<Scene>| {
        move |path: &Path| {
            let mut w = RecordingWriter::create(path).map_err(|e| e.to_string())?;
            for s in &scenes {
                w.append_scene(s).map_err(|e| e.to_string())?;
            }
            w.finish().map_err(|e| e.to_string())?;
            Ok(())
        }
    };
    // 2048x2048: a few hundred MB of image planes, far past the address space left.
    submit_job(
        &spool,
        "a-huge",
        &JobSpec::default(),
        write(city(2_000, 1, 2048, 2048)),
    )
    .unwrap();
    submit_job(
        &spool,
        "b-small",
        &JobSpec::default(),
        write(city(2_000, 2, 32, 24)),
    )
    .unwrap();
    let results = spool.join("results");
    let starts = || {
        std::fs::read_to_string(results.join("a-huge/attempts.log"))
            .unwrap_or_default()
            .lines()
            .filter(|l| l.starts_with("start "))
            .count()
    };
    for death in 1..=3 {
        let d = DaemonProcess::try_spawn_limited(
            dir.path(),
            &args,
            Duration::from_secs(120),
            Some(ADDRESS_SPACE),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let status = d
            .wait(Duration::from_secs(60))
            .unwrap_or_else(|| panic!("start {death}: the daemon did not die:\n{}", d.log()));
        assert!(!status.success(), "{status:?}\n{}", d.log());
        assert!(d.log().contains("memory allocation"), "{}", d.log());
        assert!(!results.join("a-huge").join(ERROR_FILE).exists());
    }
    // The fourth start gives up on the job and goes on to the next.
    let d = DaemonProcess::try_spawn_limited(
        dir.path(),
        &args,
        Duration::from_secs(120),
        Some(ADDRESS_SPACE),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let deadline = Instant::now() + Duration::from_secs(60);
    while !results.join("b-small").join(DONE_FILE).exists() {
        if let Some(status) = d.wait(Duration::ZERO) {
            panic!(
                "the daemon died again ({status:?}): a crash loop\n{}",
                d.log()
            );
        }
        assert!(Instant::now() < deadline, "b-small not done:\n{}", d.log());
        std::thread::sleep(Duration::from_millis(20));
    }
    let e = std::fs::read_to_string(results.join("a-huge").join(ERROR_FILE)).unwrap();
    assert!(
        e.contains("frame 1 was started 3 times and never finished"),
        "{e}"
    );
    assert_eq!(starts(), 3, "one start recorded before each death");
    assert!(d.wait(Duration::ZERO).is_none(), "the daemon still serves");
    let m: Manifest = serde_json::from_slice(
        &std::fs::read(results.join("b-small").join(MANIFEST_FILE)).unwrap(),
    )
    .unwrap();
    assert_eq!(m.frames.len(), 2);
}

fn load_test(clients: usize, frames: i32, max_renders: &str) {
    let dir = temp_dir("load");
    let scenes = Arc::new(city(10_000, frames, 128, 80));
    let expected = Arc::new(render_in_process("load", &scenes));
    let d = DaemonProcess::spawn(
        dir.path(),
        &["--max-renders", max_renders],
        Duration::from_secs(300),
    );
    let socket = d.socket.clone();
    let t0 = Instant::now();
    let threads: Vec<_> = (0..clients)
        .map(|i| {
            let (scenes, expected, socket) = (scenes.clone(), expected.clone(), socket.clone());
            std::thread::spawn(move || {
                let mut c = Client::connect_unix(&socket).unwrap();
                c.set_timeout(Some(REPLY_TIMEOUT)).unwrap();
                c.hello("load", None).unwrap();
                let mut latencies = Vec::new();
                for (k, (s, want)) in scenes.iter().zip(expected.iter()).enumerate() {
                    let t = Instant::now();
                    c.send_scene(s).unwrap();
                    let reply = render(&mut c, s.frame, (i * 1000 + k) as u64);
                    latencies.push(t.elapsed());
                    assert_same_result(&reply, want);
                }
                c.close().unwrap();
                latencies
            })
        })
        .collect();
    let mut latencies: Vec<Duration> = threads
        .into_iter()
        .flat_map(|t| t.join().expect("client thread"))
        .collect();
    let wall = t0.elapsed();
    latencies.sort();
    let pick = |q: f64| latencies[((latencies.len() - 1) as f64 * q).round() as usize];
    eprintln!(
        "load test: {clients} clients x {frames} frames (city ~10k triangles, 128x80, \
         --max-renders {max_renders}): {} frames in {:.2} s = {:.1} frames/s; latency p50 {:.1} ms, \
         p99 {:.1} ms, max {:.1} ms",
        latencies.len(),
        wall.as_secs_f64(),
        latencies.len() as f64 / wall.as_secs_f64(),
        pick(0.5).as_secs_f64() * 1e3,
        pick(0.99).as_secs_f64() * 1e3,
        latencies.last().unwrap().as_secs_f64() * 1e3,
    );
    assert_eq!(latencies.len(), clients * frames as usize);
    drop(d);
}

#[test]
fn load_8_clients_x_5_frames() {
    load_test(8, 5, "2");
}

#[test]
#[ignore = "bigger load test; run with --ignored"]
fn load_8_clients_x_20_frames() {
    load_test(8, 20, "2");
}

#[test]
fn recorded_session_replays_with_antumbra_render() {
    let dir = temp_dir("record");
    let rec = dir.path().join("recordings");
    let d = DaemonProcess::spawn(
        dir.path(),
        &["--record", rec.to_str().unwrap()],
        Duration::from_secs(60),
    );
    let scenes = city(10_000, 2, 48, 30);
    let mut c = d.client("recorded");
    let mut replies = Vec::new();
    for (i, s) in scenes.iter().enumerate() {
        c.send_scene(s).unwrap();
        replies.push(render(&mut c, s.frame, i as u64));
    }
    c.close().unwrap();
    drop(d);
    let files: Vec<PathBuf> = std::fs::read_dir(&rec)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let out = dir.path().join("out");
    let run = Command::new(env!("CARGO_BIN_EXE_antumbra"))
        .args(["render", "--scene"])
        .arg(&files[0])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    for reply in &replies {
        let exr = out.join(format!("frame_{:04}.exr", reply.frame));
        let got = read_exr(&exr).unwrap();
        let want = planes_from_reply(reply).unwrap();
        assert_eq!(got.len(), want.len());
        for w in &want {
            let g = got.iter().find(|g| g.name == w.name).expect("plane");
            assert!(
                same_bits(&g.data, &w.data),
                "frame {} {}",
                reply.frame,
                w.name
            );
        }
    }
}
