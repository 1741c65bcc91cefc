//! Warm-ups over a real socket (`RenderRequest::warm_up`, `CompareRequest::warm_up`): a session
//! that warms up on the two frames before a chunk renders the chunk's frames as a session that
//! rendered every frame does (images bit for bit, statistics rows but times, `rebuilt` too), and
//! a warm-up's reply carries no image and no row.

mod common;

use antumbra_core::compare::MethodSpec;
use antumbra_core::scene::Scene;
use antumbra_protocol::client::{Blocking, Client};
use antumbra_protocol::{
    planes_from_reply, stats_from_reply, CompareMethod, CompareRequest, FrameResultReply,
    NamedSettings, Passes,
};
use common::*;

const FRAMES: usize = 8;

/// City frames whose frames 3-6 are frame 3 again (nothing moves): one session reuses its trees
/// at frame 5, the first of a chunk.
fn frames() -> Vec<Scene> {
    let mut scenes = city_frames(4_000, FRAMES as i32, 48, 32);
    for i in 4..=6 {
        scenes[i] = scenes[3].clone();
    }
    // Frame numbers from 0, so that a frame is its index.
    for (i, s) in scenes.iter_mut().enumerate() {
        s.frame = i as i32;
    }
    scenes
}

fn settings() -> NamedSettings {
    NamedSettings::new()
        .with("build", "osah")
        .with("visibility", "previous")
        .with("width", 8_i64)
        .with("order", "sorted")
        .with("spp", 2_i64)
}

/// Every image and the visible set.
fn passes() -> Passes {
    Passes {
        visible_set: true,
        ..Passes::default()
    }
}

fn render(c: &mut Client, s: &Scene, id: u64) -> FrameResultReply {
    c.send_scene(s).unwrap();
    c.render(s.frame, settings(), passes(), id).unwrap().result
}

/// Images as bits, and rows with their times zeroed.
fn content(r: &FrameResultReply) -> (Vec<(String, Vec<u32>)>, Vec<antumbra_core::stats::StatsRow>) {
    let planes = planes_from_reply(r).unwrap();
    let images = planes
        .iter()
        .map(|p| (p.name.clone(), p.data.iter().map(|v| v.to_bits()).collect()))
        .collect();
    let rows = stats_from_reply(r)
        .into_iter()
        .map(|row| row.untimed())
        .collect();
    (images, rows)
}

#[test]
fn a_chunk_after_two_warm_ups_renders_what_one_session_renders() {
    let d = TestDaemon::start("warmup");
    let scenes = frames();
    let mut one = d.client("warmup");
    let run: Vec<FrameResultReply> = scenes
        .iter()
        .enumerate()
        .map(|(i, s)| render(&mut one, s, i as u64))
        .collect();
    one.close().unwrap();
    // The test means something: the session reused its trees at frame 5 and rebuilt at 7.
    assert!(stats_from_reply(&run[5]).iter().all(|r| !r.rebuilt));
    assert!(stats_from_reply(&run[7]).iter().any(|r| r.rebuilt));

    // The label names the statistics rows' scene: the same client name.
    let mut chunk = d.client("warmup");
    for s in &scenes[3..5] {
        chunk.send_scene(s).unwrap();
        let w = chunk.warm_up(s.frame, settings(), passes(), 100).unwrap();
        assert_eq!(w.stages, vec!["render", "encode"]);
        let w = w.result;
        assert!(
            w.images.is_empty() && w.stats.is_empty(),
            "frame {}",
            s.frame
        );
        assert_eq!((w.width, w.height), (48, 32));
        assert!(w.visible.as_ref().is_some_and(|v| !v.is_empty()));
        assert_eq!(
            w.visible, run[s.frame as usize].visible,
            "frame {}",
            s.frame
        );
    }
    for (i, s) in scenes.iter().enumerate().skip(5) {
        let r = render(&mut chunk, s, 200 + i as u64);
        assert_eq!(content(&r), content(&run[i]), "frame {}", s.frame);
        assert_eq!(r.visible, run[i].visible);
    }
    chunk.close().unwrap();

    // Without the warm-ups, frame 5 differs (its trees are built afresh).
    let mut cold = d.client("warmup");
    let r = render(&mut cold, &scenes[5], 300);
    assert_ne!(content(&r).1, content(&run[5]).1);
    cold.close().unwrap();
}

fn compare_request(frame: i32, request_id: u64, warm_up: bool) -> CompareRequest {
    let methods = [
        "sah=build=sah,width=2,order=fbto",
        "osah=build=osah,width=4,order=sorted",
    ];
    CompareRequest {
        frame,
        request_id,
        settings: NamedSettings::new().with("spp", 2_i64),
        methods: methods
            .iter()
            .map(|m| {
                let spec: MethodSpec = m.parse().unwrap();
                CompareMethod {
                    label: spec.label,
                    settings: spec.settings,
                }
            })
            .collect(),
        baseline: None,
        repeat: 1,
        images: false,
        warm_up,
    }
}

#[test]
fn a_comparison_warms_up_every_method() {
    let d = TestDaemon::start("warmcmp");
    let scenes = frames();
    let counters = |c: &mut Client, s: &Scene, id: u64| {
        c.send_scene(s).unwrap();
        let reply = c
            .compare(&mut Blocking, compare_request(s.frame, id, false), None)
            .unwrap();
        assert!(reply.mismatches.is_empty());
        let rows = reply.rows.into_iter().map(|r| (r.label, r.stats.untimed()));
        rows.collect::<Vec<_>>()
    };
    let mut one = d.client("warmcmp");
    let run: Vec<_> = scenes
        .iter()
        .enumerate()
        .map(|(i, s)| counters(&mut one, s, i as u64))
        .collect();
    one.close().unwrap();
    assert!(run[5].iter().all(|(_, r)| !r.rebuilt));

    let mut chunk = d.client("warmcmp");
    for s in &scenes[3..5] {
        chunk.send_scene(s).unwrap();
        let w = chunk
            .compare(&mut Blocking, compare_request(s.frame, 50, true), None)
            .unwrap();
        assert!(w.rows.is_empty() && w.mismatches.is_empty() && w.heat.is_empty());
        assert_eq!(w.methods.len(), 2);
    }
    for (i, s) in scenes.iter().enumerate().skip(5) {
        assert_eq!(
            counters(&mut chunk, s, 60 + i as u64),
            run[i],
            "frame {}",
            s.frame
        );
    }
    chunk.close().unwrap();
}
