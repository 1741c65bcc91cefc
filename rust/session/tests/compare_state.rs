//! [`CompareState`], the comparison a session keeps across `Compare` requests: kept while the
//! methods stay the same, rebuilt when they change, kept when refused, kept as before the
//! frame when a frame is cancelled; progress before the first method pass and after each.

#[path = "../../protocol/tests/common/mod.rs"]
mod common;

use antumbra_core::cancel::CancelToken;
use antumbra_core::compare::CompareRow;
use antumbra_core::stats::StatsRow;
use antumbra_protocol::{CompareMethod, CompareRequest, ErrorCode, NamedSettings, ProtocolError};
use antumbra_session::CompareState;
use common::tiny_scene;

fn request(frame: i32, repeat: u32) -> CompareRequest {
    let method = |label: &str, build: &str, visibility: &str| CompareMethod {
        label: label.into(),
        settings: NamedSettings::new()
            .with("build", build)
            .with("visibility", visibility)
            .with("width", 4_i64),
    };
    CompareRequest {
        frame,
        request_id: 100 + frame as u64,
        settings: NamedSettings::new().with("spp", 2_i64),
        methods: vec![
            method("sah4", "sah", "exact"),
            method("osah4", "osah", "previous"),
        ],
        baseline: None,
        repeat,
        images: false,
        warm_up: false,
    }
}

/// The rows without their timings, which differ from run to run.
fn counters(rows: Vec<CompareRow>) -> Vec<(String, StatsRow)> {
    rows.into_iter()
        .map(|r| {
            let stats = StatsRow {
                build_ms: 0.0,
                trace_ms: 0.0,
                mrays_per_s: 0.0,
                prepare_ms: 0.0,
                visibility_ms: 0.0,
                ..r.stats
            };
            (r.label, stats)
        })
        .collect()
}

fn compare(
    state: &mut CompareState,
    r: &CompareRequest,
) -> Result<Vec<(String, StatsRow)>, ProtocolError> {
    let reply = state.frame(
        r,
        "s",
        &tiny_scene(r.frame),
        &CancelToken::new(),
        &mut |_, _| {},
    )?;
    assert_eq!((reply.frame, reply.request_id), (r.frame, r.request_id));
    Ok(counters(reply.rows))
}

/// The rows of a fresh comparison of `r`'s methods over `frames`, the last one's returned.
fn fresh(r: &CompareRequest, frames: &[i32]) -> Vec<(String, StatsRow)> {
    let mut c = r.comparison().unwrap();
    let mut last = None;
    for &f in frames {
        let result = c.frame("s", &tiny_scene(f)).unwrap();
        last = Some(counters(
            result.methods.into_iter().flat_map(|m| m.rows).collect(),
        ));
    }
    last.unwrap()
}

#[test]
fn the_same_methods_keep_their_state_across_frames() {
    let mut state = CompareState::new();
    assert!(state.kept().is_none());
    compare(&mut state, &request(1, 1)).unwrap();
    let second = compare(&mut state, &request(2, 1)).unwrap();
    assert_eq!(second, fresh(&request(2, 1), &[1, 2]));
    // OSAH from the previous frame saw frame 1: not what a fresh comparison gives.
    assert_ne!(second, fresh(&request(2, 1), &[2]));
    assert_eq!(state.kept(), Some(&request(1, 1)));
}

#[test]
fn other_methods_start_afresh_and_refused_ones_keep_the_last() {
    let mut state = CompareState::new();
    compare(&mut state, &request(1, 1)).unwrap();
    // Another repeat is another comparison: frame 2 as if it were the first.
    let other = compare(&mut state, &request(2, 2)).unwrap();
    assert_eq!(other, fresh(&request(2, 2), &[2]));
    assert_eq!(state.kept().map(|r| r.repeat), Some(2));
    let mut bad = request(3, 2);
    bad.methods[1].settings = NamedSettings::new().with("widht", 4_i64);
    let e = compare(&mut state, &bad).unwrap_err();
    assert_eq!(e.code(), ErrorCode::InvalidInput);
    assert!(e.to_string().contains("widht"), "{e}");
    // A refused method set leaves the kept comparison: frame 3 follows frame 2.
    assert_eq!(state.kept(), Some(&request(2, 2)));
    assert_eq!(
        compare(&mut state, &request(3, 2)).unwrap(),
        fresh(&request(3, 2), &[2, 3])
    );
}

#[test]
fn a_cancelled_frame_keeps_the_comparison_as_before_it_with_progress() {
    let mut state = CompareState::new();
    compare(&mut state, &request(1, 1)).unwrap();
    let cancel = CancelToken::new();
    let token = cancel.clone();
    let mut seen = Vec::new();
    let e = state
        .frame(
            &request(2, 1),
            "s",
            &tiny_scene(2),
            &cancel,
            &mut |done, total| {
                seen.push((done, total));
                if done == 1 {
                    token.cancel();
                }
            },
        )
        .unwrap_err();
    assert_eq!(e.code(), ErrorCode::Cancelled, "{e}");
    // Two methods, one counted and one timed pass each; cancelled after the first.
    assert_eq!(seen, [(0, 4), (1, 4)]);
    assert_eq!(state.kept(), Some(&request(1, 1)));
    // Frame 3 follows frame 1, as if frame 2 had never been asked for.
    assert_eq!(
        compare(&mut state, &request(3, 1)).unwrap(),
        fresh(&request(3, 1), &[1, 3])
    );
    let mut seen = Vec::new();
    state
        .frame(
            &request(4, 1),
            "s",
            &tiny_scene(4),
            &CancelToken::new(),
            &mut |d, t| seen.push((d, t)),
        )
        .unwrap();
    assert_eq!(seen, [(0, 4), (1, 4), (2, 4), (3, 4), (4, 4)]);
}
