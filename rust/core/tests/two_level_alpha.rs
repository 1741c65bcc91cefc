//! Two-level scenes through alpha (issues 37 and 38): each instance reads its own alpha scene
//! (`InstanceAlpha`: one per mesh tree and materials, the ids the mesh tree's), and the
//! two-level transmission and closest hit past transparent hits equal the two-level
//! brute-force reference bit for bit, through mirrored, sheared and scaled instances, on binary
//! and 4- and 8-wide mesh trees, with a tight and a loose hit limit.

mod common;

use antumbra_core::alpha::{
    AlphaImage, AlphaProgram, AlphaScene, AlphaTriangles, Extension, FlaggedTriangle, Interpolation,
};
use antumbra_core::build::{BuildSettings, CollapseSettings};
use antumbra_core::bvh::BvhWidth;
use antumbra_core::geometry::Ray;
use antumbra_core::order::OrderView;
use antumbra_core::render::WideTree;
use antumbra_core::sampling::{hash_u32, unit_float};
use antumbra_core::scene::Scene;
use antumbra_core::trace::{AlphaQuery, AlphaStats, NoStats};
use antumbra_core::two_level::{brute, Instance, InstanceAlpha, MeshTree, TopLevel, TwoLevel};

fn r(seed: u32) -> f32 {
    unit_float(hash_u32(seed))
}

/// A 16x16 image of random alphas with exact 0s and 1s among them.
fn image(seed: u32) -> AlphaImage {
    let texels = (0..256)
        .map(|i| match hash_u32(seed + i) % 4 {
            0 => 0.0,
            1 => 1.0,
            _ => r(seed + 1000 + i),
        })
        .collect();
    AlphaImage {
        width: 16,
        height: 16,
        texels,
    }
}

/// A scene over `tree`'s ids: about two triangles in three flagged (random UVs past [0, 1]),
/// over an image read two ways and a constant.
fn alpha_for(tree: &MeshTree, seed: u32) -> AlphaScene {
    let flagged = (0..tree.triangles.len() as u32)
        .filter(|&t| !hash_u32(seed ^ t).is_multiple_of(3))
        .map(|t| FlaggedTriangle {
            triangle: t,
            material: hash_u32(seed + t) % 3,
            uvs: vec![[0, 1, 2].map(|k| {
                let s = seed + t * 7 + k * 3;
                [r(s) * 3.0 - 1.0, r(s + 1) * 3.0 - 1.0]
            })],
        })
        .collect();
    let triangles = AlphaTriangles::new(tree.triangles.len() as u32, 1, flagged).unwrap();
    let programs = vec![
        AlphaProgram::image(0, 0, Interpolation::Closest, Extension::Repeat),
        AlphaProgram::image(0, 0, Interpolation::Linear, Extension::Extend),
        AlphaProgram::constant(0.5),
    ];
    AlphaScene::new(vec![image(seed)], programs, triangles).unwrap()
}

struct Built {
    meshes: Vec<MeshTree>,
    instances: Vec<Instance>,
    top: TopLevel,
    alpha: InstanceAlpha,
}

/// The two levels of `scene`'s objects; per mesh two alpha scenes, object `i` reading its
/// mesh's first (i % 3 == 0), second (1) or none (2: opaque).
fn built(scene: &Scene) -> Built {
    let settings = BuildSettings::default();
    let meshes: Vec<MeshTree> = (scene.meshes.iter())
        .map(|m| MeshTree::build(m, &settings))
        .collect();
    let scenes: Vec<AlphaScene> = (meshes.iter().enumerate())
        .flat_map(|(i, m)| {
            [
                alpha_for(m, 100 * i as u32),
                alpha_for(m, 100 * i as u32 + 50),
            ]
        })
        .collect();
    let by_object: Vec<Option<u32>> = (scene.objects.iter().enumerate())
        .map(|(i, o)| match i % 3 {
            2 => None,
            k => Some((2 * o.mesh + k) as u32),
        })
        .collect();
    let (instances, top) = common::place_instances(scene, &meshes);
    Built {
        meshes,
        instances,
        top,
        alpha: InstanceAlpha::new(scenes, &by_object, None),
    }
}

