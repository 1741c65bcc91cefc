//! Cancel that cancels: a running render stops within a tile and frees its render slot, a
//! closed connection cancels its render, a queued render hears its place and has a deadline,
//! and a cancelled render leaves the session's renderer as a fresh one.

mod common;

use std::time::Duration;

use antumbra_core::render::RenderSettings;
use antumbra_core::scene::Scene;
use antumbra_protocol::client::Client;
use antumbra_protocol::{ErrorCode, NamedSettings, Passes, RenderRequest, Reply, Request};
use common::*;

/// What a client may wait for a reply once the daemon should answer promptly: far above the
/// fixed daemon's answer (well under a second), far below the 1024 spp render (minutes).
const PROMPT: Duration = Duration::from_secs(30);

/// A frame that renders for minutes: the city at 1024 x 1024 with 1024 samples per pixel.
fn long_scene() -> Scene {
    city_frames(60_000, 1, 1024, 1024).remove(0)
}

fn render_request(frame: i32, spp: i64, request_id: u64) -> Request {
    Request::Render(RenderRequest {
        frame,
        settings: NamedSettings::new().with("spp", spp),
        passes: Passes::default(),
        request_id,
        warm_up: false,
    })
}

/// Sends `scene` and a 1024 spp render of it; returns once the render holds a slot and runs.
fn start_long_render(c: &mut Client, scene: &Scene, request_id: u64) {
    c.send_scene(scene).unwrap();
    c.send(&render_request(scene.frame, 1024, request_id))
        .unwrap();
    loop {
        match c.recv().unwrap() {
            Reply::Progress {
                request_id: id,
                stage,
                ..
            } if id == request_id && stage == "render" => break,
            Reply::Progress { stage, .. } if stage == "queued" => {}
            other => panic!("expected the render to start, got {other:?}"),
        }
    }
    // Let it get into its passes (the test holds whether or not it has).
    std::thread::sleep(Duration::from_millis(500));
}

/// Sends Cancel and reads its Ack and the render's `Cancelled` end (in either order) within
/// [`PROMPT`] each; returns the `Cancelled` message.
fn cancel(c: &mut Client, request_id: u64) -> String {
    c.set_timeout(Some(PROMPT)).unwrap();
    c.send(&Request::Cancel { request_id }).unwrap();
    let (mut acked, mut message) = (false, None);
    while !(acked && message.is_some()) {
        match c.recv() {
            Ok(Reply::Ack) => acked = true,
            Ok(Reply::Error {
                code: ErrorCode::Cancelled,
                request_id: Some(id),
                session_usable: true,
                message: m,
            }) if id == request_id => message = Some(m),
            Ok(Reply::Progress { .. }) => {}
            other => {
                panic!("cancel of render {request_id}: expected Ack and Cancelled, got {other:?}")
            }
        }
    }
    message.unwrap()
}

/// Renders a small frame on a new client, each reply within [`PROMPT`].
fn small_render_is_prompt(d: &TestDaemon, name: &str) {
    let mut c = d.client(name);
    c.set_timeout(Some(PROMPT)).unwrap();
    let s = tiny_scene(1, 32, 24);
    c.send_scene(&s).unwrap();
    let reply = render_reply(&mut c, 1, 77);
    let want = render_in_process(name, std::slice::from_ref(&s), &RenderSettings::default());
    assert_same_result(&reply, &want[0]);
}

#[test]
fn two_cancelled_renders_free_both_slots_for_a_third_client() {
    let d = TestDaemon::start_with("cancel-two", |c| c.max_renders = 2);
    let scene = long_scene();
    let mut a = d.client("a");
    let mut b = d.client("b");
    start_long_render(&mut a, &scene, 1);
    start_long_render(&mut b, &scene, 2);
    let ma = cancel(&mut a, 1);
    let mb = cancel(&mut b, 2);
    for m in [&ma, &mb] {
        assert!(m.contains("cancelled by the client"), "{m}");
        assert!(m.contains("render slot is free"), "{m}");
    }
    small_render_is_prompt(&d, "third");
    let s = d.handle.stats();
    assert_eq!(s.renders_cancelled, 2, "{s:?}");
    // The cancelled sessions go on.
    small_render_is_prompt(&d, "fourth");
    a.set_timeout(Some(PROMPT)).unwrap();
    a.send_scene(&tiny_scene(2, 16, 12)).unwrap();
    render_reply(&mut a, 2, 3);
}

