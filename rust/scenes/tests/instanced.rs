//! The two scenes of issue 37: `instanced-forest` (a few tree meshes, many instances, optionally
//! an exact instance count) and `character-room` (one deforming character in a static hall).

use std::collections::HashMap;
use std::sync::Arc;

use antumbra_core::scene::{Animation, Scene};
use antumbra_core::Error;
use antumbra_scenes::{builtin, SceneParams, BUILTIN_SCENES, MAX_INSTANCES, MAX_TRIANGLES};

fn params(triangles: usize, instances: Option<usize>) -> SceneParams {
    SceneParams {
        triangles,
        frames: 4,
        rotated: false,
        instances,
    }
}

fn make(name: &str, p: &SceneParams) -> Box<dyn Animation> {
    builtin(name, p).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// How many objects place each mesh.
fn uses(scene: &Scene) -> HashMap<usize, usize> {
    let mut n = HashMap::new();
    for o in &scene.objects {
        *n.entry(o.mesh).or_insert(0) += 1;
    }
    n
}

fn tree_meshes(scene: &Scene) -> Vec<usize> {
    (0..scene.meshes.len())
        .filter(|&m| scene.meshes[m].name.starts_with("tree"))
        .collect()
}

#[test]
fn instanced_forest_shares_a_few_tree_meshes_among_many_instances() {
    for triangles in [10_000, 100_000, 350_000] {
        let anim = make("instanced-forest", &params(triangles, None));
        let (f1, f4) = (anim.frame(1), anim.frame(4));
        f1.validate().unwrap();
        f4.validate().unwrap();
        let trees = tree_meshes(&f1);
        assert!(
            (1..=4).contains(&trees.len()),
            "{} tree meshes",
            trees.len()
        );
        assert!(f1.meshes.len() <= trees.len() + 1, "only trees and ground");
        let uses = uses(&f1);
        let instances: usize = trees.iter().map(|m| uses[m]).sum();
        for m in &trees {
            assert!(
                uses[m] >= instances / 10,
                "tree mesh {m} is placed {} times",
                uses[m]
            );
        }
        assert!(instances >= 100, "{instances} instances at {triangles}");
        // Everything is still: the same meshes and matrices in every frame.
        for (a, b) in f1.meshes.iter().zip(&f4.meshes) {
            assert!(Arc::ptr_eq(a, b), "{} rebuilt", a.name);
        }
        assert_eq!(f1.objects, f4.objects);
        let ratio = f1.triangle_count() as f64 / triangles as f64;
        assert!((0.9..=1.1).contains(&ratio), "{ratio} at {triangles}");
    }
    let many = make("instanced-forest", &params(350_000, None)).frame(1);
    assert!(many.objects.len() > 3_000, "{}", many.objects.len());
}

#[test]
fn instanced_forest_has_mirrored_and_sheared_instances() {
    let scene = make("instanced-forest", &params(100_000, None)).frame(1);
    let trees: Vec<_> = scene
        .objects
        .iter()
        .filter(|o| scene.meshes[o.mesh].name.starts_with("tree"))
        .collect();
    let mirrored = trees
        .iter()
        .filter(|o| o.world_from_object.determinant() < 0.0)
        .count();
    let sheared = trees
        .iter()
        .filter(|o| {
            let m = o.world_from_object;
            let (x, z) = (m.x_axis.truncate(), m.z_axis.truncate());
            (x.dot(z) / (x.length() * z.length())).abs() > 0.01
        })
        .count();
    let n = trees.len();
    assert!(
        mirrored > 0 && mirrored < n / 10,
        "{mirrored} of {n} mirrored"
    );
    assert!(sheared > 0 && sheared < n / 10, "{sheared} of {n} sheared");
}

#[test]
fn instance_count_is_exact_and_triangles_budget_the_unique_ones() {
    let p = params(300_000, Some(1_000_000));
    let scene = make("instanced-forest", &p).frame(1);
    let trees = tree_meshes(&scene);
    let unique: usize = trees.iter().map(|&m| scene.meshes[m].triangles.len()).sum();
    let ratio = unique as f64 / 300_000.0;
    assert!((0.8..=1.25).contains(&ratio), "{unique} unique triangles");
    let instances = scene
        .objects
        .iter()
        .filter(|o| trees.contains(&o.mesh))
        .count();
    assert_eq!(instances, 1_000_000);
    // Far more world triangles than any flat scene could hold.
    assert!(scene.triangle_count() > 50_000_000_000);

    let small = make("instanced-forest", &params(1_000, Some(7))).frame(2);
    small.validate().unwrap();
    let trees = tree_meshes(&small);
    assert_eq!(
        small
            .objects
            .iter()
            .filter(|o| trees.contains(&o.mesh))
            .count(),
        7
    );
}

fn invalid_field(result: antumbra_core::Result<Box<dyn Animation>>) -> (String, String) {
    match result.err().expect("an error") {
        Error::Invalid { field, message } => (field, message),
        other => panic!("{other:?}"),
    }
}

#[test]
fn instances_are_checked_and_refused_by_other_scenes() {
    for name in BUILTIN_SCENES.iter().filter(|n| **n != "instanced-forest") {
        let (field, message) = invalid_field(builtin(name, &params(10_000, Some(10))));
        assert_eq!(field, "instances");
        assert!(message.contains(name), "{message}");
    }
    let (field, _) = invalid_field(builtin("forest-rot45", &params(10_000, Some(10))));
    assert_eq!(field, "instances");
    for bad in [0, MAX_INSTANCES + 1] {
        let (field, message) =
            invalid_field(builtin("instanced-forest", &params(1_000, Some(bad))));
        assert_eq!(field, "instances");
        assert!(message.contains(&MAX_INSTANCES.to_string()), "{message}");
    }
    let (field, _) = invalid_field(builtin(
        "instanced-forest",
        &params(MAX_TRIANGLES + 1, Some(10)),
    ));
    assert_eq!(field, "triangles");
}

#[test]
fn character_room_deforms_only_the_character() {
    for triangles in [10_000, 100_000] {
        let anim = make("character-room", &params(triangles, None));
        let frames: Vec<Scene> = anim.frame_range().map(|f| anim.frame(f)).collect();
        for pair in frames.windows(2) {
            let (a, b) = (&pair[0], &pair[1]);
            b.validate().unwrap();
            assert_eq!(a.meshes.len(), b.meshes.len());
            assert_eq!(a.objects.len(), b.objects.len());
            let rebuilt: Vec<&str> = a
                .meshes
                .iter()
                .zip(&b.meshes)
                .filter(|(x, y)| !Arc::ptr_eq(x, y))
                .map(|(x, _)| x.name.as_str())
                .collect();
            assert_eq!(rebuilt, ["character"]);
            let moved: Vec<&str> = a
                .objects
                .iter()
                .zip(&b.objects)
                .filter(|(x, y)| x != y)
                .map(|(x, _)| x.name.as_str())
                .collect();
            assert_eq!(moved, ["character"]);
            assert_ne!(a.camera, b.camera);
        }
        // The static set holds nearly all of the triangles.
        let scene = &frames[0];
        let character = scene
            .objects
            .iter()
            .find(|o| o.name == "character")
            .map(|o| scene.meshes[o.mesh].triangles.len())
            .unwrap();
        let total = scene.triangle_count();
        assert!(character * 20 < total, "{character} of {total}");
    }
}
