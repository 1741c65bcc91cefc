//! One session logic: the same requests answered by a daemon's connection and by
//! `antumbra-session` run in this process (as `LocalSession` runs it) give the same replies,
//! every byte but wall-clock timings: uploads, frame updates, renders, warm-ups, comparisons,
//! trades and the errors of each.

mod common;

use std::sync::Arc;

use antumbra_core::cancel::CancelToken;
use antumbra_core::output::read_exr;
use antumbra_daemon::spool::{JobSpec, DONE_FILE};
use antumbra_protocol::client::Client;
use antumbra_protocol::{
    planes_from_reply, scene_to_messages, stats_from_reply, Limits, NamedSettings, Passes,
    RenderRequest, Reply, Request, TradeRequest,
};
use antumbra_session::{Handled, MeshCache, SessionRenderer, SessionState};
use common::{compare_request, tiny_scene, TestDaemon};
use serde_json::Value;

const CLIENT: &str = "one-session";

/// Every request of the session, in order: meshes, two frames, then each kind of job and of
/// refusal. Methods are named explicitly, so no choice depends on measured time.
fn requests() -> Vec<Request> {
    let fixed = || {
        NamedSettings::new()
            .with("build", "sah")
            .with("order", "fbto")
    };
    let render = |frame, request_id, warm_up| {
        Request::Render(RenderRequest {
            frame,
            settings: fixed().with("spp", 2_i64),
            passes: Passes::default(),
            request_id,
            warm_up,
        })
    };
    let (uploads, first) = scene_to_messages(&tiny_scene(1, 16, 12)).unwrap();
    let (_, second) = scene_to_messages(&tiny_scene(2, 16, 12)).unwrap();
    let hashes: Vec<u64> = uploads
        .iter()
        .filter_map(|u| match u {
            Request::UploadMesh(m) => Some(m.hash),
            _ => None,
        })
        .collect();
    let mut requests = vec![Request::MissingMeshes {
        hashes: [hashes.clone(), vec![7]].concat(),
    }];
    requests.extend(uploads);
    requests.extend([
        Request::MissingMeshes { hashes },
        first,
        render(1, 1, true),
        second,
        render(2, 2, false),
        // Never sent: refused naming the frame.
        render(9, 3, false),
    ]);
    let methods = [
        "sah2=build=sah,width=2",
        "sah4=build=sah,width=4,order=sorted",
    ];
    let compare =
        |frame, request_id| Request::Compare(compare_request(&methods, frame, request_id, 2, 1));
    requests.extend([compare(1, 4), compare(2, 5)]);
    let mut bad = compare_request(&methods, 2, 6, 2, 1);
    bad.baseline = Some("nobody".into());
    requests.push(Request::Compare(bad));
    let trade = |knobs: &[&str], request_id| {
        Request::Trade(TradeRequest {
            frame: 2,
            request_id,
            settings: NamedSettings::new().with("spp", 2_i64),
            knobs: knobs.iter().map(|k| k.to_string()).collect(),
            repeat: 1,
        })
    };
    requests.extend([trade(&["width=2,4"], 7), trade(&["no_such_knob"], 8)]);
    requests
}

/// What a daemon's connection answers: each request's last reply (its `Progress` apart).
fn through_daemon(client: &mut Client, request: &Request) -> (Reply, Vec<(String, u32, u32)>) {
    client.send(request).unwrap();
    let mut progress = Vec::new();
    loop {
        match client.recv().unwrap() {
            Reply::Progress {
                stage, done, total, ..
            } => progress.push((stage, done, total)),
            reply => return (reply, progress),
        }
    }
}

/// What the same session answers in this process, as `LocalSession` runs it.
struct InProcess {
    state: SessionState,
    renderer: SessionRenderer,
}

impl InProcess {
    fn answer(&mut self, request: Request) -> (Reply, Vec<(String, u32, u32)>) {
        let job = match self.state.handle(request) {
            Handled::Reply(reply) | Handled::Refused(reply) => return (reply, Vec::new()),
            Handled::Job(job) => job,
            Handled::Control(_) => panic!("no control request is sent"),
        };
        let stage = job.stage();
        let mut progress = Vec::new();
        let done = self
            .renderer
            .run(&job, CLIENT, &CancelToken::new(), &mut |done, total| {
                progress.push((stage.to_string(), done, total))
            });
        match done {
            Ok(done) => (done.into_reply(&job), progress),
            Err(e) => (
                antumbra_session::protocol_error(&e, Some(job.request_id)),
                progress,
            ),
        }
    }
}

