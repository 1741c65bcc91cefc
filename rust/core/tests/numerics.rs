//! Numerics at the extremes: position and scale of a scene do not change its shadows, grazing
//! light gives no acne, bad input is rejected with errors that name the culprit.

mod common;

use std::sync::Arc;

use antumbra_core::bvh::BvhWidth;
use antumbra_core::render::{Pick, RenderSettings, Renderer};
use antumbra_core::scene::{FrameGeometry, Light, LightKind, Mesh, Object, Scene};
use antumbra_core::trace::RayMode;
use antumbra_core::Error;
use glam::{DMat4, DVec3, Vec3};

fn masks(scene: &Scene) -> Vec<Vec<f32>> {
    masks_with(scene, &RenderSettings::baseline())
}

fn masks_with(scene: &Scene, settings: &RenderSettings) -> Vec<Vec<f32>> {
    let result = Renderer::new().render("test", scene, settings).unwrap();
    result.masks.into_iter().map(|m| m.data).collect()
}

/// The 8-wide tree traced in packets (each lane's own watertight test), which must give the
/// baseline's shadows wherever the scene is.
fn packets() -> RenderSettings {
    RenderSettings {
        width: BvhWidth::Eight,
        rays: Pick::Fixed(RayMode::Packet),
        ..RenderSettings::baseline()
    }
}

fn differing(a: &[Vec<f32>], b: &[Vec<f32>]) -> usize {
    a.iter()
        .zip(b)
        .map(|(x, y)| x.iter().zip(y).filter(|(p, q)| p != q).count())
        .sum()
}

fn shadowed(m: &[Vec<f32>]) -> usize {
    m.iter()
        .map(|x| x.iter().filter(|v| **v < 1.0).count())
        .sum()
}

#[test]
fn translation_by_a_million_gives_the_same_shadows() {
    let scene = common::boxes_scene(160);
    let reference = masks(&scene);
    assert!(
        shadowed(&reference) > 500,
        "the scene must cast shadows to test anything"
    );
    for offset in [DVec3::splat(1e6), DVec3::new(-1e6, 3e5, 1e6)] {
        let moved = common::transform_scene(&scene, DMat4::from_translation(offset));
        assert_eq!(differing(&reference, &masks(&moved)), 0, "offset {offset}");
        let packed = masks_with(&moved, &packets());
        assert_eq!(
            differing(&reference, &packed),
            0,
            "offset {offset}, packets"
        );
    }
}

#[test]
fn scaling_by_powers_of_ten_gives_the_same_shadows() {
    let scene = common::boxes_scene(160);
    let reference = masks(&scene);
    for k in [1e-4, 1e4] {
        let mut scaled = common::transform_scene(&scene, DMat4::from_scale(DVec3::splat(k)));
        scaled.camera.clip_start *= k;
        scaled.camera.clip_end *= k;
        // Mesh vertices stay as they are; the scale lives in the f64 matrices, as in Blender.
        assert_eq!(differing(&reference, &masks(&scaled)), 0, "scale {k}");
        let packed = masks_with(&scaled, &packets());
        assert_eq!(differing(&reference, &packed), 0, "scale {k}, packets");
    }
}

#[test]
fn vertices_baked_far_from_the_origin_differ_only_by_input_rounding() {
    // When 1e6 is baked into f32 vertices the input itself is rounded to 1/16 unit: shadows may
    // move by that much. Measure it: the difference stays a thin fringe at shadow edges.
    let scene = common::boxes_scene(160);
    let reference = masks(&scene);
    let mut baked = scene.clone();
    baked.meshes = scene
        .objects
        .iter()
        .map(|o| {
            let m = &scene.meshes[o.mesh];
            let positions = m
                .positions
                .iter()
                .map(|p| (o.world_from_object.transform_point3(p.as_dvec3()) + 1e6).as_vec3())
                .collect();
            Arc::new(Mesh::new(&m.name, positions, m.triangles.clone()))
        })
        .collect();
    for (i, o) in baked.objects.iter_mut().enumerate() {
        o.mesh = i;
        o.world_from_object = DMat4::IDENTITY;
    }
    let baked = common::transform_scene(&baked, DMat4::IDENTITY);
    let mut baked = baked;
    baked.camera.world_from_camera =
        DMat4::from_translation(DVec3::splat(1e6)) * scene.camera.world_from_camera;
    for l in &mut baked.lights {
        l.world_from_light = DMat4::from_translation(DVec3::splat(1e6)) * l.world_from_light;
    }
    let diff = differing(&reference, &masks(&baked));
    let pixels: usize = reference.iter().map(|m| m.len()).sum();
    eprintln!("baked 1e6: {diff} of {pixels} mask pixels differ");
    assert!(diff * 100 < pixels, "{diff} of {pixels} pixels differ");
}

