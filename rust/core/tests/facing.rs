//! The facing convention: a mesh whose shading normals lean away from its geometric normal is
//! lit and shadowed differently under `facing=shading` (Cycles' convention) than under the
//! default `facing=geometric`, which ignores normals and keeps every answer it gave before.

use std::sync::Arc;

use antumbra_core::render::{Facing, RenderSettings, Renderer};
use antumbra_core::scene::{
    Camera, Light, LightKind, Mesh, Object, Resolution, Scene, TriangleRef,
};
use glam::{DMat4, DVec3, Vec3};

/// A square in z = 0 facing +Z; with `normals`, every corner's normal leans far towards +X.
fn square(normals: bool) -> Mesh {
    let positions = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    let mesh = Mesh::new("square", positions, vec![[0, 1, 2], [0, 2, 3]]);
    if normals {
        let lean = Vec3::new(0.9, 0.0, 0.3).normalize();
        mesh.with_normals(vec![[lean; 3]; 2])
    } else {
        mesh
    }
}

/// A hard sun in the direction `to_sun` (from the surface towards the sun).
fn sun(name: &str, to_sun: DVec3) -> Light {
    let xf = DMat4::look_at_rh(to_sun, DVec3::ZERO, DVec3::Y).inverse();
    Light::new(name, xf, LightKind::Sun { angle: 0.0 })
}

/// The square, 40 m across (`mirror`: mirrored in x, which turns its winding), seen from above,
/// under a sun 10 degrees above its plane on the side the normals lean away from ("Low") and one
/// 10 degrees below it on the side they lean to ("Under").
fn scene(normals: bool, mirror: bool) -> Scene {
    let e = 10f64.to_radians();
    let flip = if mirror { -1.0 } else { 1.0 };
    Scene {
        frame: 1,
        meshes: vec![Arc::new(square(normals))],
        objects: vec![Object::new(
            "Square",
            0,
            DMat4::from_scale(DVec3::new(20.0 * flip, 20.0, 20.0)),
        )],
        camera: Camera::look_at(DVec3::new(0.0, -3.0, 10.0), DVec3::ZERO, DVec3::Z),
        lights: vec![
            sun("Low", DVec3::new(-flip * e.cos(), 0.0, e.sin())),
            sun("Under", DVec3::new(flip * e.cos(), 0.0, -e.sin())),
        ],
        resolution: Resolution::new(64, 48),
        alpha: Default::default(),
    }
}

fn masks(scene: &Scene, facing: Facing) -> Vec<Vec<f32>> {
    let settings = RenderSettings {
        facing,
        ..RenderSettings::baseline()
    };
    let result = Renderer::new().render("facing", scene, &settings).unwrap();
    assert!(result.primary_hits.iter().all(|h| *h != TriangleRef::MISS));
    result.masks.into_iter().map(|m| m.data).collect()
}

fn all(mask: &[f32], value: f32) -> bool {
    mask.iter().all(|&v| v == value)
}

#[test]
fn shading_normals_decide_which_samples_are_behind_the_surface() {
    for mirror in [false, true] {
        let geometric = masks(&scene(true, mirror), Facing::Geometric);
        let shading = masks(&scene(true, mirror), Facing::Shading);
        // The plane's own side: the low sun is in front, the one below behind.
        assert!(
            all(&geometric[0], 1.0) && all(&geometric[1], 0.0),
            "mirror {mirror}"
        );
        // The normals lean away from the low sun and towards the one below the plane, whose
        // rays then leave from the plane's back and meet nothing.
        assert!(
            all(&shading[0], 0.0) && all(&shading[1], 1.0),
            "mirror {mirror}"
        );
    }
}

#[test]
fn the_default_is_geometric_and_ignores_normals() {
    assert_eq!(RenderSettings::baseline().facing, Facing::Geometric);
    let plain = Renderer::new()
        .render("facing", &scene(false, false), &RenderSettings::baseline())
        .unwrap();
    let with_normals = Renderer::new()
        .render("facing", &scene(true, false), &RenderSettings::baseline())
        .unwrap();
    for (a, b) in plain.masks.iter().zip(&with_normals.masks) {
        assert_eq!(a.data, b.data, "{}", a.name);
    }
    let counts = |r: &antumbra_core::stats::StatsRow| {
        (
            r.rays,
            r.back_facing,
            r.occluded_fraction,
            r.nts_per_ray,
            r.nbox_per_ray,
        )
    };
    let (a, b): (Vec<_>, Vec<_>) = (
        plain.stats.iter().map(counts).collect(),
        with_normals.stats.iter().map(counts).collect(),
    );
    assert_eq!(a, b);
    // Without normals the shading convention falls back to the geometric normal.
    assert_eq!(
        masks(&scene(false, true), Facing::Shading),
        masks(&scene(false, true), Facing::Geometric)
    );
}

#[test]
fn each_object_reads_its_own_normal_matrix() {
    // Strips side by side, every other one turned half round z (its normals then lean towards
    // -X), under a sun low in the west and one low in the east: under the shading convention a
    // strip is dark to the sun its normals lean away from, whichever strip came before.
    let e = 10f64.to_radians();
    let mut scene = scene(true, false);
    scene.objects = (0..8)
        .map(|i| {
            let turn = if i % 2 == 1 {
                std::f64::consts::PI
            } else {
                0.0
            };
            let at = DVec3::new(-7.0 + 2.0 * i as f64, 0.0, 0.0);
            let xf = DMat4::from_translation(at)
                * DMat4::from_rotation_z(turn)
                * DMat4::from_scale(DVec3::new(1.0, 20.0, 1.0));
            Object::new(format!("strip{i}"), 0, xf)
        })
        .collect();
    scene.lights = vec![
        sun("West", DVec3::new(-e.cos(), 0.0, e.sin())),
        sun("East", DVec3::new(e.cos(), 0.0, e.sin())),
    ];
    let settings = RenderSettings {
        facing: Facing::Shading,
        ..RenderSettings::baseline()
    };
    let r = Renderer::new().render("facing", &scene, &settings).unwrap();
    let mut seen = [0usize; 2];
    for (pixel, hit) in r.primary_hits.iter().enumerate() {
        if *hit == TriangleRef::MISS {
            continue;
        }
        let turned = (hit.object % 2) as usize;
        seen[turned] += 1;
        let (west, east) = (r.masks[0].data[pixel], r.masks[1].data[pixel]);
        let expect = if turned == 1 { (1.0, 0.0) } else { (0.0, 1.0) };
        assert_eq!((west, east), expect, "pixel {pixel}, strip {}", hit.object);
    }
    assert!(seen[0] > 100 && seen[1] > 100, "{seen:?}");
}
