//! The frame pipeline: answers do not depend on the method or on counting, statistics equal the
//! sums of the heat maps, unchanged geometry is not rebuilt, the visible set is what the camera saw.

mod common;

use antumbra_core::build::BuildSettings;
use antumbra_core::order::AnyHitOrder;
use antumbra_core::render::{Pick, RenderSettings, Renderer, StatsMode};
use antumbra_core::scene::{LightKind, TriangleRef};
use glam::{DMat4, DVec3};

fn soft_scene() -> antumbra_core::scene::Scene {
    let mut s = common::boxes_scene(96);
    s.lights[0].kind = LightKind::Sun { angle: 0.1 };
    s.lights[1].kind = LightKind::Point { radius: 0.5 };
    s
}

#[test]
fn masks_do_not_depend_on_order_leaf_size_or_counting() {
    let scene = soft_scene();
    let base = Renderer::new()
        .render("t", &scene, &RenderSettings::baseline())
        .unwrap();
    for (order, leaf, stats) in [
        (AnyHitOrder::Stored, 1, StatsMode::Counts),
        (AnyHitOrder::NearFirst, 16, StatsMode::TimingOnly),
        (AnyHitOrder::Stored, 4, StatsMode::CountsAndTiming),
    ] {
        let settings = RenderSettings {
            shadow_order: Pick::Fixed(order.into()),
            build_settings: BuildSettings {
                max_leaf_size: leaf,
                ..BuildSettings::default()
            },
            stats,
            ..RenderSettings::baseline()
        };
        let r = Renderer::new().render("t", &scene, &settings).unwrap();
        assert_eq!(r.masks, base.masks);
        assert_eq!(r.primary_hits, base.primary_hits);
        assert_eq!(r.visible, base.visible);
    }
}

#[test]
fn masks_do_not_depend_on_width_or_order_and_sorting_reports_its_cost() {
    let scene = soft_scene();
    let base = Renderer::new()
        .render("t", &scene, &RenderSettings::baseline())
        .unwrap();
    for width in ["2", "4", "8"] {
        for order in [
            "stored",
            "fbto",
            "sato",
            "rtsah",
            "random:seed=1",
            "sorted:budget=0.2",
        ] {
            for stats in [StatsMode::Counts, StatsMode::TimingOnly] {
                let settings = RenderSettings {
                    width: width.parse().unwrap(),
                    shadow_order: order.parse().unwrap(),
                    stats,
                    ..RenderSettings::baseline()
                };
                let r = Renderer::new().render("t", &scene, &settings).unwrap();
                assert_eq!(r.masks, base.masks, "{width} {order}");
                assert_eq!(r.primary_hits, base.primary_hits, "{width} {order}");
                let shadow: Vec<_> = r.stats.iter().filter(|s| s.pass == "shadow").collect();
                assert!(shadow.len() > 1);
                let per_tree = settings
                    .shadow_order
                    .fixed()
                    .is_some_and(|o| o.is_per_tree());
                for (i, row) in shadow.iter().enumerate() {
                    assert_eq!(
                        row.method,
                        format!("sah/bin{width}/{}", settings.shadow_order)
                    );
                    // Sorted orders cost each light; a per-tree order is made once, reported
                    // on the first row.
                    let costs = order.starts_with("sorted") || (per_tree && i == 0);
                    assert_eq!(row.prepare_ms > 0.0, costs, "{row:?}");
                }
            }
        }
    }
}

#[test]
fn a_per_tree_order_is_made_once_per_tree_and_shared_by_lights_and_frames() {
    let scene = soft_scene();
    let base = Renderer::new()
        .render("t", &scene, &RenderSettings::baseline())
        .unwrap();
    let settings = |order: &str| RenderSettings {
        width: "8".parse().unwrap(),
        shadow_order: order.parse().unwrap(),
        ..RenderSettings::baseline()
    };
    let shadow_prepare_ms = |r: &antumbra_core::render::FrameResult| -> Vec<f64> {
        r.stats
            .iter()
            .filter(|s| s.pass == "shadow")
            .map(|s| s.prepare_ms)
            .collect()
    };
    let mut renderer = Renderer::new();
    let first = renderer.render("t", &scene, &settings("sato")).unwrap();
    let ms = shadow_prepare_ms(&first);
    assert!(
        ms.len() > 1 && ms[0] > 0.0,
        "made on the first frame: {ms:?}"
    );
    assert!(
        ms[1..].iter().all(|&m| m == 0.0),
        "shared by the lights: {ms:?}"
    );
    let second = renderer.render("t", &scene, &settings("sato")).unwrap();
    assert!(
        shadow_prepare_ms(&second).iter().all(|&m| m == 0.0),
        "reused while the tree is"
    );
    // Another per-tree order is made anew, and none changes an answer.
    let third = renderer.render("t", &scene, &settings("rtsah")).unwrap();
    assert!(shadow_prepare_ms(&third)[0] > 0.0);
    for r in [&first, &second, &third] {
        assert_eq!(r.masks, base.masks);
    }
}