/// Zeroes every wall-clock timing in a tree of values: whatever measures time (names ending in
/// `_ms`, and `mrays_per_s`).
fn zero_timings(v: &mut Value) {
    fn zero(v: &mut Value) {
        match v {
            Value::Number(_) => *v = Value::from(0),
            Value::Array(a) => a.iter_mut().for_each(zero),
            Value::Object(o) => o.values_mut().for_each(zero),
            _ => {}
        }
    }
    match v {
        Value::Array(a) => a.iter_mut().for_each(zero_timings),
        Value::Object(o) => {
            for (k, v) in o.iter_mut() {
                if k.ends_with("_ms") || k == "mrays_per_s" {
                    zero(v);
                } else {
                    zero_timings(v);
                }
            }
        }
        _ => {}
    }
}

/// A reply as a tree of values, its timings zeroed.
fn untimed(reply: &Reply) -> Value {
    let mut v = serde_json::to_value(reply).unwrap();
    zero_timings(&mut v);
    v
}

#[test]
fn a_daemon_session_and_the_in_process_session_answer_alike() {
    let d = TestDaemon::start("one-session");
    let mut client = d.client(CLIENT);
    let mut here = InProcess {
        state: SessionState::new(Arc::new(MeshCache::new(u64::MAX)), Limits::default()),
        renderer: SessionRenderer::new(),
    };
    let mut kinds = Vec::new();
    for request in requests() {
        let what = request.kind();
        let (remote, remote_progress) = through_daemon(&mut client, &request);
        let (local, local_progress) = here.answer(request);
        assert_eq!(
            untimed(&remote),
            untimed(&local),
            "{what}: the replies differ"
        );
        // Renders report their stages apart from the session; comparisons and trades per pass.
        if what != "Render" {
            assert_eq!(
                remote_progress, local_progress,
                "{what}: the progress differs"
            );
        }
        kinds.push(remote.kind());
    }
    // Each kind of answer was given, so the test compares what it names.
    for kind in [
        "Missing",
        "MeshStored",
        "FrameAccepted",
        "FrameResult",
        "CompareResult",
        "TradeResult",
        "Error",
    ] {
        assert!(kinds.contains(&kind), "no {kind} among {kinds:?}");
    }
    assert_eq!(
        kinds.iter().filter(|k| **k == "Error").count(),
        3,
        "{kinds:?}"
    );
}

/// A spool job renders with the same session logic: the files of each frame hold what a daemon
/// session answers for the same scene and settings, every plane bit for bit and the statistics
/// but the timings.
#[test]
fn a_spool_job_writes_what_a_daemon_session_renders() {
    let spool = common::temp_dir("one-session-spool");
    let d = TestDaemon::start_with("one-session-spool", |c| {
        c.spool = Some(spool.path().to_path_buf())
    });
    let settings = NamedSettings::new()
        .with("build", "sah")
        .with("order", "fbto")
        .with("spp", 2_i64);
    let scenes: Vec<_> = (1..=3).map(|f| tiny_scene(f, 24, 16)).collect();
    let spec = JobSpec {
        name: Some("shot".into()),
        settings: settings.clone(),
        ..JobSpec::default()
    };
    common::spool::submit(spool.path(), "job", &scenes, &spec);
    let mut client = d.client("shot");
    let replies: Vec<_> = scenes
        .iter()
        .map(|s| {
            client.send_scene(s).unwrap();
            let rendered = client.render(s.frame, settings.clone(), Passes::default(), 1);
            rendered.unwrap().result
        })
        .collect();
    let results = spool.path().join("results/job");
    common::spool::wait_for_file(&results.join(DONE_FILE));
    let m = common::spool::manifest(&results);
    assert_eq!(m.frames.len(), replies.len());
    for (f, reply) in m.frames.iter().zip(&replies) {
        assert_eq!(f.frame, reply.frame);
        let dir = results.join(&f.dir);
        let written = read_exr(&dir.join(format!("{}.exr", f.dir))).unwrap();
        let sent = planes_from_reply(reply).unwrap();
        assert_eq!(written.len(), sent.len(), "frame {}: planes", f.frame);
        for s in &sent {
            let w = written
                .iter()
                .find(|w| w.name == s.name)
                .expect("plane in the EXR");
            let bits = |d: &[f32]| d.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert!(
                bits(&w.data) == bits(&s.data),
                "frame {}: plane '{}'",
                f.frame,
                s.name
            );
        }
        // Both read back from JSON text, so both meet the same float parsing.
        let json = std::fs::read(dir.join("stats.json")).unwrap();
        let mut written: Value = serde_json::from_slice(&json).unwrap();
        let sent = serde_json::to_string(&stats_from_reply(reply)).unwrap();
        let mut sent: Value = serde_json::from_str(&sent).unwrap();
        zero_timings(&mut written);
        zero_timings(&mut sent);
        assert_eq!(written, sent, "frame {}: statistics", f.frame);
    }
}