#[test]
fn a_closed_connection_cancels_its_render_and_frees_its_slot() {
    let d = TestDaemon::start_with("cancel-gone", |c| c.max_renders = 1);
    let scene = long_scene();
    let mut a = d.client("leaver");
    start_long_render(&mut a, &scene, 1);
    drop(a);
    small_render_is_prompt(&d, "next");
    d.wait_for_stats("the abandoned render to be counted", |s| {
        s.renders_cancelled == 1 && s.sessions == 0
    });
}

#[test]
fn a_cancelled_render_leaves_the_renderer_as_a_fresh_one() {
    let d = TestDaemon::start("cancel-fresh");
    let scene = long_scene();
    let mut c = d.client("again");
    start_long_render(&mut c, &scene, 1);
    cancel(&mut c, 1);
    // The same frame again (fewer samples, same trees): bit for bit a fresh renderer's frame,
    // statistics included (a tree the cancelled render built reads as built by this one).
    c.send(&render_request(scene.frame, 1, 2)).unwrap();
    let reply = c.finish_render(2).unwrap().result;
    let settings = RenderSettings {
        spp: 1,
        ..RenderSettings::default()
    };
    let want = render_in_process("again", std::slice::from_ref(&scene), &settings);
    assert_same_result(&reply, &want[0]);
}

/// The next `queued` progress of render `request_id`, skipping repeats of `previous`.
fn next_position(c: &mut Client, request_id: u64, previous: Option<u32>) -> u32 {
    loop {
        match c.recv().unwrap() {
            Reply::Progress {
                request_id: id,
                stage,
                total,
                ..
            } if id == request_id && stage == "queued" => {
                if Some(total) != previous {
                    return total;
                }
            }
            other => panic!("render {request_id}: expected a queued progress, got {other:?}"),
        }
    }
}

#[test]
fn a_queued_render_hears_its_place_and_gives_up_at_its_deadline() {
    let wait = Duration::from_secs(8);
    let d = TestDaemon::start_with("cancel-queue", |c| {
        c.max_renders = 1;
        c.queue_wait = wait;
    });
    let scene = long_scene();
    let mut a = d.client("holder");
    start_long_render(&mut a, &scene, 1);
    let small = tiny_scene(1, 16, 12);
    let mut b = d.client("second");
    let mut c = d.client("third");
    for cl in [&mut b, &mut c] {
        cl.set_timeout(Some(PROMPT)).unwrap();
        cl.send_scene(&small).unwrap();
    }
    b.send(&render_request(1, 1, 21)).unwrap();
    assert_eq!(next_position(&mut b, 21, None), 1);
    c.send(&render_request(1, 1, 31)).unwrap();
    assert_eq!(next_position(&mut c, 31, None), 2);
    // The one ahead leaves the queue: the third client moves up.
    cancel(&mut b, 21);
    assert_eq!(next_position(&mut c, 31, Some(2)), 1);
    // Its wait ends at the deadline with Busy, its place and how long it waited.
    let (code, message, usable, id) = loop {
        match c.recv().unwrap() {
            Reply::Progress { .. } => {}
            other => break expect_error(other),
        }
    };
    assert_eq!((code, usable, id), (ErrorCode::Busy, true, Some(31)));
    assert!(message.contains("place 1 in the queue"), "{message}");
    assert!(message.contains("after waiting"), "{message}");
    cancel(&mut a, 1);
    // Now it renders.
    c.send(&render_request(1, 1, 32)).unwrap();
    c.finish_render(32).unwrap();
}
