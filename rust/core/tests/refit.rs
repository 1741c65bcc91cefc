//! Refit mesh trees (`MeshTree::refit`): a deformed mesh's tree with its build's topology and
//! new boxes answers exactly what brute force answers over the new triangles, binary and wide,
//! after large deformations, chains of refits and at extreme scales and positions; refit to the
//! positions it was built over gives the build's boxes bit for bit; another triangle list,
//! vertex count or set of degenerate triangles takes a build; its SAH growth is measured.

mod common;

use std::sync::Arc;

use antumbra_core::build::{BuildSettings, CollapseSettings};
use antumbra_core::bvh::BvhWidth;
use antumbra_core::geometry::Ray;
use antumbra_core::order::OrderView;
use antumbra_core::render::WideTree;
use antumbra_core::scene::{Mesh, Scene};
use antumbra_core::trace::{NoStats, RayQuery};
use antumbra_core::two_level::{brute, Instance, MeshTree, TopLevel, TwoLevel, REFIT_LIMIT};
use glam::{DMat4, DQuat, DVec3, Vec3};

/// A mesh with `f` applied to every vertex (its index passed along).
fn deformed(mesh: &Mesh, f: impl Fn(Vec3, usize) -> Vec3) -> Mesh {
    let positions = (mesh.positions.iter().enumerate())
        .map(|(i, &p)| f(p, i))
        .collect();
    Mesh::new("deformed", positions, mesh.triangles.clone())
}

/// A vertex's new position from its old one and its index.
type Deformation = Box<dyn Fn(Vec3, usize) -> Vec3>;

/// Large deformations of a unit sphere: a twist, random displacements, a squash, a stretch
/// that tears it apart, and a move far away at another scale.
fn deformations() -> Vec<(&'static str, Deformation)> {
    let noise = |i: usize| (common::rand3(i as u32 * 31 + 7) - 0.5).as_vec3();
    vec![
        (
            "twist",
            Box::new(|p: Vec3, _| {
                let q = DQuat::from_rotation_z(3.0 * p.z as f64);
                (q * p.as_dvec3()).as_vec3()
            }),
        ),
        ("noise", Box::new(move |p, i| p + 0.6 * noise(i))),
        ("squash", Box::new(|p, _| p * Vec3::new(1.0, 1.0, 0.01))),
        (
            "tear",
            Box::new(move |p, i| p * (1.0 + 4.0 * noise(i).x.abs())),
        ),
        (
            "far and large",
            Box::new(|p, _| p * 1000.0 + Vec3::new(1e5, -2e5, 3e5)),
        ),
        (
            "small",
            Box::new(|p, _| p * 1e-4 + Vec3::new(0.5, 0.0, 0.0)),
        ),
    ]
}

/// What places a deformation's sphere back about the origin at its size.
fn undo(label: &str) -> DMat4 {
    match label {
        "far and large" => {
            DMat4::from_scale(DVec3::splat(1e-3))
                * DMat4::from_translation(-DVec3::new(1e5, -2e5, 3e5))
        }
        "small" => {
            DMat4::from_scale(DVec3::splat(1e4))
                * DMat4::from_translation(-DVec3::new(0.5, 0.0, 0.0))
        }
        _ => DMat4::IDENTITY,
    }
}

/// The two levels of `scene`'s objects over the given mesh trees, in the frame's render space.
struct Built {
    meshes: Vec<MeshTree>,
    instances: Vec<Instance>,
    top: TopLevel,
}

fn two_level(scene: &Scene, meshes: Vec<MeshTree>) -> Built {
    let (instances, top) = common::place_instances(scene, &meshes);
    Built {
        meshes,
        instances,
        top,
    }
}

use common::render_space_rays as rays;

