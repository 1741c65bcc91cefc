//! Batches through two levels (`TwoLevel`'s `occluded_batch` and `closest_hit_batch`, runs of 16
//! rays through the top level, each instance's rays traced as one batch of its mesh query):
//! the answers of the single-ray walk and of the brute-force reference bit for bit, over
//! tile-ordered camera and shadow rays and random rays in partial runs, through mirrored,
//! sheared, 1e-4/1e4-scaled and 1e6-translated instances, on binary and 4/8-wide mesh trees
//! traced as single rays or packets; and work counted per ray.

mod common;

use antumbra_core::build::{BuildSettings, CollapseSettings};
use antumbra_core::bvh::{Bvh, BvhWidth};
use antumbra_core::geometry::Ray;
use antumbra_core::order::OrderView;
use antumbra_core::render::WideTree;
use antumbra_core::scene::Scene;
use antumbra_core::trace::{Counters, Hit, NoStats, RayMode, RayQuery, TraversalStats};
use antumbra_core::two_level::{brute, Instance, MeshTree, TopLevel, TwoLevel};
use glam::{DMat4, DVec3, Vec3};

struct Built {
    meshes: Vec<MeshTree>,
    instances: Vec<Instance>,
    top: TopLevel,
    binary: Vec<Bvh>,
    /// 4- and 8-wide collapses of every mesh tree.
    wide: Vec<Vec<WideTree>>,
}

fn two_level(scene: &Scene) -> Built {
    let settings = BuildSettings::default();
    let meshes: Vec<MeshTree> = (scene.meshes.iter())
        .map(|m| MeshTree::build(m, &settings))
        .collect();
    let (instances, top) = common::place_instances(scene, &meshes);
    let collapse = CollapseSettings::default();
    let wide = [BvhWidth::Four, BvhWidth::Eight]
        .iter()
        .map(|&w| {
            (meshes.iter())
                .map(|m| WideTree::collapse(&m.bvh, w, &collapse))
                .collect()
        })
        .collect();
    Built {
        binary: meshes.iter().map(|m| m.bvh.clone()).collect(),
        meshes,
        instances,
        top,
        wide,
    }
}

/// A hit's bits: equal keys are the same hit bit for bit.
fn key(h: &Option<Hit>) -> Option<[u32; 6]> {
    h.map(|h| {
        [
            h.t.to_bits(),
            h.instance,
            h.triangle,
            h.b0.to_bits(),
            h.b1.to_bits(),
            h.b2.to_bits(),
        ]
    })
}

/// The reference answers of `rays`: closest hits and occlusion.
struct Expected {
    closest: Vec<Option<[u32; 6]>>,
    occluded: Vec<bool>,
}

impl Expected {
    fn of(b: &Built, rays: &[Ray]) -> Self {
        Expected {
            closest: (rays.iter())
                .map(|r| key(&brute::brute_closest_hit(&b.instances, &b.meshes, r)))
                .collect(),
            occluded: (rays.iter())
                .map(|r| brute::brute_occluded(&b.instances, &b.meshes, r))
                .collect(),
        }
    }
}

/// `q`'s batches (uncounted and counted) and its single rays give the reference's answers;
/// returns the batch's summed work.
fn assert_batches<Q: RayQuery>(
    q: &TwoLevel<Q>,
    rays: &[Ray],
    expected: &Expected,
    label: &str,
) -> TraversalStats {
    let n = rays.len();
    let mut work = vec![TraversalStats::default(); n];
    for counted in [false, true] {
        let mut occluded = vec![false; n];
        let mut closest = vec![None; n];
        if counted {
            q.occluded_batch(rays, &mut occluded, &mut work);
            q.closest_hit_batch(rays, &mut closest, &mut work);
        } else {
            q.occluded_batch(rays, &mut occluded, &mut vec![NoStats; n]);
            q.closest_hit_batch(rays, &mut closest, &mut vec![NoStats; n]);
        }
        for i in 0..n {
            let tag = format!("{label}: ray {i} of {n}, counted {counted}");
            assert_eq!(key(&closest[i]), expected.closest[i], "{tag}: closest");
            assert_eq!(occluded[i], expected.occluded[i], "{tag}: occluded");
        }
    }
    for (i, ray) in rays.iter().enumerate() {
        assert_eq!(
            key(&q.closest_hit(ray, &mut NoStats)),
            expected.closest[i],
            "{label}: ray {i}, single"
        );
        assert_eq!(
            q.occluded(ray, &mut NoStats),
            expected.occluded[i],
            "{label}: ray {i}, single"
        );
    }
    let mut sum = TraversalStats::default();
    for w in work {
        sum += w;
    }
    sum
}

