//! Small hand-made scenes for the core's tests.
#![allow(dead_code)]

use std::sync::Arc;

use antumbra_core::sampling::{hash_u32, unit_float};
use antumbra_core::scene::{Camera, Light, LightKind, Mesh, Object, Resolution, Scene};
use glam::{DMat4, DQuat, DVec3, Vec3};

/// An n x n grid of quads (2n^2 triangles) over [-1,1]^2 in the XY plane, shared vertices.
pub fn grid(name: &str, n: u32) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            positions.push(Vec3::new(
                -1.0 + 2.0 * i as f32 / n as f32,
                -1.0 + 2.0 * j as f32 / n as f32,
                0.0,
            ));
        }
    }
    let mut triangles = Vec::new();
    let idx = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            triangles.push([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
            triangles.push([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
        }
    }
    Mesh::new(name, positions, triangles)
}

/// A closed unit cube [-1,1]^3, 12 triangles.
pub fn cube(name: &str) -> Mesh {
    let p: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            )
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let mut t = Vec::new();
    for q in quads {
        t.push([q[0], q[1], q[2]]);
        t.push([q[0], q[2], q[3]]);
    }
    Mesh::new(name, p, t)
}

/// A closed UV sphere of radius 1 with shared vertices: `rings` x `segments` quads.
pub fn sphere(name: &str, rings: u32, segments: u32) -> Mesh {
    let mut positions = vec![Vec3::Z];
    for r in 1..rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = 2.0 * std::f32::consts::PI * s as f32 / segments as f32;
            positions.push(Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ));
        }
    }
    positions.push(Vec3::NEG_Z);
    let south = positions.len() as u32 - 1;
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let mut t = Vec::new();
    for s in 0..segments {
        t.push([0, ring(1, s), ring(1, s + 1)]);
        t.push([south, ring(rings - 1, s + 1), ring(rings - 1, s)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            t.push([ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)]);
            t.push([ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)]);
        }
    }
    Mesh::new(name, positions, t)
}

/// A ground plane with boxes on it, a sun and a point light, seen from above at an angle.
pub fn boxes_scene(resolution: u32) -> Scene {
    let ground = Arc::new(grid("ground", 8));
    let cube = Arc::new(cube("cube"));
    let mut objects = vec![Object::new(
        "Ground",
        0,
        DMat4::from_scale(DVec3::splat(10.0)),
    )];
    for (i, (x, y, s)) in [
        (0.0, 0.0, 1.0),
        (3.0, -2.0, 0.5),
        (-4.0, 3.0, 1.5),
        (2.5, 3.5, 0.7),
    ]
    .iter()
    .enumerate()
    {
        objects.push(Object::new(
            format!("Box{i}"),
            1,
            DMat4::from_translation(DVec3::new(*x, *y, *s)) * DMat4::from_scale(DVec3::splat(*s)),
        ));
    }
    let camera = Camera::look_at(DVec3::new(12.0, -14.0, 10.0), DVec3::ZERO, DVec3::Z);
    let sun = Light::new(
        "Sun",
        DMat4::look_at_rh(DVec3::new(5.0, 3.0, 8.0), DVec3::ZERO, DVec3::Z).inverse(),
        LightKind::Sun { angle: 0.0 },
    );
    let lamp = Light::new(
        "Lamp",
        DMat4::from_translation(DVec3::new(-2.0, -3.0, 4.0)),
        LightKind::Point { radius: 0.0 },
    );
    Scene {
        frame: 1,
        meshes: vec![ground, cube],
        objects,
        camera,
        lights: vec![sun, lamp],
        resolution: Resolution::new(resolution, resolution * 3 / 4),
        alpha: Default::default(),
    }
}

/// Applies `m` on the world side of every object, the camera and the lights.
pub fn transform_scene(scene: &Scene, m: DMat4) -> Scene {
    let mut s = scene.clone();
    for o in &mut s.objects {
        o.world_from_object = m * o.world_from_object;
    }
    s.camera.world_from_camera = m * s.camera.world_from_camera;
    for l in &mut s.lights {
        l.world_from_light = m * l.world_from_light;
    }
    s
}

pub fn rand(seed: u32) -> f64 {
    unit_float(hash_u32(seed)) as f64
}

pub fn rand3(seed: u32) -> DVec3 {
    DVec3::new(
        rand(seed),
        rand(seed ^ 0x1234_5678),
        rand(seed ^ 0x0bad_cafe),
    )
}

/// `count` objects over three shared meshes, rotated, scaled, some mirrored and some sheared.
pub fn instanced_scene(count: u32) -> Scene {
    let meshes = vec![
        Arc::new(sphere("sphere", 12, 24)),
        Arc::new(cube("cube")),
        Arc::new(grid("grid", 6)),
    ];
    let objects = (0..count)
        .map(|i| {
            let s = i * 7919;
            let at = (rand3(s) - 0.5) * 20.0;
            let rotation = DQuat::from_axis_angle(
                (rand3(s + 1) - 0.5).normalize_or(DVec3::Z),
                rand(s + 2) * 6.0,
            );
            let mut scale = DVec3::splat(0.3 + rand(s + 3) * 1.5);
            if i % 5 == 0 {
                scale.x = -scale.x; // mirrored
            }
            let mut m = DMat4::from_scale_rotation_translation(scale, rotation, at);
            if i % 7 == 0 {
                // Sheared: x gains a share of y.
                let mut shear = DMat4::IDENTITY;
                shear.y_axis.x = 0.6;
                m *= shear;
            }
            Object::new(format!("o{i}"), (i % 3) as usize, m)
        })
        .collect();
    let mut scene = boxes_scene(32);
    scene.meshes = meshes;
    scene.objects = objects;
    scene
}

/// Rays between random points of render space: even ones segments (t in (0, 1]), odd ones
/// unbounded.
pub fn render_space_rays(n: u32, seed: u32) -> Vec<antumbra_core::geometry::Ray> {
    (0..n)
        .map(|i| {
            let s = seed.wrapping_add(i * 104_729);
            let a = ((rand3(s) - 0.5) * 2.4).as_vec3();
            let b = ((rand3(s + 5) - 0.5) * 2.4).as_vec3();
            let t_max = if i % 2 == 0 { 1.0 } else { f32::INFINITY };
            antumbra_core::geometry::Ray::new(a, b - a, 0.0, t_max)
        })
        .collect()
}

/// `scene`'s objects as instances of `meshes` (by the object's mesh index) in the flat frame's
/// render space, and the top level over them; objects scaled to nothing are left out.
pub fn place_instances(
    scene: &Scene,
    meshes: &[antumbra_core::two_level::MeshTree],
) -> (
    Vec<antumbra_core::two_level::Instance>,
    antumbra_core::two_level::TopLevel,
) {
    use antumbra_core::two_level::{instance_box, render_from_mesh, Instance, TopLevel};
    let space = antumbra_core::scene::FrameGeometry::from_scene(scene)
        .unwrap()
        .space;
    let (mut instances, mut boxes) = (Vec::new(), Vec::new());
    for (i, o) in scene.objects.iter().enumerate() {
        let mesh = &meshes[o.mesh];
        let m = render_from_mesh(&space, &o.world_from_object, &mesh.space);
        if let Some(instance) = Instance::new(&m, o.mesh as u32, i as u32) {
            instances.push(instance);
            boxes.push(instance_box(&m, &mesh.bounds));
        }
    }
    let top = TopLevel::build(instances.clone(), boxes, &Default::default());
    (instances, top)
}
