//! A warm-up (primary pass and trees, no shadow rays) of the two frames before a chunk leaves the
//! renderer as one run over the animation would: the chunk's frames then give the same images
//! and statistics rows (times aside, `rebuilt` included) as that run, for every build, width
//! and order whose state carries across frames; and the warm-up traces no shadow ray. (VSAH is
//! left out: its camera tree holds only the triangles it was built from, so its visible set
//! depends on every frame before, and no warm-up of two frames repeats that history.)

mod common;

use antumbra_core::render::{FrameResult, RenderSettings, Renderer, StatsMode};
use antumbra_core::scene::{Camera, Scene};
use antumbra_core::stats::StatsRow;
use std::sync::OnceLock;

use glam::{DMat4, DVec3};

const FRAMES: i32 = 9;

/// Frame `f`: the camera moves over frames 0-2, holds still over 2-6 (one run reuses its trees
/// from frame 4 on, where the visible set stops changing) and moves on; box 1 slides after 6.
/// Every frame shares the meshes (the same `Arc`s), as a session's frames do.
fn frame(f: i32) -> Scene {
    static BASE: OnceLock<Scene> = OnceLock::new();
    let mut s = BASE.get_or_init(|| common::boxes_scene(40)).clone();
    s.frame = f;
    let a = f.min(2) as f64 + (f - 6).max(0) as f64 * 0.7;
    s.camera = Camera::look_at(
        DVec3::new(12.0 - a, -14.0 + 0.5 * a, 10.0),
        DVec3::ZERO,
        DVec3::Z,
    );
    let slide = (f - 6).max(0) as f64 * 0.3;
    s.objects[2].world_from_object =
        DMat4::from_translation(DVec3::new(slide, 0.0, 0.0)) * s.objects[2].world_from_object;
    s
}

fn settings(build: &str, visibility: &str, width: &str, order: &str) -> RenderSettings {
    RenderSettings {
        build: build.parse().unwrap(),
        visibility: visibility.parse().unwrap(),
        width: width.parse().unwrap(),
        shadow_order: order.parse().unwrap(),
        stats: StatsMode::CountsAndTiming,
        ..RenderSettings::baseline()
    }
}

