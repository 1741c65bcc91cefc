//! `Compare` through a real socket: one request renders a frame with every method, each
//! keeping its state across the session's frames, with the counters of core's own comparison;
//! bad methods are refused naming the setting; progress per method pass; a cancelled
//! comparison answers `Cancelled` and the session's next frame goes on from the frame before;
//! the memory budget bounds every method together.

mod common;

use std::time::Duration;

use antumbra_core::compare::{Comparison, MethodSpec};
use antumbra_core::render::{all_output_planes, estimate_comparison_bytes, estimate_render_bytes};
use antumbra_core::stats::Cell;
use antumbra_protocol::client::{Blocking, Client};
use antumbra_protocol::{
    CompareRequest, CompareRowState, ErrorCode, Limits, NamedSettings, Passes, RenderRequest,
    Reply, Request, COMPARE_STAGE,
};
use common::*;

const METHODS: [&str; 3] = [
    "base=build=sah,width=2,order=fbto",
    "sorted4=build=sah,width=4,order=sorted",
    "osah4=build=osah,visibility=previous,width=4,order=sorted",
];

fn request(frame: i32, request_id: u64) -> CompareRequest {
    compare_request(&METHODS, frame, request_id, 2, 2)
}

/// A row's cells but the times, which differ from run to run.
fn counters(r: &CompareRowState) -> Vec<(String, String)> {
    r.stats
        .cells()
        .into_iter()
        .filter(|(n, _)| !n.ends_with("_ms") && *n != "mrays_per_s")
        .map(|(n, c)| {
            let text = match c {
                Cell::Text(t) => t.to_string(),
                Cell::Int(i) => i.to_string(),
                Cell::Count(n) => n.to_string(),
                Cell::Flag(b) => b.to_string(),
                Cell::Real(x) => format!("{:?}", x.to_bits()),
            };
            (n.to_string(), text)
        })
        .collect()
}

fn renders_done(c: &mut Client) -> u64 {
    c.stats(&mut Blocking).unwrap().renders_done
}

#[test]
fn compare_equals_core_comparison_over_frames() {
    let d = TestDaemon::start("compare");
    let mut c = d.client("compare");
    let req = request(1, 0);
    let mut local = Comparison::new(
        &req.specs().unwrap(),
        &req.settings,
        None,
        req.repeat as usize,
    )
    .unwrap();
    for frame in 1..=3 {
        let scene = tiny_scene(frame, 32, 20);
        let sent = c.send_scene(&scene).unwrap();
        assert_eq!(sent.meshes_uploaded, if frame == 1 { 2 } else { 0 });
        let before = renders_done(&mut c);
        let reply = c
            .compare(&mut Blocking, request(frame, 10 + frame as u64), None)
            .unwrap();
        assert_eq!(
            renders_done(&mut c),
            before + 1,
            "one request for every method"
        );
        assert_eq!(reply.frame, frame);
        // Settings come back in name order; the methods parse to the same ones.
        let parsed: Vec<MethodSpec> = reply.methods.iter().map(|m| m.parse().unwrap()).collect();
        let given: Vec<MethodSpec> = METHODS.iter().map(|m| m.parse().unwrap()).collect();
        assert_eq!(parsed, given);
        assert!(reply.mismatches.is_empty(), "{:?}", reply.mismatches);
        let expected = local.frame("compare", &scene).unwrap();
        let expected: Vec<CompareRowState> =
            expected.methods.into_iter().flat_map(|m| m.rows).collect();
        assert_eq!(reply.rows.len(), expected.len());
        for (got, want) in reply.rows.iter().zip(&expected) {
            assert_eq!(got.label, want.label);
            assert_eq!(counters(got), counters(want), "frame {frame} {}", got.label);
        }
    }
}

#[test]
fn bad_methods_are_refused_naming_the_setting() {
    let d = TestDaemon::start("compare-bad");
    let mut c = d.client("compare-bad");
    c.send_scene(&tiny_scene(1, 16, 12)).unwrap();
    let mut bad = request(1, 7);
    bad.methods[1].settings = NamedSettings::new().with("widht", 2_i64);
    c.send(&Request::Compare(bad)).unwrap();
    let (code, message, usable, id) = expect_error(c.recv().unwrap());
    assert_eq!(code, ErrorCode::InvalidInput);
    assert!(
        message.contains("widht") && message.contains("sorted4"),
        "{message}"
    );
    assert!(usable);
    assert_eq!(id, Some(7));
    let mut bad = request(1, 8);
    bad.baseline = Some("nope".into());
    c.send(&Request::Compare(bad)).unwrap();
    let (_, message, _, _) = expect_error(c.recv().unwrap());
    assert!(message.contains("'nope'"), "{message}");
    let mut bad = request(2, 9);
    bad.repeat = 1000;
    c.send(&Request::Compare(bad)).unwrap();
    let (code, message, _, id) = expect_error(c.recv().unwrap());
    assert_eq!(code, ErrorCode::LimitExceeded);
    assert!(message.contains("repeat"), "{message}");
    assert_eq!(id, Some(9));
    // The session goes on.
    let reply = c.compare(&mut Blocking, request(1, 11), None).unwrap();
    assert_eq!(reply.request_id, 11);
}

/// The counters of every row of `rows`.
fn all_counters(rows: &[CompareRowState]) -> Vec<(String, Vec<(String, String)>)> {
    rows.iter()
        .map(|r| (r.label.clone(), counters(r)))
        .collect()
}

