//! Every built-in scene (and its rotated variant) at small size: the BVH's closest hits and
//! occlusion answers equal brute force for thousands of rays — camera rays, the frame's own shadow
//! rays, random rays, rays from inside closed meshes, grazing and axis-parallel rays.

use antumbra_core::build::{build_binned_sah, BuildSettings, CollapseMethod, CollapseSettings};
use antumbra_core::bvh::WideBvh;
use antumbra_core::cancel::CancelToken;
use antumbra_core::geometry::Ray;
use antumbra_core::order::PreparedOrder;
use antumbra_core::order::{AnyHitOrder, ShadowOrder};
use antumbra_core::render::{
    samples_for, shadow_rays, LightSampler, PrimaryPass, PrimaryRays, SamplePlan,
};
use antumbra_core::sampling::{hash_u32, unit_float};
use antumbra_core::scene::{FrameGeometry, Resolution};
use antumbra_core::trace::wide::{BoxKernel, WideQueries};
use antumbra_core::trace::{
    brute_closest_hit, brute_occluded, BinaryInOrder, NoStats, OrderedBinary, RayQuery,
};
use antumbra_scenes::{builtin, SceneParams, BUILTIN_SCENES};
use glam::Vec3;
use rayon::prelude::*;

fn r(seed: u32) -> f32 {
    unit_float(hash_u32(seed))
}

/// Random rays inside the scene's bounds, a share of them axis-parallel (with -0.0) or grazing.
fn random_rays(lo: Vec3, hi: Vec3, n: u32) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let o = lo + (hi - lo) * Vec3::new(r(6 * i), r(6 * i + 1), r(6 * i + 2));
            let mut d = Vec3::new(r(6 * i + 3), r(6 * i + 4), r(6 * i + 5)) * 2.0 - 1.0;
            match i % 6 {
                0 => d = Vec3::new(0.0, -0.0, d.z.signum()),
                1 => d = Vec3::new(d.x, 0.0, -0.0),
                2 => d = Vec3::new(d.x, d.y, 1e-6),
                _ => {}
            }
            Ray::new(o, d, 0.0, if i % 4 == 0 { 0.3 } else { f32::INFINITY })
        })
        .collect()
}

#[test]
fn every_builtin_scene_matches_brute_force() {
    for name in BUILTIN_SCENES {
        for rotated in [false, true] {
            let params = SceneParams {
                triangles: 10_000,
                frames: 2,
                rotated,
                instances: None,
            };
            let anim = builtin(name, &params).unwrap();
            let mut scene = anim.frame(*anim.frame_range().start() + 1);
            scene.resolution = Resolution::new(48, 32);
            let g = FrameGeometry::from_scene(&scene).unwrap();
            let tris = &g.camera.vertices;
            let bvh = build_binned_sah(tris, &BuildSettings::default());
            bvh.validate().unwrap();

            let camera = PrimaryRays::new(&scene.camera, &scene.resolution, &g.space);
            let mut rays: Vec<Ray> = (0..32)
                .flat_map(|y| (0..48).map(move |x| (x, y)))
                .map(|(x, y)| camera.ray(x, y))
                .collect();
            let pass = PrimaryPass::trace::<NoStats>(&camera, &bvh, &g.camera, &CancelToken::new())
                .expect("a new token is never cancelled");
            for (i, l) in scene.lights.iter().enumerate() {
                let s = LightSampler::new(l, &g.space);
                let plan = SamplePlan {
                    light_index: i as u32,
                    samples: samples_for(&s, 2),
                    seed: 1,
                };
                rays.extend(shadow_rays(&pass, &s, plan));
            }
            let b = g.camera.bounds();
            rays.extend(random_rays(b.min, b.max, 2000));
            // From inside the scene's objects: origins at triangle centroids pushed inwards.
            rays.extend((0..500u32).map(|i| {
                let t = &tris[(hash_u32(i) as usize) % tris.len()];
                let c = (t[0] + t[1] + t[2]) / 3.0;
                let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
                Ray::new(
                    c - n * 1e-3,
                    -n + Vec3::new(r(i), r(i + 9), r(i + 99)) * 0.5,
                    0.0,
                    f32::INFINITY,
                )
            }));
            assert!(rays.len() > 3000, "{name}: {} rays", rays.len());
            let mismatches: Vec<usize> = rays
                .par_iter()
                .enumerate()
                .filter(|(_, ray)| {
                    let h = bvh
                        .closest_hit(ray, &mut NoStats)
                        .map(|h| (h.triangle, h.t));
                    let b = brute_closest_hit(tris, ray).map(|h| (h.triangle, h.t));
                    let occ = brute_occluded(tris, ray);
                    h != b
                        || bvh.occluded(ray, &mut NoStats) != occ
                        || OrderedBinary {
                            bvh: &bvh,
                            order: AnyHitOrder::Stored,
                        }
                        .occluded(ray, &mut NoStats)
                            != occ
                })
                .map(|(i, _)| i)
                .collect();
            if let Some(&first) = mismatches.first() {
                let ray = &rays[first];
                panic!(
                    "{name} rotated={rotated}: {} of {} rays differ; first {ray:?}: bvh {:?} brute {:?}, occluded bvh {} brute {}",
                    mismatches.len(),
                    rays.len(),
                    bvh.closest_hit(ray, &mut NoStats),
                    brute_closest_hit(tris, ray),
                    bvh.occluded(ray, &mut NoStats),
                    brute_occluded(tris, ray),
                );
            }
        }
    }
}

