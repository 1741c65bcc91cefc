//! A comparison cancelled at any method pass ends with `Error::Cancelled` and leaves every
//! method's state as before the frame: the next frame's rows equal those of a comparison that
//! never saw the cancelled frame. Progress counts every method pass in order.

mod common;

use antumbra_core::cancel::CancelToken;
use antumbra_core::compare::{CompareRow, Comparison, MethodSpec};
use antumbra_core::scene::Scene;
use antumbra_core::settings::NamedSettings;
use antumbra_core::stats::StatsRow;
use antumbra_core::Error;
use glam::{DMat4, DVec3};

const METHODS: [&str; 3] = [
    "base=build=sah,width=2,order=fbto",
    "osah4=build=osah,visibility=previous,width=4,order=sorted",
    "sorted4=build=sah,width=4,order=sorted",
];
const REPEAT: usize = 2;

fn scene(frame: i32) -> Scene {
    let mut s = common::boxes_scene(48);
    s.frame = frame;
    // A box moves, so each frame has its own trees and visible set.
    s.objects[1].world_from_object =
        DMat4::from_translation(DVec3::new(0.3 * frame as f64, 0.0, 0.0))
            * s.objects[1].world_from_object;
    s
}

fn comparison() -> Comparison {
    let specs: Vec<MethodSpec> = METHODS.iter().map(|m| m.parse().unwrap()).collect();
    let common = NamedSettings::new().with("spp", 2_i64);
    Comparison::new(&specs, &common, None, REPEAT).unwrap()
}

/// The rows without their timings, which differ from run to run.
fn counters(rows: Vec<CompareRow>) -> Vec<(String, StatsRow)> {
    rows.into_iter()
        .map(|r| (r.label, r.stats.untimed()))
        .collect()
}

fn rows(c: &mut Comparison, frame: i32) -> Vec<(String, StatsRow)> {
    let result = c.frame("cmp", &scene(frame)).unwrap();
    counters(result.methods.into_iter().flat_map(|m| m.rows).collect())
}

#[test]
fn progress_counts_every_method_pass_in_order() {
    let mut c = comparison();
    let mut seen = Vec::new();
    c.frame_cancellable("cmp", &scene(1), &CancelToken::new(), &mut |s| {
        seen.push((s.label.to_string(), s.timed, s.done, s.total))
    })
    .unwrap();
    let total = METHODS.len() * (1 + REPEAT);
    assert_eq!(c.steps(), total);
    let labels = ["base", "osah4", "sorted4"];
    // The counted passes, then the timed ones interleaved across methods (A B C A B C).
    let want: Vec<_> = (0..1 + REPEAT)
        .flat_map(|round| labels.iter().map(move |l| (l.to_string(), round > 0)))
        .enumerate()
        .map(|(i, (l, timed))| (l, timed, i + 1, total))
        .collect();
    assert_eq!(seen, want);
}

#[test]
fn a_cancelled_frame_leaves_every_method_as_before_it() {
    let mut skipped = comparison();
    rows(&mut skipped, 1);
    let want = rows(&mut skipped, 3);
    for cancel_after in 0..comparison().steps() {
        let mut c = comparison();
        rows(&mut c, 1);
        let cancel = CancelToken::new();
        let token = cancel.clone();
        if cancel_after == 0 {
            cancel.cancel();
        }
        let result = c.frame_cancellable("cmp", &scene(2), &cancel, &mut |s| {
            if s.done == cancel_after {
                token.cancel();
            }
        });
        assert!(
            matches!(result, Err(Error::Cancelled)),
            "cancelled after {cancel_after} passes"
        );
        assert_eq!(
            rows(&mut c, 3),
            want,
            "cancelled after {cancel_after} passes"
        );
    }
}
