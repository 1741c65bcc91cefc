//! What a request may take of the daemon, through real sockets (issue 33): a `Compare`'s heat
//! images cost memory linear in its methods; a render slot is shared between method passes, so
//! another client's render finishes while a long comparison still runs; `Cancel` stops every
//! request in flight under its id.

mod common;

use std::time::{Duration, Instant};

use antumbra_protocol::client::Blocking;
use antumbra_protocol::{
    ErrorCode, Limits, NamedSettings, Passes, RenderRequest, Reply, Request, COMPARE_STAGE,
};
use common::*;

#[test]
fn compare_images_cost_memory_linear_in_the_methods() {
    // 300 methods at 64x48 with their heat images: before, each method's estimate counted
    // every method's heat plane (300 x 300 planes, 2.5 GiB); the run needs well under 1 GiB.
    let d = TestDaemon::start_with("admission-images", |c| {
        c.limits = Limits {
            max_render_bytes: 1 << 30,
            ..Limits::default()
        }
    });
    let mut c = d.client("images");
    c.set_timeout(Some(Duration::from_secs(300))).unwrap();
    c.send_scene(&tiny_scene(1, 64, 48)).unwrap();
    let methods: Vec<String> = (0..300).map(|i| format!("m{i}=width=2")).collect();
    let mut request = compare_request(&methods, 1, 1, 1, 1);
    request.images = true;
    let reply = c.compare(&mut Blocking, request, None).unwrap();
    assert_eq!(reply.heat.len(), 300);
}

/// A render of `frame` at `spp` samples (every pass).
fn render(frame: i32, request_id: u64, spp: i64) -> Request {
    Request::Render(RenderRequest {
        frame,
        settings: NamedSettings::new().with("spp", spp),
        passes: Passes::default(),
        request_id,
        warm_up: false,
    })
}

#[test]
fn cancel_stops_every_request_in_flight_under_its_id() {
    let d = TestDaemon::start("admission-ids");
    let mut c = d.client("ids");
    c.set_timeout(Some(Duration::from_secs(120))).unwrap();
    let mut city = city_frames(60_000, 1, 1024, 1024).remove(0);
    city.frame = 2;
    c.send_scene(&city).unwrap();
    // Two renders under one id: the first running, the second queued behind it.
    c.send(&render(2, 7, 16)).unwrap();
    c.send(&render(2, 7, 16)).unwrap();
    loop {
        match c.recv().unwrap() {
            Reply::Progress { stage, .. } if stage == "render" => break,
            Reply::Progress { .. } => {}
            other => panic!("expected the render's progress, got {}", other.kind()),
        }
    }
    c.send(&Request::Cancel { request_id: 7 }).unwrap();
    let (mut acked, mut cancelled) = (false, 0);
    while !(acked && cancelled == 2) {
        match c.recv().unwrap() {
            Reply::Ack => acked = true,
            Reply::Progress { .. } => {}
            other => {
                let kind = other.kind();
                let (code, m, _, id) = match other {
                    Reply::Error { .. } => expect_error(other),
                    _ => panic!("expected both renders under id 7 cancelled, got a {kind}"),
                };
                assert_eq!((code, id), (ErrorCode::Cancelled, Some(7)), "{m}");
                cancelled += 1;
            }
        }
    }
    assert_eq!(d.handle.stats().renders_cancelled, 2);
}

#[test]
fn a_render_finishes_while_another_clients_long_compare_runs() {
    // One render slot, held by a comparison of many seconds; a render from another client
    // gets the slot between two of its method passes and finishes first.
    let d = TestDaemon::start_with("admission-fair", |c| c.max_renders = 1);
    let mut long = d.client("long-compare");
    long.set_timeout(Some(Duration::from_secs(300))).unwrap();
    let city = city_frames(60_000, 1, 512, 512).remove(0);
    long.send_scene(&city).unwrap();
    let methods: Vec<String> = ["base=build=sah,width=2,order=fbto", "sah4=width=4"]
        .iter()
        .map(|m| m.to_string())
        .collect();
    let mut request = compare_request(&methods, city.frame, 1, 16, 1);
    request.repeat = 10;
    long.send(&Request::Compare(request)).unwrap();
    let total = loop {
        match long.recv().unwrap() {
            Reply::Progress {
                stage, done, total, ..
            } if stage == COMPARE_STAGE && done >= 1 => break total,
            Reply::Progress { .. } => {}
            other => panic!("expected the comparison's progress, got {}", other.kind()),
        }
    };
    let mut other = d.client("render");
    other.send_scene(&tiny_scene(1, 32, 24)).unwrap();
    let t0 = Instant::now();
    other
        .render(1, NamedSettings::new(), Passes::default(), 5)
        .unwrap();
    let waited = t0.elapsed();
    // The comparison is still running: cancelling it now ends it as cancelled.
    long.send(&Request::Cancel { request_id: 1 }).unwrap();
    let mut last_done = 0;
    let (mut acked, mut ended) = (false, None);
    while !(acked && ended.is_some()) {
        match long.recv().unwrap() {
            Reply::Ack => acked = true,
            Reply::Progress {
                stage, done, total, ..
            } if stage == COMPARE_STAGE => {
                assert!(
                    done < total,
                    "the comparison finished ({total} passes) before the other client's \
                     render (which waited {waited:?})"
                );
                last_done = done;
            }
            Reply::Progress { .. } => {}
            Reply::CompareResult(_) => panic!(
                "the comparison ({total} passes) finished before the other client's render \
                 (which waited {waited:?})"
            ),
            other => ended = Some(expect_error(other)),
        }
    }
    let (code, message, _, id) = ended.unwrap();
    assert_eq!((code, id), (ErrorCode::Cancelled, Some(1)), "{message}");
    assert!(last_done < total, "{last_done} of {total}");
}
