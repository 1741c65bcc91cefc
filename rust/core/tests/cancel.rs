//! A cancelled render stops with `Error::Cancelled` and leaves the renderer as a fresh one: the
//! next render of the frame equals a fresh renderer's, statistics included (timings aside),
//! wherever the cancel landed (before the build, between trees, inside a pass, between lights).

mod common;

use std::time::Duration;

use antumbra_core::cancel::CancelToken;
use antumbra_core::render::{FrameResult, RenderSettings, Renderer};
use antumbra_core::scene::{LightKind, Scene};
use antumbra_core::stats::StatsRow;
use antumbra_core::Error;
use glam::{DMat4, DVec3};

fn soft_scene(frame: i32) -> Scene {
    let mut s = common::boxes_scene(200);
    s.frame = frame;
    s.lights[0].kind = LightKind::Sun { angle: 0.1 };
    s.lights[1].kind = LightKind::Point { radius: 0.5 };
    // A box moves, so each frame has its own trees.
    s.objects[1].world_from_object =
        DMat4::from_translation(DVec3::new(0.2 * frame as f64, 0.0, 0.0))
            * s.objects[1].world_from_object;
    s
}

fn settings(build: &str, width: &str, order: &str) -> RenderSettings {
    RenderSettings {
        build: build.parse().unwrap(),
        width: width.parse().unwrap(),
        shadow_order: order.parse().unwrap(),
        spp: 16,
        ..RenderSettings::baseline()
    }
}

fn assert_same(got: &FrameResult, want: &FrameResult, what: &str) {
    assert_eq!(got.masks, want.masks, "{what}: masks");
    assert_eq!(got.combined, want.combined, "{what}: combined");
    assert_eq!(got.primary_hits, want.primary_hits, "{what}: primary ids");
    assert_eq!(got.visible, want.visible, "{what}: visible set");
    assert_eq!(
        got.heat
            .as_ref()
            .map(|h| (h.primary.clone(), h.shadow.clone())),
        want.heat
            .as_ref()
            .map(|h| (h.primary.clone(), h.shadow.clone())),
        "{what}: heat maps"
    );
    let rows = |r: &FrameResult| r.stats.iter().map(StatsRow::untimed).collect::<Vec<_>>();
    assert_eq!(rows(got), rows(want), "{what}: statistics");
    // Costs reported by a fresh render are reported after a cancelled one too.
    for (g, w) in got.stats.iter().zip(&want.stats) {
        assert_eq!(
            g.build_ms > 0.0,
            w.build_ms > 0.0,
            "{what}: build time of {g:?}"
        );
        assert_eq!(
            g.prepare_ms > 0.0,
            w.prepare_ms > 0.0,
            "{what}: sort time of {g:?}"
        );
    }
}

/// Renders with a token cancelled by another thread after `delay`.
fn render_cancelled_after(
    renderer: &mut Renderer,
    scene: &Scene,
    settings: &RenderSettings,
    delay: Duration,
) -> Result<FrameResult, Error> {
    let token = CancelToken::new();
    let t = token.clone();
    let canceller = std::thread::spawn(move || {
        std::thread::sleep(delay);
        t.cancel();
    });
    let r = renderer.render_cancellable("t", scene, settings, &token);
    canceller.join().unwrap();
    r
}

#[test]
fn a_cancelled_token_stops_before_any_work() {
    let token = CancelToken::new();
    token.cancel();
    let mut r = Renderer::new();
    let s = soft_scene(1);
    let err = r
        .render_cancellable("t", &s, &RenderSettings::baseline(), &token)
        .unwrap_err();
    assert_eq!(err, Error::Cancelled);
    assert_eq!(r.builds, 0);
    assert!(r.current().is_none());
}

#[test]
fn after_a_cancel_anywhere_the_next_render_equals_a_fresh_one() {
    let delays = [0, 1, 3, 10, 30, 100].map(Duration::from_millis);
    for (build, width, order) in [
        ("sah", "2", "fbto"),
        ("sah", "8", "sorted:budget=0.2"),
        ("sah", "4", "sato"),
        ("osah", "4", "fbto"),
        ("sah", "2", "srdh"),
    ] {
        let settings = settings(build, width, order);
        let (f1, f2) = (soft_scene(1), soft_scene(2));
        // What a renderer that was never cancelled gives for frames 1 and 2.
        let mut fresh = Renderer::new();
        let want1 = fresh.render("t", &f1, &settings).unwrap();
        let want2 = fresh.render("t", &f2, &settings).unwrap();
        let mut cancelled = 0;
        for delay in delays {
            let what = format!("{build} {width} {order}, cancelled after {delay:?}");
            // Frame 1 cancelled, then rendered (or finished before the cancel came).
            let mut r = Renderer::new();
            let got1 = match render_cancelled_after(&mut r, &f1, &settings, delay) {
                Err(Error::Cancelled) => {
                    cancelled += 1;
                    r.render("t", &f1, &settings).unwrap()
                }
                Err(e) => panic!("{what}: {e}"),
                Ok(got) => got,
            };
            assert_same(&got1, &want1, &what);
            // Frame 2 cancelled after a finished frame 1 (visibility-driven builds read its
            // visible set), then rendered.
            let got2 = match render_cancelled_after(&mut r, &f2, &settings, delay) {
                Err(Error::Cancelled) => {
                    cancelled += 1;
                    r.render("t", &f2, &settings).unwrap()
                }
                Err(e) => panic!("{what}: {e}"),
                Ok(got) => got,
            };
            assert_same(&got2, &want2, &what);
        }
        // At least the immediate cancels landed.
        assert!(
            cancelled >= 2,
            "{build} {width} {order}: {cancelled} cancels landed"
        );
    }
}