/// Every mesh query (binary; 4- and 8-wide as single rays and as packets) under the top level
/// answers `rays` as the reference does, in batches and one ray at a time.
fn assert_every_query(b: &Built, rays: &[Ray], label: &str) {
    let expected = Expected::of(b, rays);
    let hits = expected.closest.iter().filter(|h| h.is_some()).count();
    let occluded = expected.occluded.iter().filter(|o| **o).count();
    assert!(
        hits > rays.len() / 16 && occluded < rays.len(),
        "{label}: {hits} hits, {occluded} occluded of {} rays: too few to tell",
        rays.len()
    );
    let q = TwoLevel {
        top: &b.top,
        meshes: &b.binary,
    };
    let work = assert_batches(&q, rays, &expected, &format!("{label}, binary"));
    assert!(work.inner > 0 && work.leaves > 0 && work.triangles > 0 && work.boxes > 0);
    for (trees, width) in b.wide.iter().zip([4, 8]) {
        for mode in RayMode::ALL {
            let ordered: Vec<_> = (trees.iter())
                .map(|t| t.ordered(OrderView::FrontToBack).with_rays(mode))
                .collect();
            let q = TwoLevel {
                top: &b.top,
                meshes: &ordered,
            };
            let tag = format!("{label}, {width}-wide, {mode}");
            let work = assert_batches(&q, rays, &expected, &tag);
            assert!(work.inner > 0 && work.triangles > 0, "{tag}: {work:?}");
        }
    }
}

/// Camera rays from a point before the scene through a `size` x `size` image, in 16 x 16 tiles
/// row by row inside each (as the primary pass orders a tile's rays): runs of 16 are
/// neighbours.
fn tile_ordered_camera_rays(size: u32) -> Vec<Ray> {
    let origin = Vec3::new(0.05, -0.1, -1.6);
    let pixel = |x: u32, y: u32| {
        let u = (x as f32 + 0.5) / size as f32 * 2.4 - 1.2;
        let v = (y as f32 + 0.5) / size as f32 * 2.4 - 1.2;
        Ray::new(origin, Vec3::new(u, v, 1.0), 0.0, f32::INFINITY)
    };
    let mut rays = Vec::new();
    for ty in (0..size).step_by(16) {
        for tx in (0..size).step_by(16) {
            for y in ty..(ty + 16).min(size) {
                for x in tx..(tx + 16).min(size) {
                    rays.push(pixel(x, y));
                }
            }
        }
    }
    rays
}

/// Shadow rays toward one light point from where `camera` rays hit (segments, t in (1e-4, 1]),
/// in the camera rays' order: a count that is no multiple of 16, so runs end part full.
fn shadow_rays(b: &Built, camera: &[Ray]) -> Vec<Ray> {
    let light = Vec3::new(0.6, 1.4, -0.9);
    let rays: Vec<Ray> = (camera.iter())
        .filter_map(|r| {
            let h = brute::brute_closest_hit(&b.instances, &b.meshes, r)?;
            let p = r.at(h.t);
            Some(Ray::new(p, light - p, 1e-4, 1.0))
        })
        .collect();
    rays
}

#[test]
fn batches_through_instances_answer_as_single_rays_and_brute_force() {
    let b = two_level(&common::instanced_scene(300));
    let camera = tile_ordered_camera_rays(48);
    assert_every_query(&b, &camera, "camera");
    let shadow = shadow_rays(&b, &camera);
    assert!(
        !shadow.len().is_multiple_of(16),
        "{} shadow rays",
        shadow.len()
    );
    assert_every_query(&b, &shadow, "shadow");
    // Random rays, each run incoherent, the last run 9 rays.
    assert_every_query(&b, &common::render_space_rays(1001, 5), "random");
}