#[test]
fn progress_counts_every_method_pass() {
    let d = TestDaemon::start("compare-progress");
    let mut c = d.client("progress");
    c.send_scene(&tiny_scene(1, 24, 16)).unwrap();
    let mut seen = Vec::new();
    let reply = c
        .compare_with(
            &mut Blocking,
            request(1, 5),
            None,
            |_, stage, done, total| {
                seen.push((stage.to_string(), done, total));
                Ok(true)
            },
        )
        .unwrap();
    assert_eq!(reply.request_id, 5);
    // Three methods, one counted and two timed passes each.
    let want: Vec<_> = (0..=9).map(|i| (COMPARE_STAGE.to_string(), i, 9)).collect();
    assert_eq!(seen, want);
}

/// OSAH from the previous frame first, so that a method that kept the cancelled frame's
/// state would build frame 3 from frame 2's visible set.
const CANCEL_METHODS: [&str; 3] = [
    "osah4=build=osah,visibility=previous,width=4,order=sorted",
    "base=build=sah,width=2,order=fbto",
    "sorted4=build=sah,width=4,order=sorted",
];

#[test]
fn a_cancelled_comparison_answers_cancelled_and_the_next_frame_goes_on() {
    let d = TestDaemon::start("compare-cancel");
    let mut c = d.client("cancel");
    c.set_timeout(Some(Duration::from_secs(120))).unwrap();
    let ask = |frame, id| {
        let mut r = compare_request(&CANCEL_METHODS, frame, id, 16, 2);
        r.baseline = Some("base".into());
        r
    };
    let tiny = |frame| tiny_scene(frame, 32, 20);
    c.send_scene(&tiny(1)).unwrap();
    let first = c.compare(&mut Blocking, ask(1, 1), None).unwrap();
    // Frame 2 is a city at 1024 x 1024 with 16 samples: seconds per method pass.
    let mut city = city_frames(60_000, 1, 1024, 1024).remove(0);
    city.frame = 2;
    c.send_scene(&city).unwrap();
    c.send(&Request::Compare(ask(2, 2))).unwrap();
    // Cancel once the first method pass is done: mid-way through the nine.
    loop {
        match c.recv().unwrap() {
            Reply::Progress {
                request_id: 2,
                stage,
                done,
                total,
            } if stage == COMPARE_STAGE => {
                assert_eq!(total, 9);
                if done == 1 {
                    break;
                }
            }
            other => panic!("expected the comparison's progress, got {other:?}"),
        }
    }
    c.send(&Request::Cancel { request_id: 2 }).unwrap();
    let (mut acked, mut message) = (false, None);
    while !(acked && message.is_some()) {
        match c.recv().unwrap() {
            Reply::Ack => acked = true,
            Reply::Progress { .. } => {}
            other => {
                let (code, m, usable, id) = expect_error(other);
                assert_eq!(
                    (code, usable, id),
                    (ErrorCode::Cancelled, true, Some(2)),
                    "{m}"
                );
                message = Some(m);
            }
        }
    }
    let message = message.unwrap();
    assert!(message.contains("Compare frame 2"), "{message}");
    assert!(message.contains("cancelled by the client"), "{message}");
    assert!(message.contains("render slot is free"), "{message}");
    assert_eq!(d.handle.stats().renders_cancelled, 1);
    // Frame 3 follows frame 1 in every method, as if frame 2 had never been asked for.
    c.send_scene(&tiny(3)).unwrap();
    let third = c.compare(&mut Blocking, ask(3, 3), None).unwrap();
    let mut local = ask(1, 0).comparison().unwrap();
    let mut rows = |frame: i32| {
        let r = local.frame("cancel", &tiny(frame)).unwrap();
        r.methods
            .into_iter()
            .flat_map(|m| m.rows)
            .collect::<Vec<_>>()
    };
    assert_eq!(all_counters(&first.rows), all_counters(&rows(1)));
    assert_eq!(all_counters(&third.rows), all_counters(&rows(3)));
    assert!(third.mismatches.is_empty(), "{:?}", third.mismatches);
}

#[test]
fn the_memory_budget_bounds_every_method_together() {
    let scene = city_frames(20_000, 1, 64, 48).remove(0);
    let req = request(scene.frame, 4);
    let comparison = req.comparison().unwrap();
    let methods = comparison.settings();
    let alone = methods
        .iter()
        .map(|s| estimate_render_bytes(&scene, s, all_output_planes(&scene, s)).total())
        .max()
        .unwrap();
    let together = estimate_comparison_bytes(&scene, &methods, 0).total();
    // A budget every method fits alone, and their comparison does not.
    let budget = alone + (together - alone) / 2;
    assert!(alone < budget && budget < together);
    let d = TestDaemon::start_with("compare-memory", |c| {
        c.limits = Limits {
            max_render_bytes: budget,
            ..Limits::default()
        }
    });
    let mut c = d.client("memory");
    c.send_scene(&scene).unwrap();
    c.send(&Request::Compare(req)).unwrap();
    let (code, message, usable, id) = expect_error(c.recv().unwrap());
    assert_eq!(
        (code, usable, id),
        (ErrorCode::LimitExceeded, true, Some(4))
    );
    assert!(message.contains("comparing 3 methods"), "{message}");
    assert!(message.contains("max_render_bytes"), "{message}");
    // Each method alone renders within the budget.
    for (i, m) in METHODS.iter().enumerate() {
        let spec: MethodSpec = m.parse().unwrap();
        c.send(&Request::Render(RenderRequest {
            frame: scene.frame,
            settings: spec.settings.with("spp", 2_i64),
            passes: Passes::default(),
            request_id: 10 + i as u64,
            warm_up: false,
        }))
        .unwrap();
        c.finish_render(10 + i as u64).unwrap();
    }
}
