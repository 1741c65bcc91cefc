//! The `indoors` scene does what it is for: no fixed method of the default comparison does the
//! least work on every frame. Work is counted exactly (nodes entered per frame, the OSAH paper's
//! traversal steps N_TS over primary and shadow rays), never timed.

use antumbra_core::compare::default_methods;
use antumbra_core::render::Renderer;
use antumbra_core::scene::Resolution;
use antumbra_core::settings::NamedSettings;
use antumbra_scenes::{builtin, SceneParams};

/// Nodes entered over every pass of a frame, per method of the default comparison.
fn steps_per_frame(frames: &[i32]) -> Vec<(String, Vec<f64>)> {
    let anim = builtin("indoors", &SceneParams::default()).unwrap();
    default_methods()
        .iter()
        .map(|m| {
            let settings = m.resolve(&NamedSettings::new()).unwrap();
            let mut renderer = Renderer::new();
            let mut work = Vec::new();
            // From the frame before each, so OSAH has the previous frame's visible set.
            for &f in frames {
                for frame in [f - 1, f] {
                    let mut scene = anim.frame(frame);
                    scene.resolution = Resolution::new(320, 180);
                    let result = renderer.render("indoors", &scene, &settings).unwrap();
                    if frame == f {
                        let steps = result.stats.iter().map(|r| r.nts_per_ray * r.rays as f64);
                        work.push(steps.sum());
                    }
                }
            }
            (m.label.clone(), work)
        })
        .collect()
}

#[test]
fn the_method_doing_the_least_work_changes_from_the_garden_to_the_room() {
    // Frame 8: the camera over the garden, the lamp in the open sky. Frame 23: the camera in the
    // room, the lamp behind the back wall.
    let work = steps_per_frame(&[8, 23]);
    let best = |i: usize| {
        work.iter()
            .min_by(|a, b| a.1[i].total_cmp(&b.1[i]))
            .map(|(label, w)| (label.clone(), w[i]))
            .unwrap()
    };
    let (outside, inside) = (best(0), best(1));
    assert_ne!(outside.0, inside.0, "{work:?}");
    // Strictly: each is beaten on the other frame, not tied.
    let of = |label: &str, i: usize| work.iter().find(|(l, _)| l == label).unwrap().1[i];
    assert!(of(&inside.0, 0) > outside.1, "{work:?}");
    assert!(of(&outside.0, 1) > inside.1, "{work:?}");
}