#[test]
fn no_shadow_acne_at_grazing_light() {
    // A finely tessellated plane lit 1 degree above its horizon (89 degrees from the normal),
    // with nothing to cast a shadow: every pixel must be lit, here and far from the origin.
    for offset in [DVec3::ZERO, DVec3::new(1e5, -1e5, 3e3)] {
        let plane = Arc::new(common::grid("plane", 200));
        let elevation = 1f64.to_radians();
        let to_sun = DVec3::new(elevation.cos(), 0.3, elevation.sin()).normalize();
        let sun = Light::new(
            "Sun",
            DMat4::look_at_rh(to_sun, DVec3::ZERO, DVec3::Z).inverse(),
            LightKind::Sun { angle: 0.0 },
        );
        let lamp = Light::new(
            "Lamp",
            DMat4::from_translation(DVec3::new(-50.0, 5.0, 0.9)),
            LightKind::Point { radius: 0.0 },
        );
        let scene = common::transform_scene(
            &Scene {
                frame: 1,
                meshes: vec![plane],
                objects: vec![Object::new(
                    "Plane",
                    0,
                    DMat4::from_scale(DVec3::splat(20.0)),
                )],
                camera: antumbra_core::scene::Camera::look_at(
                    DVec3::new(0.0, -3.0, 10.0),
                    DVec3::ZERO,
                    DVec3::Z,
                ),
                lights: vec![sun, lamp],
                resolution: antumbra_core::scene::Resolution::new(200, 150),
                alpha: Default::default(),
            },
            DMat4::from_translation(offset),
        );
        let m = masks(&scene);
        assert_eq!(shadowed(&m), 0, "self-shadowed pixels at offset {offset}");
    }
}

#[test]
fn tiny_and_huge_triangles_cast_shadows() {
    for size in [1e-6f64, 1e6] {
        let scene = common::transform_scene(
            &common::boxes_scene(120),
            DMat4::from_scale(DVec3::splat(size)),
        );
        let mut scene = scene;
        scene.camera.clip_start *= size;
        scene.camera.clip_end *= size;
        assert!(shadowed(&masks(&scene)) > 300, "size {size}");
    }
}

#[test]
fn degenerate_triangles_are_skipped_and_counted() {
    let mut scene = common::boxes_scene(40);
    let mut m = (*scene.meshes[1]).clone();
    let a = m.positions.len() as u32;
    m.positions.push(Vec3::new(0.0, 0.0, 0.0));
    m.positions.push(Vec3::new(1.0, 1.0, 1.0));
    m.positions.push(Vec3::new(2.0, 2.0, 2.0));
    m.triangles.push([a, a + 1, a + 2]); // collinear
    m.triangles.push([a, a, a + 1]); // repeated index
    scene.meshes[1] = Arc::new(m);
    let g = FrameGeometry::from_scene(&scene).unwrap();
    let boxes = scene.objects.iter().filter(|o| o.mesh == 1).count();
    assert_eq!(g.camera.degenerate, 2 * boxes);
    assert!(masks(&scene).iter().all(|m| !m.is_empty()));
}

#[test]
fn non_finite_input_is_rejected_naming_the_culprit() {
    let mut scene = common::boxes_scene(40);
    let mut m = (*scene.meshes[1]).clone();
    m.positions[5].y = f32::NAN;
    scene.meshes[1] = Arc::new(m);
    let err = Renderer::new()
        .render("t", &scene, &RenderSettings::baseline())
        .unwrap_err();
    assert!(matches!(err, Error::NonFinite { index: 5, .. }), "{err}");
    assert!(err.to_string().contains("mesh 'cube'"), "{err}");

    let mut scene = common::boxes_scene(40);
    scene.objects[2].world_from_object.w_axis.x = f64::INFINITY;
    let err = Renderer::new()
        .render("t", &scene, &RenderSettings::baseline())
        .unwrap_err();
    assert!(err.to_string().contains("object 'Box1'"), "{err}");

    let mut scene = common::boxes_scene(40);
    scene.lights[0].kind = LightKind::Sun { angle: f64::NAN };
    let err = Renderer::new()
        .render("t", &scene, &RenderSettings::baseline())
        .unwrap_err();
    assert!(err.to_string().contains("light 'Sun'.angle"), "{err}");

    let mut scene = common::boxes_scene(40);
    scene.meshes[0] = Arc::new(Mesh::new("bad", vec![Vec3::ZERO], vec![[0, 0, 7]]));
    let err = Renderer::new()
        .render("t", &scene, &RenderSettings::baseline())
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("mesh 'bad': triangle 0 refers to vertex 7"),
        "{err}"
    );
}
