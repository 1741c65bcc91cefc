//! Built-in scenes: validity, size, determinism, motion, sharing of static meshes, rotation.

use std::sync::Arc;

use antumbra_core::scene::{Animation, FrameGeometry, Scene};
use antumbra_core::Error;
use antumbra_scenes::{builtin, triangle_count, Rotated, SceneParams, BUILTIN_SCENES};
use glam::{DMat4, DVec3};

fn params(triangles: usize) -> SceneParams {
    SceneParams {
        triangles,
        frames: 6,
        rotated: false,
        instances: None,
    }
}

fn make(name: &str, triangles: usize) -> Box<dyn Animation> {
    builtin(name, &params(triangles)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn all_variants() -> Vec<String> {
    BUILTIN_SCENES
        .iter()
        .flat_map(|s| [s.to_string(), format!("{s}-rot45")])
        .collect()
}

/// World-space bounds of every vertex, optionally transformed first.
fn world_bounds(scene: &Scene, extra: DMat4) -> (DVec3, DVec3) {
    let mut min = DVec3::splat(f64::INFINITY);
    let mut max = DVec3::splat(f64::NEG_INFINITY);
    for o in &scene.objects {
        let m = extra * o.world_from_object;
        for p in &scene.meshes[o.mesh].positions {
            let w = m.transform_point3(p.as_dvec3());
            min = min.min(w);
            max = max.max(w);
        }
    }
    (min, max)
}

fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
    (a - b).abs().max_element() <= tol
}

#[test]
fn every_variant_builds_validates_and_has_no_degenerate_triangles() {
    for name in all_variants() {
        let anim = make(&name, 10_000);
        assert_eq!(anim.name(), name);
        assert_eq!(anim.frame_range(), 1..=6);
        for frame in [1, 6] {
            let scene = anim.frame(frame);
            assert_eq!(scene.frame, frame);
            scene
                .validate()
                .unwrap_or_else(|e| panic!("{name} frame {frame}: {e}"));
            assert!(!scene.lights.is_empty(), "{name}: no light");
            assert_eq!(scene.resolution.pixels(), (640, 360));
            let geometry = FrameGeometry::from_scene(&scene).unwrap();
            assert_eq!(
                geometry.camera.degenerate, 0,
                "{name}: degenerate triangles"
            );
        }
    }
}

#[test]
fn triangle_counts_follow_the_target() {
    for name in BUILTIN_SCENES {
        let small = triangle_count(make(name, 10_000).as_ref());
        let large = triangle_count(make(name, 100_000).as_ref());
        for (target, got) in [(10_000, small), (100_000, large)] {
            let ratio = got as f64 / target as f64;
            assert!(
                (1.0 / 1.5..=1.5).contains(&ratio),
                "{name}: {got} triangles for a target of {target}"
            );
        }
        assert!(large > 5 * small, "{name}: {small} -> {large}");
    }
}

#[test]
fn counts_are_the_same_in_every_frame() {
    for name in BUILTIN_SCENES {
        let anim = make(name, 10_000);
        let counts: Vec<usize> = anim
            .frame_range()
            .map(|f| anim.frame(f).triangle_count())
            .collect();
        assert!(
            counts.windows(2).all(|w| w[0] == w[1]),
            "{name}: {counts:?}"
        );
    }
}

/// `a` and `b` are the same frame: meshes of the same content, the same objects, camera,
/// lights, resolution and alpha.
fn assert_same_frame(name: &str, a: &Scene, b: &Scene) {
    assert_eq!(a.frame, b.frame, "{name}");
    assert_eq!(a.meshes.len(), b.meshes.len(), "{name}");
    for (ma, mb) in a.meshes.iter().zip(&b.meshes) {
        assert_eq!(ma.name, mb.name);
        assert_eq!(
            ma.content_hash(),
            mb.content_hash(),
            "{name}: mesh {}",
            ma.name
        );
    }
    assert_eq!(a.objects, b.objects, "{name}");
    assert_eq!(a.camera, b.camera, "{name}");
    assert_eq!(a.lights, b.lights, "{name}");
    assert_eq!(a.resolution, b.resolution, "{name}");
    assert_eq!(a.alpha, b.alpha, "{name}");
}

#[test]
fn generation_is_deterministic() {
    for name in all_variants() {
        let (a, b) = (make(&name, 10_000).frame(2), make(&name, 10_000).frame(2));
        assert_same_frame(&name, &a, &b);
    }
}

#[test]
fn a_frame_taken_from_the_scene_is_the_frame_asked_for() {
    for name in all_variants() {
        for frame in [1, 6] {
            let anim = make(&name, 10_000);
            let asked = anim.frame(frame);
            assert_same_frame(&name, &asked, &anim.into_frame(frame));
        }
    }
}

#[test]
fn something_moves_while_static_meshes_are_shared() {
    for name in all_variants() {
        let anim = make(&name, 10_000);
        let (f1, f2) = (anim.frame(1), anim.frame(2));
        assert_eq!(f1.meshes.len(), f2.meshes.len(), "{name}");
        let mut shared = 0;
        let mut deformed = 0;
        for (a, b) in f1.meshes.iter().zip(&f2.meshes) {
            if Arc::ptr_eq(a, b) {
                shared += 1;
            } else {
                // A mesh made anew each frame must be a deforming one: same triangles, moved
                // vertices.
                assert_eq!(a.triangles, b.triangles, "{name}: {}", a.name);
                assert_ne!(
                    a.positions, b.positions,
                    "{name}: {} rebuilt unchanged",
                    a.name
                );
                deformed += 1;
            }
        }
        assert!(shared > 0, "{name}: no static mesh shared between frames");
        let moved = f1
            .objects
            .iter()
            .zip(&f2.objects)
            .filter(|(a, b)| a.world_from_object != b.world_from_object)
            .count();
        // A scene of still objects (instanced-forest) moves its lights instead.
        let lit = f1.lights != f2.lights;
        assert!(
            moved + deformed > 0 || lit,
            "{name}: nothing moves between frames 1 and 2"
        );
        assert_ne!(f1.camera, f2.camera, "{name}: the camera does not move");
    }
}

#[test]
fn rotated_variant_is_the_scene_turned_45_degrees_about_z() {
    let r = Rotated::rotation();
    for name in BUILTIN_SCENES {
        let plain = make(name, 10_000).frame(3);
        let turned = make(&format!("{name}-rot45"), 10_000).frame(3);
        let via_params = builtin(
            name,
            &SceneParams {
                rotated: true,
                ..params(10_000)
            },
        )
        .unwrap()
        .frame(3);
        assert_eq!(via_params.objects, turned.objects, "{name}");

        assert_eq!(plain.objects.len(), turned.objects.len());
        for (a, b) in plain.objects.iter().zip(&turned.objects) {
            assert_eq!(a.mesh, b.mesh);
            assert!(
                (r * a.world_from_object).abs_diff_eq(b.world_from_object, 1e-9),
                "{name}"
            );
        }
        for (a, b) in plain.meshes.iter().zip(&turned.meshes) {
            assert_eq!(
                a.content_hash(),
                b.content_hash(),
                "{name}: meshes must not change"
            );
        }
        let cam = r * plain.camera.world_from_camera;
        assert!(
            cam.abs_diff_eq(turned.camera.world_from_camera, 1e-9),
            "{name}: camera"
        );
        for (a, b) in plain.lights.iter().zip(&turned.lights) {
            assert!(
                (r * a.world_from_light).abs_diff_eq(b.world_from_light, 1e-9),
                "{name}: light"
            );
        }

        let (min, max) = world_bounds(&plain, r);
        let (tmin, tmax) = world_bounds(&turned, DMat4::IDENTITY);
        let size = (max - min).max_element();
        assert!(
            close(min, tmin, 1e-6 * size) && close(max, tmax, 1e-6 * size),
            "{name}"
        );
        let (pmin, pmax) = world_bounds(&plain, DMat4::IDENTITY);
        assert!(
            !close(pmin, tmin, 0.01 * size) || !close(pmax, tmax, 0.01 * size),
            "{name}: rotation changed nothing"
        );
        // Turning about Z leaves heights alone.
        assert!((pmin.z - tmin.z).abs() < 1e-6 * size && (pmax.z - tmax.z).abs() < 1e-6 * size);
    }
}

#[test]
fn cameras_clip_nothing_of_the_scene() {
    for name in BUILTIN_SCENES {
        let anim = make(name, 10_000);
        for frame in anim.frame_range() {
            let scene = anim.frame(frame);
            let (min, max) = world_bounds(&scene, DMat4::IDENTITY);
            let eye = scene.camera.position();
            let farthest = (0..8)
                .map(|c| {
                    let corner = DVec3::new(
                        if c & 1 == 0 { min.x } else { max.x },
                        if c & 2 == 0 { min.y } else { max.y },
                        if c & 4 == 0 { min.z } else { max.z },
                    );
                    corner.distance(eye)
                })
                .fold(0.0, f64::max);
            assert!(
                scene.camera.clip_end >= farthest,
                "{name}: clip_end {} < {farthest}",
                scene.camera.clip_end
            );
            assert!(scene.camera.clip_start <= 1.0, "{name}");
        }
    }
}

#[test]
fn unknown_names_and_bad_parameters_are_errors() {
    let err = builtin("castle", &SceneParams::default())
        .err()
        .expect("unknown scene");
    match &err {
        Error::Invalid { field, message } => {
            assert_eq!(field, "scene");
            assert!(message.contains("unknown scene 'castle'"), "{message}");
            for known in BUILTIN_SCENES {
                assert!(message.contains(known), "{message}");
            }
        }
        other => panic!("{other:?}"),
    }
    assert!(builtin("castle-rot45", &SceneParams::default()).is_err());
    for bad in [
        SceneParams {
            triangles: 0,
            ..SceneParams::default()
        },
        SceneParams {
            frames: 0,
            ..SceneParams::default()
        },
        SceneParams {
            triangles: usize::MAX,
            ..SceneParams::default()
        },
    ] {
        let err = builtin("city", &bad).err().expect("bad parameters");
        assert!(matches!(err, Error::Invalid { .. }), "{err:?}");
    }
}

#[test]
fn tiny_targets_keep_a_minimum_of_detail() {
    for name in all_variants() {
        let scene = make(&name, 1).frame(1);
        scene.validate().unwrap();
        assert!(scene.triangle_count() > 100, "{name}");
    }
}

#[test]
fn default_parameters() {
    let p = SceneParams::default();
    assert_eq!((p.triangles, p.frames, p.rotated), (100_000, 24, false));
    assert_eq!(make("hairball", 10_000).frame_range(), 1..=6);
    let single = builtin(
        "bedroom",
        &SceneParams {
            frames: 1,
            triangles: 10_000,
            rotated: false,
            instances: None,
        },
    )
    .unwrap();
    assert_eq!(single.frame_range(), 1..=1);
    single.frame(1).validate().unwrap();
}