#[test]
fn a_static_scene_keeps_its_wide_tree_across_frames() {
    let scene = soft_scene();
    let settings = RenderSettings {
        width: "8".parse().unwrap(),
        shadow_order: "sorted".parse().unwrap(),
        ..RenderSettings::baseline()
    };
    let mut renderer = Renderer::new();
    let first = renderer.render("t", &scene, &settings).unwrap();
    let second = renderer.render("t", &scene, &settings).unwrap();
    assert_eq!(renderer.builds, 1);
    assert!(first.stats.iter().all(|r| r.rebuilt));
    assert!(second.stats.iter().all(|r| !r.rebuilt && r.build_ms == 0.0));
    assert_eq!(first.masks, second.masks);
}

#[test]
fn statistics_are_the_sums_of_the_heat_maps() {
    let r = Renderer::new()
        .render("t", &soft_scene(), &RenderSettings::baseline())
        .unwrap();
    let heat = r.heat.as_ref().unwrap();
    let sum = |p: &antumbra_core::image::ImagePlane| p.data.iter().map(|v| *v as f64).sum::<f64>();
    let primary = &r.stats[0];
    assert_eq!(primary.pass, "primary");
    assert_eq!(primary.rays, (r.width * r.height) as u64);
    assert_eq!(
        sum(&heat.primary[0]),
        primary.nb_per_ray * primary.rays as f64
    );
    assert_eq!(
        sum(&heat.primary[2]),
        primary.nt_per_ray * primary.rays as f64
    );
    let shadow_rows: Vec<_> = r.stats.iter().filter(|s| s.pass == "shadow").collect();
    assert_eq!(shadow_rows.len(), 2);
    let nb: f64 = shadow_rows
        .iter()
        .map(|s| (s.nb_per_ray * s.rays as f64).round())
        .sum();
    let nl: f64 = shadow_rows
        .iter()
        .map(|s| (s.nl_per_ray * s.rays as f64).round())
        .sum();
    assert_eq!(sum(&heat.shadow[0]), nb);
    assert_eq!(sum(&heat.shadow[1]), nl);
    // Soft lights take spp samples per pixel.
    assert!(shadow_rows
        .iter()
        .all(|s| s.rays > (r.width * r.height) as u64));
}

#[test]
fn soft_shadows_have_penumbrae_and_hard_ones_do_not() {
    let soft = Renderer::new()
        .render(
            "t",
            &soft_scene(),
            &RenderSettings {
                spp: 16,
                ..RenderSettings::baseline()
            },
        )
        .unwrap();
    let hard = Renderer::new()
        .render("t", &common::boxes_scene(96), &RenderSettings::baseline())
        .unwrap();
    let fractional = |m: &[f32]| m.iter().filter(|v| **v > 0.0 && **v < 1.0).count();
    assert_eq!(fractional(&hard.masks[0].data), 0);
    assert!(fractional(&soft.masks[0].data) > 20);
    assert!(fractional(&soft.masks[1].data) > 20);
}

