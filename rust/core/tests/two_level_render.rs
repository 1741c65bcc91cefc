//! Two-level frames through the renderer: the same shadows as the flat tree but at triangle
//! edges, the same answers for every width and order on two levels, mesh trees kept across
//! frames, positions far from the origin, packets through instances as single rays, `auto`'s
//! structure and the memory estimate.

mod common;

use std::str::FromStr;
use std::sync::Arc;

use antumbra_core::bvh::BvhWidth;
use antumbra_core::order::ShadowOrder;
use antumbra_core::render::{
    estimate_render_bytes, FrameResult, Pick, RenderSettings, Renderer, SceneStructure,
};
use antumbra_core::scene::{Mesh, Object, Resolution, Scene, TriangleRef};
use antumbra_core::trace::RayMode;
use glam::{DMat4, DVec3, Vec3};

fn scene(count: u32) -> Scene {
    let mut s = common::instanced_scene(count);
    s.resolution = Resolution::new(160, 120);
    s
}

fn settings(structure: SceneStructure, width: BvhWidth, order: ShadowOrder) -> RenderSettings {
    RenderSettings {
        width,
        shadow_order: Pick::Fixed(order),
        structure: Pick::Fixed(structure),
        ..RenderSettings::baseline()
    }
}

fn render(scene: &Scene, s: &RenderSettings) -> FrameResult {
    Renderer::new().render("two-level", scene, s).unwrap()
}

fn differing(a: &FrameResult, b: &FrameResult) -> (usize, usize) {
    let masks = a
        .masks
        .iter()
        .zip(&b.masks)
        .map(|(x, y)| x.data.iter().zip(&y.data).filter(|(p, q)| p != q).count())
        .sum();
    let hits = a
        .primary_hits
        .iter()
        .zip(&b.primary_hits)
        .filter(|(p, q)| p != q)
        .count();
    (masks, hits)
}

#[test]
fn two_levels_cast_the_flat_trees_shadows_but_at_triangle_edges() {
    let scene = scene(300);
    let flat = render(&scene, &RenderSettings::baseline());
    let shadowed: usize = flat
        .masks
        .iter()
        .map(|m| m.data.iter().filter(|v| **v < 1.0).count())
        .sum();
    assert!(shadowed > 2000, "the scene must cast shadows: {shadowed}");
    let two = render(
        &scene,
        &settings(SceneStructure::TwoLevel, BvhWidth::Two, ShadowOrder::Fbto),
    );
    assert_eq!(two.structure, SceneStructure::TwoLevel);
    assert_eq!(flat.structure, SceneStructure::Flat);
    let (masks, hits) = differing(&flat, &two);
    let pixels = 160 * 120;
    // Instance transforms round differently from the flat set's: only rays through an edge.
    assert!(
        masks * 1000 <= pixels * flat.masks.len(),
        "{masks} mask pixels differ"
    );
    assert!(hits * 1000 <= pixels, "{hits} primary hits differ");
    assert!(two.visible.len() > 100);
}

