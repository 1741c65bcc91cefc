//! `leaf-cards` through alpha: every shadow order and width (and packets, and `auto`) renders
//! masks equal bit for bit to `brute_transmission` on the same rays, and camera hits equal to
//! `brute_closest_hit_alpha`, on a frame of the built-in scene.

#[path = "../../core/tests/common/alpha_ref.rs"]
mod alpha_ref;

use antumbra_core::render::{Pick, RenderSettings, StatsMode};
use antumbra_core::scene::{Resolution, Scene};
use antumbra_core::trace::RayMode;
use antumbra_scenes::{builtin, leaf_image, SceneParams};

fn frame() -> Scene {
    let params = SceneParams {
        triangles: 3_000,
        frames: 3,
        ..SceneParams::default()
    };
    let mut scene = builtin("leaf-cards", &params).unwrap().frame(2);
    scene.resolution = Resolution::new(80, 45);
    scene
}

#[test]
fn the_leaf_image_has_a_soft_rim() {
    let image = leaf_image();
    assert_eq!((image.width, image.height), (64, 64));
    let soft = image.texels.iter().filter(|&&a| a > 0.0 && a < 1.0).count();
    let (clear, solid) = (
        image.texels.iter().filter(|&&a| a == 0.0).count(),
        image.texels.iter().filter(|&&a| a == 1.0).count(),
    );
    assert!(
        soft > 50 && clear > 500 && solid > 500,
        "{soft} {clear} {solid}"
    );
}

#[test]
fn every_order_and_width_equals_brute_force_on_leaf_cards() {
    let scene = frame();
    assert!(scene.has_alpha());
    let base = RenderSettings::baseline();
    let (first, renderer) = alpha_ref::render(&scene, &base, "baseline");
    let reference = alpha_ref::reference(&scene, &base, &renderer);
    alpha_ref::compare(&first, &reference, "baseline");
    assert!(
        (first.masks.iter()).any(|m| m.data.iter().any(|&v| v > 0.0 && v < 1.0)),
        "no fractional shadow"
    );
    let stats = renderer.alpha_stats().expect("alpha traced");
    assert!(stats.primary > 0 && stats.shadow.iter().any(|(_, n)| *n > 0));
    for width in ["2", "4", "8"] {
        for order in [
            "fbto",
            "sato",
            "sorted:budget=0.2",
            "srdh:rays=all:min_occluded=0",
        ] {
            let mut s = RenderSettings {
                width: width.parse().unwrap(),
                shadow_order: order.parse().unwrap(),
                ..base.clone()
            };
            let label = s.method_name();
            let (r, _) = alpha_ref::render(&scene, &s, &label);
            alpha_ref::compare(&r, &reference, &label);
            if width == "8" {
                s.rays = Pick::Fixed(RayMode::Packet);
                s.stats = StatsMode::CountsAndTiming;
                let (r, _) = alpha_ref::render(&scene, &s, &format!("{label} packets"));
                alpha_ref::compare(&r, &reference, &label);
            }
        }
    }
    let auto = RenderSettings {
        spp: base.spp,
        ..RenderSettings::default()
    };
    let (r, _) = alpha_ref::render(&scene, &auto, "auto");
    alpha_ref::compare(&r, &reference, "auto");
}