#[test]
fn batches_through_extreme_instance_transforms_answer_exactly() {
    let scene = common::instanced_scene(120);
    let camera = tile_ordered_camera_rays(32);
    let random = common::render_space_rays(333, 41);
    let mut mixed = scene.clone();
    mixed.objects[0].world_from_object = DMat4::from_scale(DVec3::splat(1e-4));
    mixed.objects[1].world_from_object = DMat4::from_scale(DVec3::splat(1e4));
    for (label, moved) in [
        (
            "translated by 1e6",
            common::transform_scene(&scene, DMat4::from_translation(DVec3::new(1e6, -1e6, 3e5))),
        ),
        (
            "scaled by 1e-4",
            common::transform_scene(&scene, DMat4::from_scale(DVec3::splat(1e-4))),
        ),
        (
            "scaled by 1e4",
            common::transform_scene(&scene, DMat4::from_scale(DVec3::splat(1e4))),
        ),
        ("mixed scales", mixed),
    ] {
        let b = two_level(&moved);
        assert_every_query(&b, &camera, &format!("{label}, camera"));
        assert_every_query(&b, &random, &format!("{label}, random"));
        if label != "mixed scales" {
            // (There the camera sees the inside of the 1e4 object, which nothing shadows.)
            assert_every_query(&b, &shadow_rays(&b, &camera), &format!("{label}, shadow"));
        }
    }
}

#[test]
fn batches_break_ties_between_twin_instances_by_the_object() {
    // Every object twice, the twin placed exactly alike: every hit ties in t with its twin's,
    // and the lower object must win whichever the run's walk reaches first.
    let mut twins = common::instanced_scene(80);
    let copies = twins.objects.clone();
    twins.objects.extend(copies);
    let b = two_level(&twins);
    let camera = tile_ordered_camera_rays(32);
    assert_every_query(&b, &camera, "twins, camera");
    let expected = Expected::of(&b, &camera);
    let first_copy = expected.closest.iter().flatten().all(|h| h[1] < 80);
    assert!(first_copy, "the reference keeps the lower object");
    assert_every_query(&b, &common::render_space_rays(500, 9), "twins, random");
}

/// The counters of a batch of one ray (its run has one lane) on single-ray mesh queries.
fn alone<C: Counters, Q: RayQuery>(q: &TwoLevel<Q>, ray: &Ray) -> (C, C) {
    let (mut any, mut closest) = ([C::default()], [C::default()]);
    q.occluded_batch(std::slice::from_ref(ray), &mut [false], &mut any);
    q.closest_hit_batch(std::slice::from_ref(ray), &mut [None], &mut closest);
    (any[0], closest[0])
}

#[test]
fn batches_count_work_per_ray() {
    let b = two_level(&common::instanced_scene(200));
    let ordered: Vec<_> = (b.wide[1].iter())
        .map(|t| t.ordered(OrderView::FrontToBack))
        .collect();
    let q = TwoLevel {
        top: &b.top,
        meshes: &ordered,
    };
    // A lone ray walks the top level as the single-ray walk does: the same counts.
    let rays = common::render_space_rays(400, 77);
    for (i, ray) in rays.iter().enumerate() {
        let (mut any, mut closest) = (TraversalStats::default(), TraversalStats::default());
        q.occluded(ray, &mut any);
        q.closest_hit(ray, &mut closest);
        assert_eq!(alone(&q, ray), (any, closest), "ray {i}");
    }
    // A ray missing the top level's root counts its box test alone, whatever its run does.
    // The image's middle row (lanes through the scene's middle).
    let mut run = tile_ordered_camera_rays(16)[8 * 16..9 * 16].to_vec();
    let away = Ray::new(
        Vec3::new(5.0, 5.0, 5.0),
        Vec3::new(1.0, 0.0, 0.0),
        0.0,
        1e30,
    );
    run[7] = away;
    let mut counters = vec![TraversalStats::default(); run.len()];
    let mut out = vec![None; run.len()];
    q.closest_hit_batch(&run, &mut out, &mut counters);
    let root_box = TraversalStats {
        boxes: 1,
        ..Default::default()
    };
    assert_eq!(counters[7], root_box);
    assert!(
        counters[6].leaves > 0 && counters[8].triangles > 0,
        "{:?}",
        &counters[6..9]
    );
    // The run's other rays count what a batch without the stray ray counts for them.
    let mut alone_run = run.clone();
    alone_run[7] = run[6];
    let mut without = vec![TraversalStats::default(); run.len()];
    q.closest_hit_batch(&alone_run, &mut vec![None; run.len()], &mut without);
    assert_eq!(counters[8..], without[8..]);
}