fn assert_same(a: &FrameResult, b: &FrameResult, what: &str) {
    let f = a.frame;
    assert_eq!(a.masks.len(), b.masks.len(), "{what} frame {f}");
    for (x, y) in a.masks.iter().zip(&b.masks) {
        assert_eq!(x.data, y.data, "{what} frame {f}: mask {}", x.name);
    }
    let heat = |r: &FrameResult| {
        let h = r.heat.as_ref().expect("counted");
        h.primary
            .iter()
            .chain(&h.shadow)
            .map(|p| p.data.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(heat(a), heat(b), "{what} frame {f}: heat maps");
    assert_eq!(a.primary_hits, b.primary_hits, "{what} frame {f}");
    assert_eq!(a.visible, b.visible, "{what} frame {f}");
    let rows = |r: &FrameResult| r.stats.iter().map(StatsRow::untimed).collect::<Vec<_>>();
    assert_eq!(rows(a), rows(b), "{what} frame {f}: statistics rows");
}

#[test]
fn a_chunk_after_two_warm_ups_renders_what_one_run_renders() {
    let methods = [
        settings("osah", "previous", "2", "fbto"),
        settings("osah", "previous", "8", "sorted"),
        settings("abvh", "prepass:16x12", "4", "sato"),
        settings("sbvh", "previous", "8", "random"),
        settings("osah", "exact", "2", "srdh"),
        settings("sah", "previous", "4", "rtsah"),
    ];
    for s in &methods {
        let what = format!("{} {}", s.method_name(), s.visibility.name());
        let mut one_run = Renderer::new();
        let run: Vec<FrameResult> = (0..FRAMES)
            .map(|f| one_run.render("t", &frame(f), s).unwrap())
            .collect();
        // The test means something: one run reuses trees at a chunk's first frame (4), and
        // rebuilds at another (7).
        assert!(run[4].stats.iter().all(|r| !r.rebuilt), "{what}");
        assert!(run[7].stats.iter().any(|r| r.rebuilt), "{what}");
        for start in [2, 4, 7] {
            let mut chunk = Renderer::new();
            for f in start - 2..start {
                let w = chunk.warm_up(&frame(f), s).unwrap();
                assert_eq!(w.visible, run[f as usize].visible, "{what} warm-up {f}");
                assert_eq!(
                    chunk.shadow_rays, 0,
                    "{what}: a warm-up traces no shadow ray"
                );
            }
            for f in start..FRAMES {
                let r = chunk.render("t", &frame(f), s).unwrap();
                assert_same(&r, &run[f as usize], &format!("{what}, chunk from {start}"));
            }
            assert!(chunk.shadow_rays > 0, "{what}: {}", chunk.shadow_rays);
        }
    }
}

#[test]
fn without_the_warm_up_a_chunk_differs() {
    // The counterpart that shows the test above could fail: a chunk from frame 4 with one
    // warm-up (or none) reports a rebuild where one run reuses its trees, or other work.
    let s = settings("osah", "previous", "2", "fbto");
    let mut one_run = Renderer::new();
    let run: Vec<FrameResult> = (0..5)
        .map(|f| one_run.render("t", &frame(f), &s).unwrap())
        .collect();
    let mut cold = Renderer::new();
    let r = cold.render("t", &frame(4), &s).unwrap();
    assert_ne!(
        r.stats.iter().map(StatsRow::untimed).collect::<Vec<_>>(),
        run[4]
            .stats
            .iter()
            .map(StatsRow::untimed)
            .collect::<Vec<_>>()
    );
    let mut once = Renderer::new();
    once.warm_up(&frame(3), &s).unwrap();
    let r = once.render("t", &frame(4), &s).unwrap();
    assert!(r.stats.iter().all(|r| r.rebuilt));
    assert!(run[4].stats.iter().all(|r| !r.rebuilt));
}

#[test]
fn a_warm_up_traces_no_shadow_ray_and_a_render_counts_its_own() {
    let s = settings("osah", "previous", "2", "fbto");
    let mut r = Renderer::new();
    r.warm_up(&frame(0), &s).unwrap();
    assert_eq!((r.shadow_rays, r.builds), (0, 1));
    let done = r.render("t", &frame(1), &s).unwrap();
    let counted: u64 = done.stats[1..].iter().map(|row| row.rays).sum();
    // Counted and timed: every shadow ray twice.
    assert!(counted > 0);
    assert_eq!(r.shadow_rays, 2 * counted);
}

#[test]
fn a_comparison_warms_up_every_method() {
    use antumbra_core::compare::{Comparison, MethodSpec};
    let specs: Vec<MethodSpec> = [
        "sah=build=sah,width=2,order=fbto",
        "osah=build=osah,width=8,order=sorted",
    ]
    .iter()
    .map(|s| s.parse().unwrap())
    .collect();
    let new = || Comparison::new(&specs, &Default::default(), None, 1).unwrap();
    let rows = |c: &mut Comparison, f: i32| {
        let done = c.frame("t", &frame(f)).unwrap();
        assert!(done.mismatches.is_empty());
        let rows = done.methods.iter().flat_map(|m| &m.rows);
        rows.map(|r| (r.label.clone(), StatsRow::untimed(&r.stats)))
            .collect::<Vec<_>>()
    };
    let mut one_run = new();
    let run: Vec<_> = (0..FRAMES).map(|f| rows(&mut one_run, f)).collect();
    assert!(run[4].iter().all(|(_, r)| !r.rebuilt));
    let mut chunk = new();
    let mut steps = Vec::new();
    for f in [2, 3] {
        let cancel = antumbra_core::cancel::CancelToken::new();
        chunk
            .warm_up_cancellable(&frame(f), &cancel, &mut |s| steps.push((s.done, s.total)))
            .unwrap();
    }
    assert_eq!(steps, [(1, 2), (2, 2), (1, 2), (2, 2)]);
    for f in 4..FRAMES {
        assert_eq!(rows(&mut chunk, f), run[f as usize], "frame {f}");
    }
}