/// Every width, every shadow order and every box kernel (scalar, SSE, AVX2 where present) on
/// every built-in scene, single rays and packets: occlusion answers and closest-hit ids equal
/// brute force, and sorting per light (from the frame's own shadow rays) changes no answer.
#[test]
fn every_width_order_and_kernel_matches_brute_force_on_every_builtin_scene() {
    for name in BUILTIN_SCENES {
        for rotated in [false, true] {
            let params = SceneParams {
                triangles: 4_000,
                frames: 1,
                rotated,
                instances: None,
            };
            let anim = builtin(name, &params).unwrap();
            let mut scene = anim.frame(*anim.frame_range().start());
            scene.resolution = Resolution::new(40, 30);
            let g = FrameGeometry::from_scene(&scene).unwrap();
            let tris = &g.camera.vertices;
            let bvh = build_binned_sah(tris, &BuildSettings::default());
            let camera = PrimaryRays::new(&scene.camera, &scene.resolution, &g.space);
            let primary: Vec<Ray> = (0..30)
                .flat_map(|y| (0..40).map(move |x| (x, y)))
                .map(|(x, y)| camera.ray(x, y))
                .collect();
            let pass = PrimaryPass::trace::<NoStats>(&camera, &bvh, &g.camera, &CancelToken::new())
                .expect("a new token is never cancelled");
            let mut shadow = Vec::new();
            for (i, l) in scene.lights.iter().enumerate() {
                let s = LightSampler::new(l, &g.space);
                let plan = SamplePlan {
                    light_index: i as u32,
                    samples: samples_for(&s, 2),
                    seed: 5,
                };
                shadow.extend(shadow_rays(&pass, &s, plan));
            }
            let b = g.camera.bounds();
            shadow.extend(random_rays(b.min, b.max, 600));
            let occ: Vec<bool> = shadow.par_iter().map(|r| brute_occluded(tris, r)).collect();
            let ids: Vec<Option<u32>> = primary
                .par_iter()
                .map(|r| brute_closest_hit(tris, r).map(|h| h.triangle))
                .collect();
            let label = format!("{name} rotated={rotated}");
            check_wide::<2>(&label, &bvh, &primary, &ids, &shadow, &occ);
            check_wide::<4>(&label, &bvh, &primary, &ids, &shadow, &occ);
            check_wide::<8>(&label, &bvh, &primary, &ids, &shadow, &occ);
        }
    }
}

fn check_wide<const N: usize>(
    label: &str,
    bvh: &antumbra_core::bvh::Bvh,
    primary: &[Ray],
    ids: &[Option<u32>],
    shadow: &[Ray],
    occ: &[bool],
) where
    WideBvh<N>: WideQueries,
{
    for method in CollapseMethod::ALL {
        let wide = WideBvh::<N>::collapse_with(bvh, &CollapseSettings::new(method));
        let label = format!("{label} {method}");
        check_tree(&label, &wide, primary, ids, shadow, occ);
    }
}