#[test]
fn unchanged_geometry_is_not_rebuilt() {
    let scene = common::boxes_scene(32);
    let mut renderer = Renderer::new();
    let settings = RenderSettings::baseline();
    let mut f = scene.clone();
    for frame in 1..=3 {
        f.frame = frame;
        // The camera moves; geometry does not.
        f.camera.world_from_camera =
            DMat4::from_translation(DVec3::new(0.1 * frame as f64, 0.0, 0.0))
                * scene.camera.world_from_camera;
        let r = renderer.render("t", &f, &settings).unwrap();
        assert_eq!(r.stats[0].rebuilt, frame == 1);
    }
    assert_eq!(renderer.builds, 1);
    f.objects[1].world_from_object =
        DMat4::from_translation(DVec3::X) * f.objects[1].world_from_object;
    let r = renderer.render("t", &f, &settings).unwrap();
    assert!(r.stats[0].rebuilt);
    assert_eq!(renderer.builds, 2);
}

#[test]
fn visible_set_is_what_the_camera_saw() {
    let scene = common::boxes_scene(64);
    let mut renderer = Renderer::new();
    let r = renderer
        .render("t", &scene, &RenderSettings::baseline())
        .unwrap();
    let (geometry, _, _) = renderer.current().unwrap();
    // Every pixel's hit is a triangle of the camera set, and the visible set is their union.
    let mut expected: Vec<_> = r
        .primary_hits
        .iter()
        .filter(|h| **h != TriangleRef::MISS)
        .inspect(|h| assert!(geometry.camera.refs.binary_search(h).is_ok(), "{h:?}"))
        .copied()
        .collect();
    expected.sort();
    expected.dedup();
    assert_eq!(r.visible, expected);
    assert!(!r.visible.is_empty() && r.visible.len() < geometry.camera.len());
    assert_eq!(renderer.previous_visible, r.visible);
}

#[test]
fn objects_without_shadows_are_seen_but_cast_none() {
    let scene = common::boxes_scene(96);
    let with = Renderer::new()
        .render("t", &scene, &RenderSettings::baseline())
        .unwrap();
    let mut no_shadow = scene.clone();
    for o in no_shadow.objects.iter_mut().skip(1) {
        o.casts_shadow = false;
    }
    let without = Renderer::new()
        .render("t", &no_shadow, &RenderSettings::baseline())
        .unwrap();
    assert_eq!(with.primary_hits, without.primary_hits);
    let dark = |r: &antumbra_core::render::FrameResult| {
        r.masks[0].data.iter().filter(|v| **v == 0.0).count()
    };
    assert!(dark(&without) < dark(&with));
    // A light with shadows off gets no mask and no rays.
    let mut off = scene;
    off.lights[1].casts_shadow = false;
    let r = Renderer::new()
        .render("t", &off, &RenderSettings::baseline())
        .unwrap();
    assert_eq!(r.masks.len(), 1);
}

/// The object-id pass is, per pixel, the object of the nearest hit found by brute force over
/// each object's triangles on its own (ties to the lower object index), -1 where nothing is hit.
#[test]
fn object_ids_equal_brute_force_per_object() {
    use antumbra_core::render::{PrimaryRays, OBJECT_PLANE};
    use antumbra_core::trace::brute_closest_hit;
    use glam::Vec3;

    let mut scene = common::boxes_scene(64);
    // The boxes share a mesh, and one is hidden from the camera: ids must still be positions
    // in the frame's object list, not in the camera's triangle set.
    scene.objects[2].visible_to_camera = false;
    let mut renderer = Renderer::new();
    let r = renderer
        .render("t", &scene, &RenderSettings::baseline())
        .unwrap();
    let (geometry, _, _) = renderer.current().unwrap();
    let space = geometry.space;
    let rays = PrimaryRays::new(&scene.camera, &scene.resolution, &space);

    // Each camera-visible object's triangles in render space, transformed as the renderer does.
    let per_object: Vec<Option<Vec<[Vec3; 3]>>> = scene
        .objects
        .iter()
        .map(|o| {
            o.visible_to_camera.then(|| {
                let mesh = &scene.meshes[o.mesh];
                let m = DMat4::from_scale(DVec3::splat(space.scale))
                    * DMat4::from_translation(-space.origin)
                    * o.world_from_object;
                mesh.triangles
                    .iter()
                    .map(|t| {
                        t.map(|i| {
                            m.transform_point3(mesh.positions[i as usize].as_dvec3())
                                .as_vec3()
                        })
                    })
                    .collect()
            })
        })
        .collect();

    let plane = r.object_plane();
    assert_eq!(plane.name, OBJECT_PLANE);
    assert_eq!((plane.width, plane.height), (r.width, r.height));
    let mut counts = vec![0usize; scene.objects.len()];
    let mut misses = 0;
    for y in 0..r.height {
        for x in 0..r.width {
            let ray = rays.ray(x, y);
            let mut best: Option<(f32, usize)> = None;
            for (object, tris) in per_object.iter().enumerate() {
                let Some(tris) = tris else { continue };
                if let Some(h) = brute_closest_hit(tris, &ray) {
                    let closer = match best {
                        None => true,
                        Some((t, _)) => h.t < t,
                    };
                    if closer {
                        best = Some((h.t, object));
                    }
                }
            }
            let i = (y * r.width + x) as usize;
            let want = best.map_or(u32::MAX, |(_, o)| o as u32);
            assert_eq!(r.primary_objects[i], want, "pixel ({x}, {y})");
            assert_eq!(
                plane.data[i],
                best.map_or(-1.0, |(_, o)| o as f32),
                "pixel ({x}, {y})"
            );
            match best {
                Some((_, o)) => counts[o] += 1,
                None => misses += 1,
            }
        }
    }
    // The check means something: the ground, several boxes and the sky are all in view, and
    // the hidden box is nowhere.
    assert!(misses > 0, "no background pixel");
    assert_eq!(counts[2], 0);
    assert!(counts.iter().filter(|&&c| c > 0).count() >= 4, "{counts:?}");
}

