//! Shared test scenes.
#![allow(dead_code)]

use std::sync::Arc;

use antumbra_core::scene::{Camera, Light, LightKind, Mesh, Object, Resolution, Scene};
use glam::{DMat4, DVec3, Vec3};

/// A 2x2 ground quad at z = 0.
pub fn ground() -> Mesh {
    Mesh::new(
        "ground",
        vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

/// A unit cube centred on the origin.
pub fn cube() -> Mesh {
    let p: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -0.5 } else { 0.5 },
                if i & 2 == 0 { -0.5 } else { 0.5 },
                if i & 4 == 0 { -0.5 } else { 0.5 },
            )
        })
        .collect();
    let t = vec![
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ];
    Mesh::new("cube", p, t)
}

/// Ground scaled up, a box standing on it (moving with `frame`), a tilted sun and a spot light.
pub fn tiny_scene(frame: i32) -> Scene {
    let ground = Arc::new(ground());
    let cube = Arc::new(cube());
    let x = 0.1 * frame as f64;
    let mut hidden = Object::new(
        "hidden box",
        1,
        DMat4::from_translation(DVec3::new(-1.5, 1.0, 0.25)) * DMat4::from_scale(DVec3::splat(0.5)),
    );
    hidden.visible_to_camera = false;
    let mut spot = Light::new(
        "spot",
        DMat4::from_translation(DVec3::new(0.0, 0.0, 4.0)),
        LightKind::Spot {
            radius: 0.1,
            spot_size: 1.2,
            spot_blend: 0.15,
        },
    );
    spot.casts_shadow = frame % 2 == 0;
    Scene {
        frame,
        meshes: vec![ground, cube],
        objects: vec![
            Object::new("ground", 0, DMat4::from_scale(DVec3::splat(4.0))),
            Object::new("box", 1, DMat4::from_translation(DVec3::new(x, 0.0, 0.5))),
            hidden,
        ],
        camera: Camera::look_at(
            DVec3::new(0.0, -6.0, 4.0),
            DVec3::new(0.0, 0.0, 0.3),
            DVec3::Z,
        ),
        lights: vec![
            Light::new(
                "sun",
                DMat4::from_rotation_x(0.4) * DMat4::from_rotation_y(0.3),
                LightKind::Sun { angle: 0.05 },
            ),
            spot,
        ],
        resolution: Resolution::new(32, 24),
        alpha: Default::default(),
    }
}

/// Fields equal, meshes compared by content.
pub fn assert_same_scene(a: &Scene, b: &Scene) {
    assert_eq!(a.frame, b.frame);
    assert_eq!(a.objects.len(), b.objects.len());
    for (x, y) in a.objects.iter().zip(&b.objects) {
        assert_eq!(x.name, y.name);
        assert_eq!(*a.meshes[x.mesh], *b.meshes[y.mesh]);
        assert_eq!(x.world_from_object, y.world_from_object);
        assert_eq!(x.visible_to_camera, y.visible_to_camera);
        assert_eq!(x.casts_shadow, y.casts_shadow);
    }
    assert_eq!(a.camera, b.camera);
    assert_eq!(a.lights, b.lights);
    assert_eq!(a.resolution, b.resolution);
}
