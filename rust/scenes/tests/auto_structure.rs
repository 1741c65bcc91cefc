//! `auto`'s scene structure on a moving part in a large static set (`character-room`): two
//! levels from the first frame that moves where the kept triangles are many per traced ray,
//! the flat tree where they are few, and a farm chunk after its warm-up choosing as one run.

use antumbra_core::render::{FrameResult, RenderSettings, Renderer, SceneStructure};
use antumbra_core::scene::Scene;
use antumbra_scenes::{builtin, SceneParams};

/// The character-room's frames 1-5 at `triangles`, rendered at `width` x `height`.
fn frames(triangles: usize, width: u32, height: u32) -> Vec<Scene> {
    let params = SceneParams {
        triangles,
        frames: 5,
        rotated: false,
        instances: None,
    };
    let anim = builtin("character-room", &params).unwrap();
    (anim.frame_range())
        .map(|f| {
            let mut s = anim.frame(f);
            s.resolution.x = width;
            s.resolution.y = height;
            s.resolution.percentage = 100;
            s
        })
        .collect()
}

fn render(frames: &[Scene], settings: &RenderSettings) -> Vec<FrameResult> {
    let mut renderer = Renderer::new();
    (frames.iter())
        .map(|s| renderer.render("t", s, settings).unwrap())
        .collect()
}

fn structures(results: &[FrameResult]) -> Vec<SceneStructure> {
    results.iter().map(|r| r.structure).collect()
}

fn fixed(structure: &str) -> RenderSettings {
    RenderSettings {
        structure: structure.parse().unwrap(),
        ..RenderSettings::default()
    }
}

fn assert_same_answers(a: &FrameResult, b: &FrameResult, what: &str) {
    let f = a.frame;
    assert_eq!(a.structure, b.structure, "{what} frame {f}");
    assert_eq!(a.primary_hits, b.primary_hits, "{what} frame {f}");
    for (x, y) in a.masks.iter().zip(&b.masks) {
        assert_eq!(x.data, y.data, "{what} frame {f}: mask {}", x.name);
    }
}

#[test]
fn many_static_triangles_per_ray_take_two_levels_from_the_first_frame_that_moves() {
    // 40k triangles under 64x36 pixels (13 rays a pixel): more than one kept triangle a ray.
    let scenes = frames(40_000, 64, 36);
    let auto = render(&scenes, &RenderSettings::default());
    use SceneStructure::{Flat, TwoLevel};
    assert_eq!(
        structures(&auto),
        [Flat, TwoLevel, TwoLevel, TwoLevel, TwoLevel]
    );
    // The primary row names the choice.
    let primary = |r: &FrameResult| r.stats.iter().find(|s| s.pass == "primary").cloned();
    assert_eq!(primary(&auto[2]).unwrap().auto_choice, "two-level");
    // The answers are those of the fixed structure auto chose, frame by frame.
    let flat = render(&scenes, &fixed("flat"));
    let two = render(&scenes, &fixed("two-level"));
    assert_same_answers(&auto[0], &flat[0], "auto against flat");
    for f in 1..scenes.len() {
        assert_same_answers(&auto[f], &two[f], "auto against two-level");
    }
}

#[test]
fn few_kept_triangles_per_ray_stay_flat() {
    // 4k triangles under 160x90 pixels: about 0.02 kept triangles a ray.
    let scenes = frames(4_000, 160, 90);
    let auto = render(&scenes, &RenderSettings::default());
    assert!(
        structures(&auto).iter().all(|s| *s == SceneStructure::Flat),
        "{:?}",
        structures(&auto)
    );
}

#[test]
fn a_chunk_after_its_warm_up_chooses_the_structure_of_one_run() {
    let scenes = frames(40_000, 64, 36);
    let settings = RenderSettings::default();
    let run = render(&scenes, &settings);
    for start in [2, 3] {
        let mut chunk = Renderer::new();
        for s in &scenes[start - 2..start] {
            chunk.warm_up(s, &settings).unwrap();
        }
        for (f, s) in scenes.iter().enumerate().skip(start) {
            let r = chunk.render("t", s, &settings).unwrap();
            assert_same_answers(&r, &run[f], &format!("chunk from {start}"));
        }
    }
}
