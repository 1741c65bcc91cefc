//! The top level's orders on issue 37's scenes (`instanced-forest`, `character-room` once its
//! character moves): shadow rays walking the top level in every order give fbto's masks and
//! hits bit for bit through the renderer, at widths 4 and 8, single rays and runs; and the
//! ordered top level answers as the brute-force reference over the same instances.

use std::str::FromStr;

use antumbra_core::build::{BuildSettings, CollapseSettings};
use antumbra_core::bvh::BvhWidth;
use antumbra_core::geometry::Ray;
use antumbra_core::order::{OrderView, ShadowOrder, SortSettings};
use antumbra_core::render::{
    FrameResult, Pick, RenderSettings, Renderer, SceneStructure, StatsMode, WideTree,
};
use antumbra_core::scene::{FrameGeometry, Scene};
use antumbra_core::trace::{NoStats, RayMode, RayQuery};
use antumbra_core::two_level::{
    brute, instance_box, render_from_mesh, Instance, MeshTree, TopLevel, TopOrdered, TopOrders,
    TwoLevel,
};
use antumbra_scenes::{builtin, SceneParams};
use glam::Vec3;

/// Frames `1..=frames` of `name` at 12k triangles, 96x54 pixels.
fn frames(name: &str, frames: i32) -> Vec<Scene> {
    let params = SceneParams {
        triangles: 12_000,
        frames,
        rotated: false,
        instances: None,
    };
    let anim = builtin(name, &params).unwrap();
    (1..=frames)
        .map(|f| {
            let mut s = anim.frame(f);
            s.resolution.x = 96;
            s.resolution.y = 54;
            s.resolution.percentage = 100;
            s
        })
        .collect()
}

fn orders() -> Vec<ShadowOrder> {
    [
        "stored",
        "sato",
        "rtsah",
        "random:seed=4",
        "sorted",
        "sorted:logging=fbto:p=area",
    ]
    .iter()
    .map(|o| ShadowOrder::from_str(o).unwrap())
    .collect()
}

fn render(
    scenes: &[Scene],
    width: BvhWidth,
    rays: RayMode,
    order: ShadowOrder,
) -> Vec<FrameResult> {
    let settings = RenderSettings {
        width,
        rays: Pick::Fixed(rays),
        shadow_order: Pick::Fixed(order),
        structure: Pick::Fixed(SceneStructure::TwoLevel),
        stats: StatsMode::Counts,
        ..RenderSettings::baseline()
    };
    let mut renderer = Renderer::new();
    (scenes.iter())
        .map(|s| renderer.render("t", s, &settings).unwrap())
        .collect()
}

fn assert_same(a: &FrameResult, b: &FrameResult, what: &str) {
    assert_eq!(b.structure, SceneStructure::TwoLevel, "{what}");
    assert!(a.primary_hits == b.primary_hits, "{what}: hits differ");
    for (x, y) in a.masks.iter().zip(&b.masks) {
        let bits = |m: &[f32]| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert!(
            bits(&x.data) == bits(&y.data),
            "{what}: mask {} differs",
            x.name
        );
    }
}

#[test]
fn every_top_order_casts_fbtos_shadows_on_the_instanced_scenes() {
    for (name, count) in [("instanced-forest", 1), ("character-room", 2)] {
        let scenes = frames(name, count);
        for width in [BvhWidth::Four, BvhWidth::Eight] {
            for rays in [RayMode::Single, RayMode::Packet] {
                let fbto = render(&scenes, width, rays, ShadowOrder::Fbto);
                let shadowed: usize = (fbto.last().unwrap().masks.iter())
                    .map(|m| m.data.iter().filter(|v| **v < 1.0).count())
                    .sum();
                assert!(shadowed > 100, "{name}: {shadowed} shadowed");
                for order in orders() {
                    let r = render(&scenes, width, rays, order);
                    for (a, b) in fbto.iter().zip(&r) {
                        let what = format!("{name} frame {} {width} {rays:?} {order}", a.frame);
                        assert_same(a, b, &what);
                    }
                }
            }
        }
    }
}