use common::render_space_rays as rays;

/// Every layout's two-level transmission and clipped closest hit equal the reference bit for
/// bit; returns how many rays came out fractional (neither 0 nor 1).
fn assert_exact(b: &Built, rays: &[Ray], max_hits: u32, label: &str) -> usize {
    let binary: Vec<_> = b.meshes.iter().map(|m| m.bvh.clone()).collect();
    let collapse = CollapseSettings::default();
    let wide: Vec<Vec<WideTree>> = [BvhWidth::Four, BvhWidth::Eight]
        .iter()
        .map(|&w| {
            (b.meshes.iter())
                .map(|m| WideTree::collapse(&m.bvh, w, &collapse))
                .collect()
        })
        .collect();
    let ordered: Vec<Vec<_>> = (wide.iter())
        .map(|trees| {
            (trees.iter())
                .map(|t| t.ordered(OrderView::FrontToBack))
                .collect()
        })
        .collect();
    let binary_q = TwoLevel {
        top: &b.top,
        meshes: &binary,
    };
    let mut fractional = 0;
    let mut lookups = AlphaStats::default();
    for (i, ray) in rays.iter().enumerate() {
        let want = brute::brute_transmission(&b.instances, &b.meshes, ray, &b.alpha, max_hits);
        let clip = brute::brute_closest_hit_alpha(&b.instances, &b.meshes, ray, &b.alpha, 0.5);
        fractional += (want > 0.0 && want < 1.0) as usize;
        let got = binary_q.transmission(ray, &b.alpha, max_hits, &mut lookups);
        assert_eq!(got.to_bits(), want.to_bits(), "{label}: ray {i}, binary");
        let hit = binary_q.closest_hit_alpha(ray, &b.alpha, 0.5, &mut NoStats);
        assert_eq!(hit, clip, "{label}: ray {i}, binary closest");
        for (meshes, width) in ordered.iter().zip([4, 8]) {
            let q = TwoLevel {
                top: &b.top,
                meshes,
            };
            let got = q.transmission(ray, &b.alpha, max_hits, &mut NoStats);
            assert_eq!(
                got.to_bits(),
                want.to_bits(),
                "{label}: ray {i}, {width} wide"
            );
            let hit = q.closest_hit_alpha(ray, &b.alpha, 0.5, &mut NoStats);
            assert_eq!(hit, clip, "{label}: ray {i}, {width} wide closest");
        }
    }
    assert!(
        lookups.alpha_lookups > 0,
        "{label}: no alpha lookup counted"
    );
    fractional
}

#[test]
fn two_level_alpha_equals_brute_force_per_instance() {
    let scene = common::instanced_scene(240);
    let b = built(&scene);
    assert_eq!(b.alpha.scenes().len(), 6, "two scenes per mesh, shared");
    assert!(!b.alpha.flags_nothing());
    let rays = rays(2500, 41);
    let fractional = assert_exact(&b, &rays, 8, "limit 8");
    assert!(fractional > 100, "{fractional} fractional rays");
    // A tight limit: rays past two transparent hits are stopped, the same by both.
    assert_exact(&b, &rays, 2, "limit 2");
}

#[test]
fn an_instance_reads_its_own_scene_not_its_neighbours() {
    // The same instances with every object reading its mesh's first scene: answers change where
    // objects of the second scene or opaque ones are hit, so the per-instance switch is seen.
    let scene = common::instanced_scene(240);
    let b = built(&scene);
    let scenes = b.alpha.scenes().to_vec();
    let first: Vec<Option<u32>> = (scene.objects.iter())
        .map(|o| Some(2 * o.mesh as u32))
        .collect();
    let shared = InstanceAlpha::new(scenes, &first, None);
    let q = TwoLevel {
        top: &b.top,
        meshes: &b.meshes.iter().map(|m| m.bvh.clone()).collect::<Vec<_>>(),
    };
    let differ = rays(1500, 7)
        .iter()
        .filter(|r| {
            q.transmission(r, &b.alpha, 8, &mut NoStats)
                != q.transmission(r, &shared, 8, &mut NoStats)
        })
        .count();
    assert!(differ > 50, "{differ} rays differ");
}
