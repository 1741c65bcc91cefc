//! `Compare` through a real socket: one request renders a frame with every method, each
//! keeping its state across the session's frames, with the counters of core's own comparison;
//! bad methods are refused naming the setting.

mod common;

use antumbra_core::compare::{Comparison, MethodSpec};
use antumbra_core::stats::Cell;
use antumbra_protocol::client::{Blocking, Client};
use antumbra_protocol::{
    CompareMethod, CompareRequest, CompareRowState, ErrorCode, NamedSettings, Reply, Request,
};
use common::*;

const METHODS: [&str; 3] = [
    "base=build=sah,width=2,order=fbto",
    "sorted4=build=sah,width=4,order=sorted",
    "osah4=build=osah,visibility=previous,width=4,order=sorted",
];

fn request(frame: i32, request_id: u64) -> CompareRequest {
    CompareRequest {
        frame,
        request_id,
        settings: NamedSettings::new().with("spp", 2_i64),
        methods: METHODS
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
        repeat: 2,
        images: false,
    }
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
    let reply = c.call(&Request::Compare(request(1, 11))).unwrap();
    assert!(matches!(reply, Reply::CompareResult(r) if r.request_id == 11));
}