#[test]
fn srdh_masks_equal_the_default_and_rows_report_the_light_tree() {
    let scene = soft_scene();
    let base = Renderer::new()
        .render("t", &scene, &RenderSettings::baseline())
        .unwrap();
    for width in ["2", "8"] {
        for order in [
            "srdh:min_occluded=0",
            "srdh:rays=all:leaf=2:kernels=constant:min_occluded=0",
            "srdh:rays=0.1:bins=8:kernels=directional:min_occluded=0",
            "srdh:min_occluded=1",
        ] {
            let settings = RenderSettings {
                width: width.parse().unwrap(),
                shadow_order: order.parse().unwrap(),
                stats: StatsMode::CountsAndTiming,
                ..RenderSettings::baseline()
            };
            let r = Renderer::new().render("t", &scene, &settings).unwrap();
            assert_eq!(r.masks, base.masks, "{width} {order}");
            for row in r.stats.iter().filter(|s| s.pass == "shadow") {
                assert!(row.prepare_ms > 0.0, "{row:?}");
                let default_row = base
                    .stats
                    .iter()
                    .find(|b| b.pass == "shadow" && b.light == row.light)
                    .unwrap();
                // min_occluded=1: no light is fully occluded here, all trace the SAH tree.
                let own_tree = !order.ends_with("min_occluded=1");
                assert_eq!(row.bvh_bytes != default_row.bvh_bytes, own_tree, "{row:?}");
            }
        }
    }
}

#[test]
fn light_names_never_fail_a_write_nor_hide_a_plane() {
    // Named like a heat map, twice the same, too long for an EXR channel, and two that clean
    // to the same file name.
    let mut scene = common::boxes_scene(16);
    let names = ["N_B", "Sun", "Sun", &"x".repeat(300), "a/b", "a_b"];
    let template = scene.lights[0].clone();
    scene.lights = names
        .iter()
        .map(|n| {
            let mut l = template.clone();
            l.name = n.to_string();
            l
        })
        .collect();
    let result = Renderer::new()
        .render("names", &scene, &RenderSettings::baseline())
        .unwrap();
    let named = antumbra_core::output::mask_names(&result);
    let planes: Vec<&str> = named.iter().map(|n| n.plane.as_str()).collect();
    assert_eq!(&planes[..3], ["shadow.N_B#2", "shadow.Sun", "shadow.Sun#2"]);
    assert!(planes[3].len() <= 255 && planes[3].starts_with("shadow.xxx"));
    assert_eq!(&planes[4..], ["shadow.a/b", "shadow.a_b#2"]);
    let dir = tempfile::tempdir().unwrap();
    let files = antumbra_core::output::write_frame_files(
        dir.path(),
        &result,
        &antumbra_core::output::Outputs::default(),
    )
    .unwrap();
    let exr = antumbra_core::output::read_exr(&dir.path().join("frame_0001.exr")).unwrap();
    let channels: std::collections::HashSet<&str> = exr.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(channels.len(), exr.len(), "every plane is its own channel");
    for (name, mask) in named.iter().zip(&result.masks) {
        let plane = exr.iter().find(|p| p.name == name.plane).unwrap();
        assert_eq!(plane.data, mask.data, "{}", name.plane);
    }
    let pngs: std::collections::HashSet<&String> =
        files.files.iter().filter(|f| f.ends_with(".png")).collect();
    assert_eq!(
        pngs.len(),
        files.files.iter().filter(|f| f.ends_with(".png")).count()
    );
    assert_eq!(
        pngs.len(),
        names.len() + 1 + 6,
        "a PNG per mask, combined and heat map"
    );
}