/// The binary trees and the wide ones (`wide`, refit alongside) answer what brute force
/// answers over the meshes' triangles, ray for ray.
fn assert_exact(b: &Built, wide: &[Vec<WideTree>], rays: &[Ray], label: &str) {
    let binary: Vec<_> = b.meshes.iter().map(|m| m.bvh.clone()).collect();
    let binary_q = TwoLevel {
        top: &b.top,
        meshes: &binary,
    };
    let mut hits = 0;
    for (i, ray) in rays.iter().enumerate() {
        let closest = brute::brute_closest_hit(&b.instances, &b.meshes, ray);
        let occluded = brute::brute_occluded(&b.instances, &b.meshes, ray);
        let binary_hit = binary_q.closest_hit(ray, &mut NoStats);
        assert_eq!(binary_hit, closest, "{label}: ray {i}, binary");
        let binary_occluded = binary_q.occluded(ray, &mut NoStats);
        assert_eq!(binary_occluded, occluded, "{label}: ray {i}, binary");
        for trees in wide {
            let ordered: Vec<_> = (trees.iter())
                .map(|t| t.ordered(OrderView::FrontToBack))
                .collect();
            let q = TwoLevel {
                top: &b.top,
                meshes: &ordered,
            };
            let hit = q.closest_hit(ray, &mut NoStats);
            assert_eq!(hit, closest, "{label}: ray {i}, wide");
            assert_eq!(q.occluded(ray, &mut NoStats), occluded, "{label}: ray {i}");
        }
        hits += closest.is_some() as usize;
    }
    assert!(
        hits > rays.len() / 10,
        "{label}: {hits} of {} hit",
        rays.len()
    );
}

fn validate_wide(tree: &WideTree) {
    let result = match tree {
        WideTree::Two(t) => t.validate(),
        WideTree::Four(t) => t.validate(),
        WideTree::Eight(t) => t.validate(),
    };
    result.unwrap();
}

const WIDTHS: [BvhWidth; 2] = [BvhWidth::Four, BvhWidth::Eight];

#[test]
fn refit_trees_answer_what_brute_force_answers_after_large_deformations() {
    let settings = BuildSettings::default();
    let collapse = CollapseSettings::default();
    let scene = common::instanced_scene(150);
    let base = scene.meshes[0].clone();
    let built = MeshTree::build(&base, &settings);
    let built_wide: Vec<WideTree> = (WIDTHS.iter())
        .map(|&w| WideTree::collapse(&built.bvh, w, &collapse))
        .collect();
    let rays = rays(1500, 41);
    for (label, f) in deformations() {
        let mesh = deformed(&base, f);
        let tree = built.refit(&base, &mesh).expect("same topology");
        tree.bvh.validate().unwrap();
        // The same triangles, ids and space a build over the new positions keeps.
        let fresh = MeshTree::build(&mesh, &settings);
        assert_eq!(tree.triangles, fresh.triangles, "{label}");
        assert_eq!(tree.primitives, fresh.primitives, "{label}");
        assert_eq!((tree.space, tree.bounds), (fresh.space, fresh.bounds));
        // Every mesh refit or built: the deformed sphere's trees wide and binary. Objects
        // place a moved or scaled sphere back where the others are, so rays meet it.
        let mut scene = scene.clone();
        let undo = undo(label);
        for o in scene.objects.iter_mut().filter(|o| o.mesh == 0) {
            o.world_from_object *= undo;
        }
        scene.meshes[0] = Arc::new(mesh);
        let mut meshes: Vec<MeshTree> = (scene.meshes.iter())
            .map(|m| MeshTree::build(m, &settings))
            .collect();
        let mut wide: Vec<Vec<WideTree>> = (WIDTHS.iter())
            .map(|&w| {
                (meshes.iter())
                    .map(|m| WideTree::collapse(&m.bvh, w, &collapse))
                    .collect()
            })
            .collect();
        for (trees, refit) in wide.iter_mut().zip(&built_wide) {
            let mut refit = refit.clone();
            refit.refit(&tree.bvh.triangles);
            validate_wide(&refit);
            trees[0] = refit;
        }
        meshes[0] = tree;
        let b = two_level(&scene, meshes);
        assert_exact(&b, &wide, &rays, label);
        // And placed far away and small: the instances carry it, exactly.
        let far = DMat4::from_translation(DVec3::new(1e6, -1e6, 3e5))
            * DMat4::from_scale(DVec3::splat(1e-4));
        let moved = common::transform_scene(&scene, far);
        let b = two_level(&moved, b.meshes);
        assert_exact(&b, &wide, &rays[..500], label);
    }
}