/// The scene's objects as instances of a tree per mesh in the flat frame's render space, and
/// the top level over them.
fn instances(scene: &Scene) -> (Vec<MeshTree>, Vec<Instance>, TopLevel) {
    let settings = BuildSettings::default();
    let meshes: Vec<MeshTree> = (scene.meshes.iter())
        .map(|m| MeshTree::build(m, &settings))
        .collect();
    let space = FrameGeometry::from_scene(scene).unwrap().space;
    let (mut placed, mut boxes) = (Vec::new(), Vec::new());
    for (i, o) in scene.objects.iter().enumerate() {
        let mesh = &meshes[o.mesh];
        let m = render_from_mesh(&space, &o.world_from_object, &mesh.space);
        if let Some(instance) = Instance::new(&m, o.mesh as u32, i as u32) {
            placed.push(instance);
            boxes.push(instance_box(&m, &mesh.bounds));
        }
    }
    let top = TopLevel::build(placed.clone(), boxes, &settings);
    (meshes, placed, top)
}

/// Segments between points of render space, most crossing several instances.
fn rays(n: u32) -> Vec<Ray> {
    let point = |k: u32| {
        let h = |j: u32| {
            let x =
                (k.wrapping_mul(2_654_435_761) ^ j.wrapping_mul(40_503)).wrapping_mul(747_796_405);
            (x >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        Vec3::new(h(1), h(2), h(3))
    };
    (0..n)
        .map(|i| {
            let (a, b) = (point(2 * i), point(2 * i + 1));
            Ray::new(a, b - a, 0.0, 1.0)
        })
        .collect()
}

#[test]
fn the_ordered_top_level_answers_as_brute_force_on_the_instanced_scenes() {
    for (name, frame) in [("instanced-forest", 1), ("character-room", 2)] {
        let scene = frames(name, frame).pop().unwrap();
        let (meshes, placed, top) = instances(&scene);
        assert!(top.len() > 1, "{name}: {} instances", top.len());
        let rays = rays(400);
        let expected: Vec<bool> = (rays.iter())
            .map(|r| brute::brute_occluded(&placed, &meshes, r))
            .collect();
        let occluded = expected.iter().filter(|o| **o).count();
        assert!(occluded > 20, "{name}: {occluded} rays occluded");
        for width in [BvhWidth::Four, BvhWidth::Eight] {
            let trees: Vec<WideTree> = (meshes.iter())
                .map(|m| WideTree::collapse(&m.bvh, width, &CollapseSettings::default()))
                .collect();
            let queries: Vec<_> = (trees.iter())
                .map(|t| t.ordered(OrderView::FrontToBack).with_rays(RayMode::Packet))
                .collect();
            let levels = TwoLevel {
                top: &top,
                meshes: &queries,
            };
            let sato = TopOrders::prepare(&top, Some(&ShadowOrder::Sato), &[]);
            let rtsah = TopOrders::prepare(&top, Some(&ShadowOrder::Rtsah), &[]);
            let random = TopOrders::prepare(&top, Some(&ShadowOrder::Random { seed: 4 }), &[]);
            let tables = TopOrders::default();
            let logging = TopOrdered {
                levels,
                order: sato.view(&ShadowOrder::Sato),
            };
            let stoppers: Vec<u32> = (rays.iter())
                .filter_map(|r| {
                    logging.first_stopper(r, |m, l| m.occluded(l, &mut NoStats).then_some(()))
                })
                .map(|(instance, _, _)| instance)
                .collect();
            let sorted = tables.sort_for_light(&top, &stoppers, &SortSettings::default());
            let views = [
                ("stored", OrderView::Stored),
                ("sato", sato.view(&ShadowOrder::Sato)),
                ("rtsah", rtsah.view(&ShadowOrder::Rtsah)),
                ("random", random.view(&ShadowOrder::Random { seed: 4 })),
                ("sorted", sorted.view()),
            ];
            for (label, order) in views {
                let q = TopOrdered { levels, order };
                let what = format!("{name} {width} {label}");
                let single: Vec<bool> = rays.iter().map(|r| q.occluded(r, &mut NoStats)).collect();
                assert!(single == expected, "{what}: single rays");
                let mut runs = vec![false; rays.len()];
                q.occluded_batch(&rays, &mut runs, &mut vec![NoStats; rays.len()]);
                assert!(runs == expected, "{what}: runs");
            }
        }
    }
}