#[test]
fn every_width_order_and_count_mode_on_two_levels_gives_the_same_answers() {
    let scene = scene(200);
    let base = render(
        &scene,
        &settings(SceneStructure::TwoLevel, BvhWidth::Two, ShadowOrder::Fbto),
    );
    let mut checked = 0;
    for width in [BvhWidth::Two, BvhWidth::Four, BvhWidth::Eight] {
        for order in [
            ShadowOrder::Fbto,
            ShadowOrder::Stored,
            ShadowOrder::Sato,
            ShadowOrder::Rtsah,
            ShadowOrder::Random { seed: 3 },
            ShadowOrder::from_str("sorted").unwrap(),
            ShadowOrder::from_str("sorted:logging=fbto:p=area:budget=0.2").unwrap(),
            ShadowOrder::from_str("srdh:min_occluded=0").unwrap(),
            ShadowOrder::from_str("srdh:rays=all:bins=8:leaf=2:kernels=directional:min_occluded=0")
                .unwrap(),
        ] {
            let mut s = settings(SceneStructure::TwoLevel, width, order);
            s.stats = antumbra_core::render::StatsMode::CountsAndTiming;
            let r = render(&scene, &s);
            assert_eq!(differing(&base, &r), (0, 0), "{width} {order}");
            assert_eq!(r.visible, base.visible, "{width} {order}");
            let shadow_rows = r.stats.iter().filter(|row| row.pass == "shadow");
            assert!(shadow_rows.clone().count() == 2);
            for row in shadow_rows {
                assert!(
                    row.nb_per_ray > 0.0 && row.nt_per_ray > 0.0,
                    "{width} {order}: {row:?}"
                );
                // Sorting for the light, or its SRDH tree, is its preparation.
                let prepared = matches!(order, ShadowOrder::Sorted(_) | ShadowOrder::Srdh(_));
                assert_eq!(row.prepare_ms > 0.0, prepared, "{width} {order}: {row:?}");
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 27);
}

#[test]
fn srdh_on_two_levels_builds_each_lights_tree_over_the_instances() {
    let scene = scene(200);
    let counted = |order: &str| {
        let mut s = settings(
            SceneStructure::TwoLevel,
            BvhWidth::Eight,
            ShadowOrder::from_str(order).unwrap(),
        );
        s.stats = antumbra_core::render::StatsMode::CountsAndTiming;
        render(&scene, &s)
    };
    let fbto = counted("fbto");
    let srdh = counted("srdh:rays=all:min_occluded=0");
    assert_eq!(differing(&fbto, &srdh), (0, 0));
    let shadow = |r: &FrameResult| -> Vec<_> {
        (r.stats.iter())
            .filter(|row| row.pass == "shadow")
            .cloned()
            .collect()
    };
    for (f, s) in shadow(&fbto).iter().zip(shadow(&srdh)) {
        // The light's tree in the top level's place: its own node count, the same mesh trees.
        assert_ne!(f.bvh_nodes, s.bvh_nodes, "{f:?}\n{s:?}");
        assert_eq!(
            s.method,
            "sah/bin8/srdh:rays=all:bins=32:leaf=1:kernels=all:min_occluded=0/two-level"
        );
        // Built from every shadow ray of the light, the tree serves them with fewer box tests
        // than the top level's near-first walk (the same mesh trees below).
        assert!(
            s.nbox_per_ray < f.nbox_per_ray,
            "{} against {}",
            s.nbox_per_ray,
            f.nbox_per_ray
        );
    }
    // Where too few of a light's rays are occluded it traces the top level, front to back: the
    // sun's rays, about half of them occluded, at a threshold of all; the other light's rays
    // are all occluded, and it has its tree.
    let all = counted("srdh:min_occluded=1");
    assert_eq!(differing(&fbto, &all), (0, 0));
    let (f, a) = (shadow(&fbto), shadow(&all));
    assert_eq!(f[0].light, "Sun");
    assert!((0.3..0.7).contains(&f[0].occluded_fraction), "{:?}", f[0]);
    assert_eq!(
        (f[0].bvh_nodes, f[0].nb_per_ray),
        (a[0].bvh_nodes, a[0].nb_per_ray)
    );
    assert!(
        a[0].prepare_ms > 0.0,
        "its rays were still traced: {:?}",
        a[0]
    );
    assert_eq!(f[1].occluded_fraction, 1.0, "{:?}", f[1]);
    assert_ne!(f[1].bvh_nodes, a[1].bvh_nodes);
}

#[test]
fn auto_chooses_each_lights_order_on_two_levels_among_the_orders_they_have() {
    let scene = scene(200);
    let fixed = render(
        &scene,
        &settings(SceneStructure::TwoLevel, BvhWidth::Eight, ShadowOrder::Fbto),
    );
    let mut s = settings(SceneStructure::TwoLevel, BvhWidth::Eight, ShadowOrder::Fbto);
    s.shadow_order = Pick::Auto;
    let mut renderer = Renderer::new();
    let mut choices = Vec::new();
    for frame in 1..=4 {
        let mut f = scene.clone();
        f.frame = frame;
        let r = renderer.render("t", &f, &s).unwrap();
        assert_eq!(r.structure, SceneStructure::TwoLevel);
        assert_eq!(differing(&fixed, &r), (0, 0), "frame {frame}");
        for row in r.stats.iter().filter(|row| row.pass == "shadow") {
            choices.push((frame, row.auto_choice.clone(), row.prepare_ms));
        }
    }
    // SATO first where it is a candidate (its tables made by the first light, as its
    // preparation), then whatever measures fastest.
    assert!(choices[0].1.starts_with("sato;"), "{choices:?}");
    // Sorting is measured on a sample of a light's rays beside the order that traces it.
    assert!(
        choices.iter().any(|(_, c, _)| c.contains("sorted")),
        "{choices:?}"
    );
    assert!(choices[0].2 > 0.0, "{choices:?}");
    assert!(choices.iter().all(|(_, c, _)| !c.is_empty()), "{choices:?}");
}

#[test]
fn auto_measures_orders_on_two_levels_apart_from_the_flat_trees() {
    let scene = scene(200);
    let mut renderer = Renderer::new();
    let mut choices = |frame: i32, structure| {
        let mut s = settings(structure, BvhWidth::Eight, ShadowOrder::Fbto);
        s.shadow_order = Pick::Auto;
        let mut f = scene.clone();
        f.frame = frame;
        let r = renderer.render("t", &f, &s).unwrap();
        assert_eq!(r.structure, structure);
        (r.stats.iter().filter(|row| row.pass == "shadow"))
            .map(|row| row.auto_choice.clone())
            .collect::<Vec<_>>()
    };
    let first = choices(1, SceneStructure::Flat);
    assert!(first.iter().all(|c| c == "sato;sample=fbto"), "{first:?}");
    // The flat frame's measurements are not the two levels' own: the first two-level frame
    // starts as a first frame does.
    let two = choices(2, SceneStructure::TwoLevel);
    assert_eq!(two, first);
    let flat_again = choices(3, SceneStructure::Flat);
    assert!(
        flat_again.iter().all(|c| c != "sato;sample=fbto"),
        "{flat_again:?}"
    );
}

/// `scene` with a mesh of its own per object: every object is then in the static group, whose
/// tree is the flat tree's.
fn unshared(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    s.meshes = (s.objects.iter())
        .map(|o| Arc::new((*scene.meshes[o.mesh]).clone()))
        .collect();
    for (i, o) in s.objects.iter_mut().enumerate() {
        o.mesh = i;
    }
    s
}

#[test]
fn sorting_on_two_levels_sorts_the_group_tree_as_the_flat_tree_is_sorted() {
    let scene = unshared(&scene(60));
    let sorted = ShadowOrder::from_str("sorted").unwrap();
    let counted = |structure, order| {
        let mut s = settings(structure, BvhWidth::Eight, order);
        s.stats = antumbra_core::render::StatsMode::Counts;
        let r = render(&scene, &s);
        assert_eq!(r.structure, structure);
        r
    };
    let flat = counted(SceneStructure::Flat, sorted);
    let two = counted(SceneStructure::TwoLevel, sorted);
    let logging = counted(SceneStructure::TwoLevel, ShadowOrder::Sato);
    // One tree in the same render space: the same answers bit for bit.
    assert_eq!(differing(&flat, &two), (0, 0));
    let shadow = |r: &FrameResult| -> Vec<(String, f64)> {
        (r.stats.iter().filter(|row| row.pass == "shadow"))
            .map(|row| (row.light.clone(), row.nt_per_ray))
            .collect()
    };
    // The group tree sorted for each light as the flat tree is: the same triangle tests (the
    // top level adds nodes, not tests), and not the logging order's.
    assert_eq!(shadow(&flat), shadow(&two));
    assert_ne!(shadow(&two), shadow(&logging));
}

#[test]
fn packets_through_instances_give_the_single_rays_frames_bit_for_bit() {
    let scene = scene(200);
    let bits = |r: &FrameResult| -> Vec<Vec<u32>> {
        (r.masks.iter())
            .map(|m| m.data.iter().map(|v| v.to_bits()).collect())
            .collect()
    };
    for width in [BvhWidth::Two, BvhWidth::Four, BvhWidth::Eight] {
        for order in [
            ShadowOrder::Fbto,
            ShadowOrder::Sato,
            ShadowOrder::from_str("sorted").unwrap(),
        ] {
            let mut single = settings(SceneStructure::TwoLevel, width, order);
            single.rays = Pick::Fixed(RayMode::Single);
            single.stats = antumbra_core::render::StatsMode::CountsAndTiming;
            let packet = RenderSettings {
                rays: Pick::Fixed(RayMode::Packet),
                ..single.clone()
            };
            let (a, b) = (render(&scene, &single), render(&scene, &packet));
            assert_eq!(b.structure, SceneStructure::TwoLevel);
            assert!(bits(&a) == bits(&b), "{width} {order}: masks differ");
            assert!(
                a.primary_hits == b.primary_hits,
                "{width} {order}: hits differ"
            );
            assert_eq!(a.visible, b.visible, "{width} {order}");
            // Packets count work per ray too.
            for row in b.stats.iter().filter(|row| row.pass == "shadow") {
                assert!(row.nb_per_ray > 0.0 && row.nt_per_ray > 0.0, "{row:?}");
            }
        }
    }
}

/// `scene(count)` with each mesh a single triangle: a mesh tree is one leaf, so any work an
/// order changes on two levels is the top level's.
fn one_triangle_meshes(count: u32) -> Scene {
    let mut s = scene(count);
    let triangle = |i: usize| {
        let corners = vec![
            Vec3::new(-1.5, -1.0, 0.0),
            Vec3::new(1.5, -1.0, 0.2),
            Vec3::new(0.0, 1.5, -0.2),
        ];
        Arc::new(Mesh::new(format!("triangle{i}"), corners, vec![[0, 1, 2]]))
    };
    s.meshes = (0..s.meshes.len()).map(triangle).collect();
    s
}

#[test]
fn shadow_rays_walk_the_top_level_in_their_order() {
    let scene = one_triangle_meshes(400);
    let shadow = |r: &FrameResult| -> Vec<(f64, f64)> {
        (r.stats.iter().filter(|row| row.pass == "shadow"))
            .map(|row| (row.nb_per_ray, row.nl_per_ray))
            .collect()
    };
    for rays in [RayMode::Single, RayMode::Packet] {
        for width in [BvhWidth::Four, BvhWidth::Eight] {
            let counted = |order: ShadowOrder| {
                let mut s = settings(SceneStructure::TwoLevel, width, order);
                s.rays = Pick::Fixed(rays);
                s.stats = antumbra_core::render::StatsMode::Counts;
                render(&scene, &s)
            };
            let fbto = counted(ShadowOrder::Fbto);
            let shadowed: usize = (fbto.masks.iter())
                .map(|m| m.data.iter().filter(|v| **v < 1.0).count())
                .sum();
            assert!(
                shadowed > 500,
                "the triangles must cast shadows: {shadowed}"
            );
            let sato = counted(ShadowOrder::Sato);
            for order in [
                ShadowOrder::Stored,
                ShadowOrder::Sato,
                ShadowOrder::Rtsah,
                ShadowOrder::Random { seed: 9 },
                ShadowOrder::from_str("sorted").unwrap(),
                ShadowOrder::from_str("sorted:logging=fbto").unwrap(),
            ] {
                let r = counted(order);
                let what = format!("{rays:?} {width} {order}");
                assert_eq!(differing(&fbto, &r), (0, 0), "{what}");
                // The mesh trees are single leaves: only the top level's walk can differ.
                let (a, b) = (shadow(&fbto), shadow(&r));
                assert!(
                    a.iter().zip(&b).all(|(x, y)| x != y),
                    "{what}: {b:?} against fbto's {a:?}"
                );
                // Sorted for the light from its stoppers, the top level stops rays in fewer
                // leaves than its logging order (SATO) does.
                if order == ShadowOrder::from_str("sorted").unwrap() {
                    for (x, y) in b.iter().zip(shadow(&sato)) {
                        assert!(x.1 < y.1, "{what}: leaves {} against SATO's {}", x.1, y.1);
                    }
                }
            }
        }
    }
}

#[test]
fn mesh_trees_are_kept_while_their_mesh_is_and_rebuilt_when_it_changes() {
    let first = scene(120);
    let s = settings(SceneStructure::TwoLevel, BvhWidth::Eight, ShadowOrder::Fbto);
    let mut renderer = Renderer::new();
    let r1 = renderer.render("frames", &first, &s).unwrap();
    let trees = renderer.scene_trees().unwrap().two_level().unwrap();
    assert_eq!(trees.meshes_built(), 3);
    let builds = renderer.builds;
    // Frame 2: one object moves, one mesh deforms (a new Arc with other positions).
    let mut second = first.clone();
    second.frame = 2;
    second.objects[5].world_from_object =
        DMat4::from_translation(DVec3::new(0.5, 0.0, 0.0)) * second.objects[5].world_from_object;
    let mut grid = (*second.meshes[2]).clone();
    for p in &mut grid.positions {
        p.z += 0.1 * p.x;
    }
    second.meshes[2] = Arc::new(grid);
    let r2 = renderer.render("frames", &second, &s).unwrap();
    let trees = renderer.scene_trees().unwrap().two_level().unwrap();
    assert_eq!(
        (trees.meshes_built(), trees.meshes_refit()),
        (0, 1),
        "only the deformed mesh's tree is made: refit, its triangle list is the same"
    );
    assert_eq!(renderer.builds, builds + 1);
    let primary = |r: &FrameResult| r.stats.iter().find(|row| row.pass == "primary").cloned();
    assert!(primary(&r1).unwrap().rebuilt && primary(&r2).unwrap().rebuilt);
    // Frame 3: nothing changes, nothing is built and the frame reports no build.
    let mut third = second.clone();
    third.frame = 3;
    let r3 = renderer.render("frames", &third, &s).unwrap();
    assert_eq!(renderer.builds, builds + 1);
    let row = primary(&r3).unwrap();
    assert!(!row.rebuilt && row.build_ms == 0.0, "{row:?}");
    assert_eq!(differing(&r2, &r3), (0, 0));
    // A fresh renderer on frame 2 gives what the kept trees gave.
    let fresh = Renderer::new().render("frames", &second, &s).unwrap();
    assert_eq!(differing(&r2, &fresh), (0, 0));
}

#[test]
fn two_level_shadows_hold_a_million_units_from_the_origin_and_at_any_power_of_two() {
    let scene = scene(150);
    let s = settings(SceneStructure::TwoLevel, BvhWidth::Eight, ShadowOrder::Fbto);
    let reference = render(&scene, &s);
    let moved = |m: DMat4, clip: f64| {
        let mut moved = common::transform_scene(&scene, m);
        moved.camera.clip_start *= clip;
        moved.camera.clip_end *= clip;
        moved
    };
    for (m, clip) in [
        (DMat4::from_translation(DVec3::splat(1e6)), 1.0),
        (DMat4::from_translation(DVec3::new(-1e6, 3e5, 1e6)), 1.0),
        (DMat4::from_scale(DVec3::splat(1e-4)), 1e-4),
        (DMat4::from_scale(DVec3::splat(1e4)), 1e4),
    ] {
        let r = render(&moved(m, clip), &s);
        let (masks, hits) = differing(&reference, &r);
        assert!(
            masks <= 2 && hits <= 2,
            "{m}: {masks} mask and {hits} hit pixels differ"
        );
    }
}

#[test]
fn auto_takes_two_levels_for_large_instanced_scenes_and_small_moving_parts() {
    // 12 instances of a 204,800-triangle mesh: 2.5M world triangles.
    let mut instanced = common::boxes_scene(48);
    instanced.meshes = vec![Arc::new(common::grid("big", 320))];
    instanced.objects = (0..12)
        .map(|i| {
            let at = DVec3::new((i % 4) as f64 * 2.5 - 4.0, (i / 4) as f64 * 2.5 - 2.5, 0.0);
            Object::new(format!("o{i}"), 0, DMat4::from_translation(at))
        })
        .collect();
    let r = render(&instanced, &RenderSettings::default());
    assert_eq!(r.structure, SceneStructure::TwoLevel);
    assert!(
        r.stats[0].method.starts_with("auto/bin8/auto"),
        "{}",
        r.stats[0].method
    );
    // The same instancing below two million world triangles stays flat.
    assert_eq!(
        render(&scene(100), &RenderSettings::default()).structure,
        SceneStructure::Flat
    );
    // A small part that moves in a static set of many triangles per ray (3,248 under 48x36
    // pixels): two levels from the first frame that moves (rust/scenes/tests/auto_structure.rs
    // has the character-room); under 36x the pixels (at most 0.053 a ray), the flat tree.
    use SceneStructure::{Flat, TwoLevel};
    let room = Room::new();
    let structures = |scale: u32, settings: &RenderSettings| -> Vec<SceneStructure> {
        let mut renderer = Renderer::new();
        (1..=3)
            .map(|f| {
                let mut scene = room.with_character(f);
                scene.resolution.x *= scale;
                scene.resolution.y *= scale;
                let r = renderer.render("room", &scene, settings);
                r.unwrap().structure
            })
            .collect()
    };
    let default = RenderSettings::default();
    assert_eq!(structures(1, &default), [Flat, TwoLevel, TwoLevel]);
    assert_eq!(structures(6, &default), [Flat, Flat, Flat]);
    // A named build is a method compared as published: the flat tree.
    let named = RenderSettings {
        build: Pick::Fixed("sah".parse().unwrap()),
        ..RenderSettings::default()
    };
    assert_eq!(structures(1, &named), [Flat, Flat, Flat]);
    // So is SRDH named as the order; two levels trace it when asked (a tree over instances).
    let srdh = RenderSettings {
        shadow_order: Pick::Fixed("srdh".parse().unwrap()),
        ..RenderSettings::default()
    };
    assert_eq!(structures(1, &srdh), [Flat, Flat, Flat]);
    let instanced = scene(100);
    let two_level_srdh = RenderSettings {
        structure: Pick::Fixed(SceneStructure::TwoLevel),
        ..srdh
    };
    assert!(two_level_srdh.validate().is_ok());
    assert_eq!(
        render(&instanced, &two_level_srdh).structure,
        SceneStructure::TwoLevel
    );
    // Settings two levels lack are refused there.
    let e = RenderSettings {
        structure: Pick::Fixed(SceneStructure::TwoLevel),
        build: Pick::Fixed("osah".parse().unwrap()),
        ..RenderSettings::default()
    }
    .validate()
    .unwrap_err()
    .to_string();
    assert!(e.contains("scene_structure") && e.contains("osah"), "{e}");
    // Sorting is one of them too.
    let sorted = RenderSettings {
        shadow_order: Pick::Fixed("sorted".parse().unwrap()),
        ..RenderSettings::default()
    };
    let two_level_sorted = RenderSettings {
        structure: Pick::Fixed(SceneStructure::TwoLevel),
        ..sorted
    };
    assert!(two_level_sorted.validate().is_ok());
    let r = render(&instanced, &two_level_sorted);
    assert_eq!(r.structure, SceneStructure::TwoLevel);
}

#[test]
fn the_memory_estimate_counts_instances_and_unique_triangles_apart() {
    // A million instances of a 100k-triangle mesh: 1e11 world triangles.
    let mut scene = common::boxes_scene(64);
    scene.resolution = Resolution::new(1920, 1080);
    let n = 316u32; // 316 x 316 grid of quads ~ 200k triangles
    let big = common::grid("big", n / 2);
    let triangles = big.triangles.len() as u64;
    scene.meshes = vec![Arc::new(big)];
    scene.objects = (0..1_000_000)
        .map(|i| {
            let at = DVec3::new((i % 1000) as f64 * 3.0, (i / 1000) as f64 * 3.0, 0.0);
            Object::new(format!("tree{i}"), 0, DMat4::from_translation(at))
        })
        .collect();
    let auto = estimate_render_bytes(&scene, &RenderSettings::default(), 4);
    assert_eq!(auto.world_triangles, 1_000_000 * triangles);
    assert_eq!(auto.instances, 1_000_000);
    assert_eq!(auto.held_triangles, triangles);
    assert!(auto.total() < 2 << 30, "{auto}");
    assert!(auto.to_string().contains("1000000 instances"), "{auto}");
    // A light's SRDH tree on two levels is built over the instances: counted per instance,
    // and the million still fits (the render measured 1.19 GB timed only, BENCHMARKS.md).
    let srdh = RenderSettings {
        shadow_order: Pick::Fixed("srdh".parse().unwrap()),
        structure: Pick::Fixed(SceneStructure::TwoLevel),
        ..RenderSettings::default()
    };
    let with_srdh = estimate_render_bytes(&scene, &srdh, 4);
    let fbto = RenderSettings {
        shadow_order: Pick::Fixed(ShadowOrder::Fbto),
        ..srdh.clone()
    };
    let without = estimate_render_bytes(&scene, &fbto, 4);
    assert!(
        with_srdh.light_bytes >= without.light_bytes + 1_000_000 * 64,
        "{with_srdh:?} against {without:?}"
    );
    assert!(with_srdh.total() < 2 << 30, "{with_srdh}");
    let flat = estimate_render_bytes(&scene, &RenderSettings::baseline(), 4);
    assert_eq!(flat.instances, 0);
    assert!(flat.total() > 1 << 40, "{flat}");
    let _ = (
        Mesh::new("unused", vec![Vec3::ZERO], vec![]),
        TriangleRef::MISS,
    );
}

/// A room of meshes used once (a floor, four boxes), the same `Arc`s every frame, and one
/// character that deforms (a new mesh each frame) and moves.
struct Room {
    meshes: Vec<Arc<Mesh>>,
}

impl Room {
    fn new() -> Self {
        let cube = common::cube("cube");
        let mut meshes = vec![Arc::new(common::grid("floor", 40))];
        meshes.extend((0..4).map(|_| Arc::new(cube.clone())));
        Room { meshes }
    }

    fn with_character(&self, frame: i32) -> Scene {
        let mut m = common::sphere("character", 10, 20);
        for p in &mut m.positions {
            p.z *= 1.0 + 0.1 * frame as f32;
        }
        self.with_mesh(frame, m)
    }

    /// The room with `m` as the character.
    fn with_mesh(&self, frame: i32, m: Mesh) -> Scene {
        // 48x36 pixels: few rays for its triangles, so a flat rebuild outweighs the trace.
        let mut s = common::boxes_scene(48);
        s.frame = frame;
        s.meshes = self.meshes.clone();
        for (i, o) in s.objects.iter_mut().enumerate() {
            o.mesh = i;
        }
        s.meshes.push(Arc::new(m));
        let t = frame as f64 * 0.7;
        s.objects.push(Object::new(
            "character",
            s.meshes.len() - 1,
            DMat4::from_translation(DVec3::new(t - 3.0, 1.0, 0.8)),
        ));
        s
    }
}

#[test]
fn a_moving_character_rebuilds_its_own_tree_not_the_rooms() {
    let s = settings(SceneStructure::TwoLevel, BvhWidth::Eight, ShadowOrder::Fbto);
    let mut renderer = Renderer::new();
    let room = Room::new();
    let (mut built, mut refit) = (Vec::new(), Vec::new());
    for frame in 1..=4 {
        let scene = room.with_character(frame);
        let r = renderer.render("room", &scene, &s).unwrap();
        let trees = renderer.scene_trees().unwrap().two_level().unwrap();
        built.push(trees.meshes_built());
        refit.push(trees.meshes_refit());
        // The room is the group tree: the flat tree's triangles, so the same shadows but at
        // the character's edges.
        let flat = render(&scene, &RenderSettings::baseline());
        let (masks, hits) = differing(&flat, &r);
        assert!(masks <= 20 && hits <= 10, "frame {frame}: {masks} {hits}");
    }
    // Frame 1: all in the group. Frame 2: the character changed, so it gets its own tree and
    // the group is rebuilt without it. Then only the character's tree, refit (it deforms).
    assert_eq!(built, vec![1, 2, 0, 0]);
    assert_eq!(refit, vec![0, 0, 1, 1]);
}

#[test]
fn a_deformed_mesh_is_refit_from_its_own_tree_when_the_mesh_list_is_reordered() {
    let s = settings(SceneStructure::TwoLevel, BvhWidth::Eight, ShadowOrder::Fbto);
    let mut renderer = Renderer::new();
    let room = Room::new();
    let mut refit = Vec::new();
    for frame in 1..=4 {
        let mut scene = room.with_character(frame);
        if frame >= 3 {
            // The character's mesh moves from last to first (as an exporter's order may).
            let n = scene.meshes.len();
            scene.meshes.rotate_right(1);
            for o in &mut scene.objects {
                o.mesh = (o.mesh + 1) % n;
            }
        }
        let r = renderer.render("room", &scene, &s).unwrap();
        let trees = renderer.scene_trees().unwrap().two_level().unwrap();
        refit.push(trees.meshes_refit());
        let flat = render(&scene, &RenderSettings::baseline());
        let (masks, hits) = differing(&flat, &r);
        assert!(masks <= 20 && hits <= 10, "frame {frame}: {masks} {hits}");
    }
    // Frame 3 pairs the character with last frame's character tree by name, not with the
    // tree of the mesh last frame held at its new index (the floor, in the group: a build).
    assert_eq!(refit, vec![0, 0, 1, 1]);
}

/// The character twisted about its X axis, more every frame: its tree wears.
fn twisted(frame: i32) -> Mesh {
    let mut m = common::sphere("character", 10, 20);
    for p in &mut m.positions {
        let (sin, cos) = (0.5 * frame as f32 * p.x).sin_cos();
        *p = Vec3::new(p.x, cos * p.y - sin * p.z, sin * p.y + cos * p.z);
    }
    m
}

#[test]
fn a_deforming_character_is_refit_until_worn_and_casts_what_a_build_casts() {
    let room = Room::new();
    let sato = ShadowOrder::from_str("sato").unwrap();
    for s in [
        settings(SceneStructure::TwoLevel, BvhWidth::Two, ShadowOrder::Fbto),
        settings(SceneStructure::TwoLevel, BvhWidth::Eight, sato),
    ] {
        let mut renderer = Renderer::new();
        let mut made = Vec::new();
        for frame in 1..=8 {
            let r = renderer.render("room", &room.with_mesh(frame, twisted(frame)), &s);
            let r = r.unwrap();
            let trees = renderer.scene_trees().unwrap().two_level().unwrap();
            made.push((trees.meshes_built(), trees.meshes_refit()));
            // The rows say how many trees were refit.
            let refit = trees.meshes_refit() as u64;
            assert!(
                r.stats.iter().all(|row| row.trees_refit == refit),
                "{:?}",
                r.stats
            );
            if frame < 3 {
                continue;
            }
            // A renderer whose last frame had another triangle list builds the character's
            // tree this frame: the same shadows and hits, exactly.
            let mut fresh = Renderer::new();
            let mut other = twisted(frame - 1);
            other.triangles.reverse();
            fresh
                .render("room", &room.with_mesh(frame - 1, other), &s)
                .unwrap();
            let b = fresh.render("room", &room.with_mesh(frame, twisted(frame)), &s);
            let trees = fresh.scene_trees().unwrap().two_level().unwrap();
            assert_eq!((trees.meshes_built(), trees.meshes_refit()), (2, 0));
            assert_eq!(differing(&r, &b.unwrap()), (0, 0), "frame {frame}");
        }
        // Frame 2 gives the character its own tree, refit from frame 3 until the twist wears
        // it past the limit, then built again and refit after.
        assert_eq!(made[..3], [(1, 0), (2, 0), (0, 1)]);
        let rebuilt = made[3..]
            .iter()
            .position(|m| *m == (1, 0))
            .expect("{made:?}");
        assert!(
            made[3..3 + rebuilt].iter().all(|m| *m == (0, 1)),
            "{made:?}"
        );
        // Another triangle list takes a build.
        let mut other = twisted(9);
        other.triangles.pop();
        renderer
            .render("room", &room.with_mesh(9, other), &s)
            .unwrap();
        let trees = renderer.scene_trees().unwrap().two_level().unwrap();
        assert_eq!((trees.meshes_built(), trees.meshes_refit()), (1, 0));
    }
}
