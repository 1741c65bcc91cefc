//! An in-process daemon on a temporary socket, clients for it, and small scenes.
#![allow(dead_code)]

use std::path::PathBuf;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use antumbra_core::render::{FrameResult, RenderSettings, Renderer};
use antumbra_core::scene::{Camera, Light, LightKind, Mesh, Object, Resolution, Scene};
use antumbra_daemon::{Daemon, DaemonConfig, DaemonError, DaemonHandle};
use antumbra_protocol::client::Client;
use antumbra_protocol::{
    planes_from_reply, DaemonStats, FrameResultReply, NamedSettings, Passes, Reply, Request,
};
use antumbra_scenes::{builtin, SceneParams};
use glam::{DMat4, DVec3, Vec3};

/// Replies must come within this; no test waits longer for one.
pub const TIMEOUT: Duration = Duration::from_secs(60);

pub use tempfile::TempDir;

pub mod spool;

/// A unique empty folder under the system's temp dir (named after `tag`), removed on drop.
pub fn temp_dir(tag: &str) -> TempDir {
    tempfile::Builder::new()
        .prefix(&format!("antd-{tag}-"))
        .tempdir()
        .unwrap()
}

/// A daemon serving on its own thread; stopped and joined on drop.
pub struct TestDaemon {
    pub dir: TempDir,
    pub socket: PathBuf,
    pub tcp: Option<std::net::SocketAddr>,
    pub handle: DaemonHandle,
    thread: Option<JoinHandle<Result<(), DaemonError>>>,
}

impl TestDaemon {
    pub fn start(tag: &str) -> Self {
        Self::start_with(tag, |_| {})
    }

    pub fn start_with(tag: &str, configure: impl FnOnce(&mut DaemonConfig)) -> Self {
        let dir = temp_dir(tag);
        let socket = dir.path().join("run").join("daemon.sock");
        let mut config = DaemonConfig::new(&socket);
        config.shutdown_grace = Duration::from_secs(20);
        config.spool_rescan = Duration::from_millis(200);
        configure(&mut config);
        let daemon = Daemon::bind(config).expect("daemon binds");
        let handle = daemon.handle();
        let tcp = daemon.tcp_addr();
        let thread = std::thread::spawn(move || daemon.run());
        TestDaemon {
            dir,
            socket,
            tcp,
            handle,
            thread: Some(thread),
        }
    }

    /// A connected client that said Hello.
    pub fn client(&self, name: &str) -> Client {
        let mut c = self.raw_client();
        c.hello(name, None).expect("hello");
        c
    }

    /// A connected client that said nothing yet.
    pub fn raw_client(&self) -> Client {
        let c = Client::connect_unix(&self.socket).expect("connect");
        c.set_timeout(Some(TIMEOUT)).unwrap();
        c
    }

    /// Stops the daemon and waits for `run` to return.
    pub fn stop(mut self) -> Result<(), DaemonError> {
        self.handle.stop();
        self.thread.take().unwrap().join().unwrap()
    }