fn check_tree<const N: usize>(
    label: &str,
    wide: &WideBvh<N>,
    primary: &[Ray],
    ids: &[Option<u32>],
    shadow: &[Ray],
    occ: &[bool],
) where
    WideBvh<N>: WideQueries,
{
    wide.validate().unwrap();
    let kernels = [
        BoxKernel::Scalar,
        BoxKernel::Sse,
        BoxKernel::Avx2,
        BoxKernel::Auto,
    ];
    for k in kernels {
        let differ = primary
            .par_iter()
            .zip(ids)
            .filter(|(r, id)| {
                WideQueries::closest_hit(wide, r, k, &mut NoStats).map(|h| h.triangle) != **id
            })
            .count();
        assert_eq!(differ, 0, "{label} N={N} {k:?}: closest-hit ids differ");
        // Packets of 16 neighbouring camera rays (rows of pixels) answer as single rays do.
        let mut hits = vec![None; primary.len()];
        wide.closest_hit_packets(primary, k, &mut hits, &mut vec![NoStats; primary.len()]);
        let packet_ids: Vec<Option<u32>> = hits.iter().map(|h| h.map(|h| h.triangle)).collect();
        let differ = packet_ids.iter().zip(ids).filter(|(a, b)| a != b).count();
        assert_eq!(
            differ, 0,
            "{label} N={N} {k:?}: packets' closest-hit ids differ"
        );
    }
    for order in [
        "stored",
        "fbto",
        "sato",
        "rtsah",
        "random:seed=9",
        "sorted:budget=0.5",
        "sorted:logging=fbto:p=area:depth=3:budget=0.5",
    ] {
        let order: ShadowOrder = order.parse().unwrap();
        let prepared = PreparedOrder::new(wide, &order, None, shadow, BoxKernel::Auto);
        for k in kernels {
            let differ = shadow
                .par_iter()
                .zip(occ)
                .filter(|(r, o)| {
                    WideQueries::occluded(wide, r, prepared.view(), k, &mut NoStats) != **o
                })
                .count();
            assert_eq!(differ, 0, "{label} N={N} {order} {k:?}: occlusion differs");
            // Packets of the frame's shadow rays, light by light in pixel order.
            let mut packets = vec![false; shadow.len()];
            let none = &mut vec![NoStats; shadow.len()];
            wide.occluded_packets(shadow, prepared.view(), k, &mut packets, none);
            let differ = packets.iter().zip(occ).filter(|(a, b)| a != b).count();
            assert_eq!(
                differ, 0,
                "{label} N={N} {order} {k:?}: packets' occlusion differs"
            );
        }
    }
}

/// SRDH on every built-in scene: per light a tree from the light's own rays (all of them, and
/// a 4x4 prepass) and the baselines' kernels on the SAH tree answer every shadow ray and random
/// ray as brute force does.
#[test]
fn srdh_trees_match_brute_force_on_every_builtin_scene() {
    use antumbra_core::order::{
        rtsah_kernels, Kernel, RandomKernel, RaySetSource, SrdhSettings, Uniform,
    };
    use antumbra_core::render::srdh_rays;
    use antumbra_core::srdh::{build_srdh, RaySet};
    for name in BUILTIN_SCENES {
        for rotated in [false, true] {
            let params = SceneParams {
                triangles: 4_000,
                frames: 1,
                rotated,
                instances: None,
            };
            let anim = builtin(name, &params).unwrap();
            let mut scene = anim.frame(*anim.frame_range().start());
            scene.resolution = Resolution::new(40, 30);
            let g = FrameGeometry::from_scene(&scene).unwrap();
            let tris = &g.camera.vertices;
            let settings = BuildSettings::default();
            let bvh = build_binned_sah(tris, &settings);
            let camera = PrimaryRays::new(&scene.camera, &scene.resolution, &g.space);
            let pass = PrimaryPass::trace::<NoStats>(&camera, &bvh, &g.camera, &CancelToken::new())
                .expect("a new token is never cancelled");
            let b = g.camera.bounds();
            let random = random_rays(b.min, b.max, 300);
            let rtsah = rtsah_kernels(&bvh);
            for (i, l) in scene.lights.iter().enumerate() {
                let s = LightSampler::new(l, &g.space);
                let plan = SamplePlan {
                    light_index: i as u32,
                    samples: samples_for(&s, 2),
                    seed: 5,
                };
                let mut rays = shadow_rays(&pass, &s, plan);
                rays.extend_from_slice(&random);
                let occ: Vec<bool> = rays.par_iter().map(|r| brute_occluded(tris, r)).collect();
                for source in [
                    RaySetSource::All,
                    RaySetSource::Prepass {
                        width: 4,
                        height: 4,
                    },
                ] {
                    let srdh = SrdhSettings {
                        rays: source,
                        ..SrdhSettings::default()
                    };
                    let set = RaySet::trace(&bvh, srdh_rays(&pass, &s, plan, source));
                    let tree = build_srdh(tris, &set, &srdh, &settings);
                    tree.bvh.validate().unwrap();
                    let wrong = rays
                        .par_iter()
                        .zip(&occ)
                        .filter(|(r, o)| tree.occluded(r, &mut NoStats) != **o)
                        .count();
                    assert_eq!(wrong, 0, "{name} rotated={rotated} light {i} {source:?}");
                }
                let wrong = rays
                    .par_iter()
                    .zip(&occ)
                    .filter(|(r, o)| {
                        BinaryInOrder {
                            bvh: &bvh,
                            order: &rtsah,
                        }
                        .occluded(r, &mut NoStats)
                            != **o
                            || BinaryInOrder {
                                bvh: &bvh,
                                order: &RandomKernel { seed: 2 },
                            }
                            .occluded(r, &mut NoStats)
                                != **o
                            || BinaryInOrder {
                                bvh: &bvh,
                                order: &Uniform(Kernel::BackToFront),
                            }
                            .occluded(r, &mut NoStats)
                                != **o
                    })
                    .count();
                assert_eq!(wrong, 0, "{name} rotated={rotated} light {i} baselines");
            }
        }
    }
}