#[test]
fn a_chain_of_refits_stays_exact_and_refit_back_gives_the_builds_boxes() {
    let settings = BuildSettings::default();
    let collapse = CollapseSettings::default();
    let base = common::sphere("sphere", 24, 48);
    let built = MeshTree::build(&base, &settings);
    let mut tree = built.clone();
    let mut wide = WideTree::collapse(&built.bvh, BvhWidth::Eight, &collapse);
    let mut over = base.clone();
    for (_, f) in deformations() {
        let mesh = deformed(&over, f);
        tree = tree.refit(&over, &mesh).expect("same topology");
        wide.refit(&tree.bvh.triangles);
        tree.bvh.validate().unwrap();
        validate_wide(&wide);
        over = mesh;
    }
    // Back at the positions it was built over: the builder's boxes, bit for bit.
    let back = tree.refit(&over, &base).unwrap();
    wide.refit(&back.bvh.triangles);
    let bits = |t: &MeshTree| -> Vec<[u32; 6]> {
        (t.bvh.nodes.iter())
            .map(|n| std::array::from_fn(|k| [n.min, n.max][k / 3][k % 3].to_bits()))
            .collect()
    };
    assert_eq!(bits(&back), bits(&built));
    assert_eq!(back.bvh.triangles, built.bvh.triangles);
    let (WideTree::Eight(a), WideTree::Eight(b)) = (
        &wide,
        &WideTree::collapse(&built.bvh, BvhWidth::Eight, &collapse),
    ) else {
        unreachable!("both eight wide")
    };
    let wide_bits = |t: &antumbra_core::bvh::WideBvh<8>| -> Vec<u32> {
        (t.nodes.iter())
            .flat_map(|n| n.bounds.iter().flatten().map(|v| v.to_bits()))
            .collect()
    };
    assert_eq!(wide_bits(a), wide_bits(b));
    assert_eq!(a.root_bounds, b.root_bounds);
    assert_eq!(back.sah_growth(&settings), 1.0);
}

#[test]
fn another_topology_or_degenerate_set_takes_a_build() {
    let settings = BuildSettings::default();
    let base = common::sphere("sphere", 8, 16);
    let tree = MeshTree::build(&base, &settings);
    let moved = deformed(&base, |p, _| p * 2.0);
    assert!(tree.refit(&base, &moved).is_some());
    // One triangle's corners in another order.
    let mut wound = moved.clone();
    wound.triangles[5].swap(1, 2);
    assert!(tree.refit(&base, &wound).is_none());
    // One triangle fewer.
    let mut fewer = moved.clone();
    fewer.triangles.pop();
    assert!(tree.refit(&base, &fewer).is_none());
    // A vertex more (unused).
    let mut more = moved.clone();
    more.positions.push(Vec3::ZERO);
    assert!(tree.refit(&base, &more).is_none());
    // A triangle degenerate now but not when built: its corner onto another corner.
    let [a, b, _] = base.triangles[20];
    let collapsed = deformed(&base, |p, i| {
        if i == b as usize {
            base.positions[a as usize]
        } else {
            p
        }
    });
    assert!(tree.refit(&base, &collapsed).is_none());
    // And the reverse: built with it degenerate, refit to a frame where it is not.
    let degenerate = MeshTree::build(&collapsed, &settings);
    assert_eq!(
        degenerate.degenerate,
        tree.degenerate + 2,
        "the two triangles on that edge"
    );
    assert!(degenerate.refit(&collapsed, &base).is_none());
}

#[test]
fn sah_growth_is_one_after_a_build_and_a_move_small_for_a_bend_large_for_a_tear() {
    let settings = BuildSettings::default();
    let base = common::sphere("sphere", 24, 48);
    let tree = MeshTree::build(&base, &settings);
    assert_eq!(tree.sah_growth(&settings), 1.0);
    assert!(!tree.is_worn(&settings));
    // Moved as a whole: the cost does not change.
    let moved = deformed(&base, |p, _| p + Vec3::splat(100.0));
    let g = tree.refit(&base, &moved).unwrap().sah_growth(&settings);
    assert!((g - 1.0).abs() < 1e-3, "{g}");
    // A gentle bend keeps the tree.
    let bent = deformed(&base, |p, _| p + Vec3::new(0.1 * p.z * p.z, 0.0, 0.0));
    let t = tree.refit(&base, &bent).unwrap();
    assert!(!t.is_worn(&settings), "{}", t.sah_growth(&settings));
    // Vertices scattered: refit boxes overlap, past the limit.
    let noise = |i: usize| (common::rand3(i as u32 * 13 + 1) - 0.5).as_vec3();
    let torn = deformed(&base, |p, i| p + 1.5 * noise(i));
    let t = tree.refit(&base, &torn).unwrap();
    assert!(
        t.sah_growth(&settings) > REFIT_LIMIT,
        "{}",
        t.sah_growth(&settings)
    );
    assert!(t.is_worn(&settings));
}