    /// Waits until `pred` holds for the daemon's statistics.
    pub fn wait_for_stats(&self, what: &str, pred: impl Fn(&DaemonStats) -> bool) -> DaemonStats {
        let deadline = Instant::now() + TIMEOUT;
        loop {
            let s = self.handle.stats();
            if pred(&s) {
                return s;
            }
            assert!(
                Instant::now() < deadline,
                "timed out waiting for {what}: {s:?}"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

impl Drop for TestDaemon {
    fn drop(&mut self) {
        self.handle.stop();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// A 2x2 ground quad at z = 0.
pub fn ground() -> Mesh {
    Mesh::new(
        "ground",
        vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

/// A unit cube centred on the origin.
pub fn cube() -> Mesh {
    let p: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -0.5 } else { 0.5 },
                if i & 2 == 0 { -0.5 } else { 0.5 },
                if i & 4 == 0 { -0.5 } else { 0.5 },
            )
        })
        .collect();
    let t = vec![
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ];
    Mesh::new("cube", p, t)
}

/// A ground, a box sliding along x with `frame` (same meshes every frame), a soft sun.
pub fn tiny_scene(frame: i32, width: u32, height: u32) -> Scene {
    let x = 0.1 * frame as f64;
    Scene {
        frame,
        meshes: vec![Arc::new(ground()), Arc::new(cube())],
        objects: vec![
            Object::new("ground", 0, DMat4::from_scale(DVec3::splat(4.0))),
            Object::new("box", 1, DMat4::from_translation(DVec3::new(x, 0.0, 0.5))),
        ],
        camera: Camera::look_at(DVec3::new(0.0, -6.0, 4.0), DVec3::ZERO, DVec3::Z),
        lights: vec![Light::new(
            "sun",
            DMat4::from_rotation_x(0.4) * DMat4::from_rotation_y(0.3),
            LightKind::Sun { angle: 0.05 },
        )],
        resolution: Resolution::new(width, height),
        alpha: Default::default(),
    }
}

/// Frames of the built-in city at about `triangles` triangles, rendered at `w`x`h`.
pub fn city_frames(triangles: usize, frames: i32, w: u32, h: u32) -> Vec<Scene> {
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

/// Renders `scenes` in order with one renderer, as a session does.
pub fn render_in_process(
    label: &str,
    scenes: &[Scene],
    settings: &RenderSettings,
) -> Vec<FrameResult> {
    let mut r = Renderer::new();
    scenes
        .iter()
        .map(|s| r.render(label, s, settings).unwrap())
        .collect()
}

/// Asserts that a reply carries exactly the in-process result: every image bit for bit (in the
/// CLI's plane order), and the statistics except wall-clock timings.
pub fn assert_same_result(reply: &FrameResultReply, expected: &FrameResult) {
    assert_eq!(reply.frame, expected.frame);
    assert_eq!(
        (reply.width, reply.height),
        (expected.width, expected.height)
    );
    let got = planes_from_reply(reply).unwrap();
    let want = antumbra_core::output::planes(expected);
    assert_eq!(
        got.len(),
        want.len(),
        "frame {}: plane count",
        expected.frame
    );
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g.name, w.name);
        let gb: Vec<u32> = g.data.iter().map(|v| v.to_bits()).collect();
        let wb: Vec<u32> = w.data.iter().map(|v| v.to_bits()).collect();
        assert!(
            gb == wb,
            "frame {}: plane '{}' differs",
            expected.frame,
            g.name
        );
    }
    let got = antumbra_protocol::stats_from_reply(reply);
    assert_eq!(got.len(), expected.stats.len());
    for (g, w) in got.iter().zip(&expected.stats) {
        let untimed = antumbra_core::stats::StatsRow::untimed;
        assert_eq!(
            untimed(g),
            untimed(w),
            "frame {}: statistics",
            expected.frame
        );
    }
}

pub fn render_reply(c: &mut Client, frame: i32, request_id: u64) -> FrameResultReply {
    c.render(
        frame,
        NamedSettings::default(),
        Passes::default(),
        request_id,
    )
    .expect("render")
    .result
}

/// The `Error` fields of a reply; panics on anything else.
pub fn expect_error(reply: Reply) -> (antumbra_protocol::ErrorCode, String, bool, Option<u64>) {
    match reply {
        Reply::Error {
            code,
            message,
            session_usable,
            request_id,
        } => (code, message, session_usable, request_id),
        other => panic!("expected an error reply, got {}", other.kind()),
    }
}

/// After an error that closed the connection, the stream ends.
pub fn assert_closed(c: &mut Client) {
    match c.recv() {
        Err(antumbra_protocol::client::ClientError::Read {
            error: antumbra_protocol::FrameError::Closed | antumbra_protocol::FrameError::Io(_),
            ..
        }) => {}
        other => panic!("expected the connection to be closed, got {other:?}"),
    }
}

/// A client that sends a tiny scene and can prove the daemon still serves it.
pub struct Bystander {
    pub client: Client,
    frame: i32,
    /// Renders the bystander's frames in process, in the order its session renders them (the
    /// default method, `auto`, chooses from the frames before).
    here: Renderer,
}

impl Bystander {
    pub fn new(d: &TestDaemon) -> Self {
        let mut client = d.client("bystander");
        client.send_scene(&tiny_scene(1, 16, 12)).unwrap();
        Bystander {
            client,
            frame: 1,
            here: Renderer::new(),
        }
    }

    /// Renders a new frame and checks it against an in-process render.
    pub fn still_served(&mut self) {
        self.frame += 1;
        let s = tiny_scene(self.frame, 16, 12);
        self.client.send_scene(&s).unwrap();
        let reply = render_reply(&mut self.client, self.frame, 1000 + self.frame as u64);
        let want = (self.here)
            .render("bystander", &s, &RenderSettings::default())
            .unwrap();
        assert_same_result(&reply, &want);
        assert!(matches!(
            self.client.call(&Request::Stats).unwrap(),
            Reply::DaemonStats(_)
        ));
    }
}

/// A `Compare` of `methods` (`LABEL=NAME=VALUE,...`) at `spp`, `repeat` timed passes each.
pub fn compare_request(
    methods: &[impl AsRef<str>],
    frame: i32,
    request_id: u64,
    spp: i64,
    repeat: u32,
) -> antumbra_protocol::CompareRequest {
    antumbra_protocol::CompareRequest {
        frame,
        request_id,
        settings: NamedSettings::new().with("spp", spp),
        methods: methods
            .iter()
            .map(|m| {
                let spec: antumbra_core::compare::MethodSpec = m.as_ref().parse().unwrap();
                antumbra_protocol::CompareMethod {
                    label: spec.label,
                    settings: spec.settings,
                }
            })
            .collect(),
        baseline: None,
        repeat,
        images: false,
        warm_up: false,
    }
}
