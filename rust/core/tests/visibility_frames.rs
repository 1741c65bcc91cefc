//! The frame loop of visibility-driven builds: every method and visibility source renders the
//! same ids and masks as SAH; frame t builds from V(t-1); a frame whose geometry and visible-set
//! input did not change is not rebuilt; objects that appear or disappear do not confuse it.

mod common;

use antumbra_core::build::BuildMethod;
use antumbra_core::render::{FrameResult, RenderSettings, Renderer, VisibilitySource};
use antumbra_core::scene::Scene;
use glam::{DMat4, DVec3};

/// Frame `f` of a small animation: the camera orbits, box 1 slides, box 3 exists only on odd
/// frames (an object that appears and disappears shifts every later triangle index).
fn frame(f: i32) -> Scene {
    let mut s = common::boxes_scene(48);
    s.frame = f;
    let a = f as f64 * 0.15;
    s.camera = antumbra_core::scene::Camera::look_at(
        DVec3::new(14.0 * a.cos(), -14.0 * a.sin() - 4.0, 10.0),
        DVec3::ZERO,
        DVec3::Z,
    );
    s.objects[2].world_from_object = DMat4::from_translation(DVec3::new(0.4 * f as f64, 0.0, 0.0))
        * s.objects[2].world_from_object;
    if f % 2 == 0 {
        s.objects.remove(3);
    }
    s
}

fn settings(build: BuildMethod, visibility: VisibilitySource) -> RenderSettings {
    RenderSettings {
        build: build.into(),
        visibility,
        ..RenderSettings::baseline()
    }
}

fn render_all(settings: &RenderSettings, frames: i32) -> (Vec<FrameResult>, Renderer) {
    let mut renderer = Renderer::new();
    let results = (0..frames)
        .map(|f| renderer.render("t", &frame(f), settings).unwrap())
        .collect();
    (results, renderer)
}

#[test]
fn every_method_and_source_renders_what_sah_renders() {
    let frames = 4;
    let (base, _) = render_all(&RenderSettings::baseline(), frames);
    let sources = [
        VisibilitySource::Previous,
        VisibilitySource::Exact,
        VisibilitySource::Prepass {
            width: 16,
            height: 12,
        },
    ];
    for build in [BuildMethod::Sbvh, BuildMethod::Abvh, BuildMethod::Osah] {
        for source in sources {
            let (results, _) = render_all(&settings(build, source), frames);
            for (r, b) in results.iter().zip(&base) {
                let what = format!("{build:?} {source:?} frame {}", r.frame);
                assert_eq!(r.primary_hits, b.primary_hits, "{what}");
                assert_eq!(r.masks, b.masks, "{what}");
                assert_eq!(r.visible, b.visible, "{what}");
            }
        }
    }
    // VSAH is complete only for the rays its set came from: exact visibility.
    let (results, _) = render_all(
        &settings(BuildMethod::Vsah, VisibilitySource::Exact),
        frames,
    );
    for (r, b) in results.iter().zip(&base) {
        assert_eq!(r.primary_hits, b.primary_hits);
        assert_eq!(r.masks, b.masks);
    }
}

#[test]
fn frame_t_builds_from_the_previous_frames_visible_set() {
    let s = settings(BuildMethod::Osah, VisibilitySource::Previous);
    let mut renderer = Renderer::new();
    let mut previous: Option<FrameResult> = None;
    for f in 0..3 {
        let r = renderer.render("t", &frame(f), &s).unwrap();
        let primary = &r.stats[0];
        let camera_set = &renderer.current().unwrap().0.camera;
        let expected = match &previous {
            None => 0,
            Some(p) => camera_set
                .refs
                .iter()
                .filter(|t| p.visible.binary_search(t).is_ok())
                .count() as u64,
        };
        assert_eq!(primary.visible_input, expected, "frame {f}");
        assert!(primary.rebuilt);
        previous = Some(r);
    }
    assert!(previous.unwrap().stats[0].visible_input > 0);
}

#[test]
fn unchanged_geometry_and_visibility_are_not_rebuilt() {
    let scene = frame(1);
    for source in [VisibilitySource::Previous, VisibilitySource::Exact] {
        let mut renderer = Renderer::new();
        let s = settings(BuildMethod::Osah, source);
        let runs: Vec<bool> = (0..3)
            .map(|_| renderer.render("t", &scene, &s).unwrap().stats[0].rebuilt)
            .collect();
        let expected = match source {
            // Frame 0 has no set; frame 1 gets V(0); frame 2 gets the same set again.
            VisibilitySource::Previous => [true, true, false],
            _ => [true, false, false],
        };
        assert_eq!(runs, expected, "{source:?}");
    }
}

#[test]
fn first_frame_prepass_gives_a_visible_set() {
    let s = settings(
        BuildMethod::Osah,
        VisibilitySource::Prepass {
            width: 16,
            height: 12,
        },
    );
    let r = Renderer::new().render("t", &frame(0), &s).unwrap();
    assert!(r.stats[0].visible_input > 0);
    assert!(r.stats[0].visibility_ms > 0.0);
    assert!(r.stats[0].method.starts_with("osah-prepass:16x12/"));
}