#[test]
fn lights_differing_in_non_ascii_letters_keep_their_names_and_files() {
    // Their PNGs were `shadow_Lamp__` both, so the second light's plane became `Lamp ö#2`.
    let mut scene = common::boxes_scene(16);
    let template = scene.lights[0].clone();
    scene.lights = ["Lamp ä", "Lamp ö", "Lampe 灯"]
        .iter()
        .map(|n| {
            let mut l = template.clone();
            l.name = n.to_string();
            l
        })
        .collect();
    let result = Renderer::new()
        .render("names", &scene, &RenderSettings::baseline())
        .unwrap();
    let named = antumbra_core::output::mask_names(&result);
    let planes: Vec<&str> = named.iter().map(|n| n.plane.as_str()).collect();
    assert_eq!(
        planes,
        ["shadow.Lamp ä", "shadow.Lamp ö", "shadow.Lampe 灯"]
    );
    let dir = tempfile::tempdir().unwrap();
    let files = antumbra_core::output::write_frame_files(
        dir.path(),
        &result,
        &antumbra_core::output::Outputs::default(),
    )
    .unwrap();
    for light in ["Lamp_ä", "Lamp_ö", "Lampe_灯"] {
        let name = format!("frame_0001_shadow_{light}.png");
        assert!(files.files.contains(&name), "{name} in {:?}", files.files);
        assert!(dir.path().join(&name).is_file(), "{name}");
    }
    let exr = antumbra_core::output::read_exr(&dir.path().join("frame_0001.exr")).unwrap();
    for plane in planes {
        assert!(exr.iter().any(|p| p.name == plane), "{plane}");
    }
}

#[test]
fn the_frame_trees_are_the_trees_the_passes_traced() {
    use antumbra_core::bvh::BvhWidth;
    use antumbra_core::render::CameraTree;
    let scene = soft_scene();
    for width in [BvhWidth::Two, BvhWidth::Eight] {
        let settings = RenderSettings {
            width,
            shadow_order: Pick::Fixed("sato".parse().unwrap()),
            ..RenderSettings::baseline()
        };
        let mut r = Renderer::new();
        let frame = r.render("t", &scene, &settings).unwrap();
        let trees = r.trees().expect("a rendered frame keeps its trees");
        let primary = &frame.stats[0];
        let nodes = match trees.camera() {
            CameraTree::Binary(b) => b.nodes.len(),
            CameraTree::Wide(t) => t.node_count(),
        };
        assert_eq!(nodes as u64, primary.bvh_nodes, "{width}: the camera tree");
        assert_eq!(
            matches!(trees.camera(), CameraTree::Wide(_)),
            width != BvhWidth::Two,
            "{width}: widths 4 and 8 trace the collapse"
        );
        // Every object casts shadows: the shadow rays trace the camera's tree.
        assert!(std::ptr::eq(trees.shadow_bvh(), trees.camera_bvh()));
        // SATO is an order the binary traversal lacks: at width 2 too, shadow rays trace the
        // (2-wide) collapse, with the order made once for the tree and read by every light.
        let shadow = trees.shadow();
        let traced = shadow.wide.map(|t| t.node_count() as u64);
        for row in frame.stats.iter().filter(|s| s.pass == "shadow") {
            assert_eq!(Some(row.bvh_nodes), traced, "{width}: {}", row.light);
        }
        assert!(shadow.per_tree.is_some_and(|p| p.0.to_string() == "sato"));
    }
}
