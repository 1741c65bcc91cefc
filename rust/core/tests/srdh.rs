//! SRDH: answers equal brute force, the empty ray set gives the SAH tree, the chosen split is
//! the cheapest candidate (exhaustively, against an independent evaluation of the cost), and
//! for two one-triangle leaves the cost is exactly the triangle tests of the traversal.

use antumbra_core::build::{build_binned_sah, BuildSettings};
use antumbra_core::geometry::Ray;
use antumbra_core::order::{rtsah_kernels, Kernel, KernelSet, RandomKernel, SrdhSettings, Uniform};
use antumbra_core::sampling::{hash_u32, unit_float};
use antumbra_core::srdh::{build_srdh, cost::reference_cost, root_candidates, RaySet};
use antumbra_core::trace::{brute_occluded, BinaryInOrder, NoStats, RayQuery, TraversalStats};
use glam::Vec3;

fn r(seed: u32) -> f32 {
    unit_float(hash_u32(seed))
}

fn v(seed: u32) -> Vec3 {
    Vec3::new(r(3 * seed), r(3 * seed + 1), r(3 * seed + 2)) * 2.0 - 1.0
}

/// Small random triangles in [-1, 1]^3, plus a large "blind" of triangles near z = 0.5 that
/// occludes many rays coming from below.
fn triangles(n: u32, seed: u32) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|i| {
            let s = seed.wrapping_mul(7919).wrapping_add(i * 5);
            if i % 3 == 0 {
                let c = Vec3::new(v(s).x, v(s).y, 0.5 + 0.01 * v(s + 1).z);
                [
                    c,
                    c + Vec3::new(0.3, 0.0, 0.0),
                    c + Vec3::new(0.0, 0.3, 0.01),
                ]
            } else {
                let c = v(s);
                [c, c + 0.15 * v(s + 1), c + 0.15 * v(s + 2)]
            }
        })
        .collect()
}

/// Segments from points below the blind to a light above (plus a few stray directions).
fn shadow_rays(n: u32, seed: u32) -> Vec<Ray> {
    let light = Vec3::new(0.2, -0.1, 1.5);
    (0..n)
        .map(|i| {
            let s = seed.wrapping_mul(104_729).wrapping_add(i * 11) ^ 0x55;
            let o = Vec3::new(v(s).x, v(s).y, -0.9 + 0.5 * r(s + 7));
            if i % 7 == 0 {
                Ray::new(o, v(s + 3), 0.0, 2.0)
            } else {
                Ray::new(o, light - o, 0.0, 1.0)
            }
        })
        .collect()
}

#[test]
fn srdh_and_baseline_answers_equal_brute_force() {
    let tris = triangles(3000, 1);
    let sah = BuildSettings::default();
    let base = build_binned_sah(&tris, &sah);
    let rays = shadow_rays(1500, 2);
    let set = RaySet::trace(&base, rays[..300].to_vec());
    assert!(set.occluded_fraction() > 0.3, "test scene occludes");
    let rtsah = rtsah_kernels(&base);
    for kernels in [KernelSet::All, KernelSet::Constant, KernelSet::Directional] {
        for leaf in [1, 3] {
            let settings = SrdhSettings {
                kernels,
                leaf,
                ..SrdhSettings::default()
            };
            let t = build_srdh(&tris, &set, &settings, &sah);
            t.bvh.validate().unwrap();
            for ray in &rays {
                let expect = brute_occluded(&tris, ray);
                assert_eq!(t.occluded(ray, &mut NoStats), expect);
                if kernels == KernelSet::All && leaf == 1 {
                    for k in Kernel::ALL {
                        assert_eq!(
                            BinaryInOrder {
                                bvh: &base,
                                order: &Uniform(k)
                            }
                            .occluded(ray, &mut NoStats),
                            expect
                        );
                    }
                    let random = RandomKernel { seed: 3 };
                    assert_eq!(
                        BinaryInOrder {
                            bvh: &base,
                            order: &random
                        }
                        .occluded(ray, &mut NoStats),
                        expect
                    );
                    assert_eq!(
                        BinaryInOrder {
                            bvh: &base,
                            order: &rtsah
                        }
                        .occluded(ray, &mut NoStats),
                        expect
                    );
                }
            }
        }
    }
}

#[test]
fn srdh_reduces_box_tests_on_its_own_rays() {
    let tris = triangles(3000, 4);
    let sah = BuildSettings {
        max_leaf_size: 1,
        ..BuildSettings::default()
    };
    let base = build_binned_sah(&tris, &sah);
    let rays = shadow_rays(800, 5);
    let set = RaySet::trace(&base, rays.clone());
    let t = build_srdh(&tris, &set, &SrdhSettings::default(), &sah);
    let (mut srdh, mut random) = (TraversalStats::default(), TraversalStats::default());
    for ray in &rays {
        t.occluded(ray, &mut srdh);
        BinaryInOrder {
            bvh: &base,
            order: &RandomKernel { seed: 0 },
        }
        .occluded(ray, &mut random);
    }
    assert!(
        srdh.boxes < random.boxes,
        "srdh {} vs random {}",
        srdh.boxes,
        random.boxes
    );
}

#[test]
fn empty_ray_set_gives_the_sah_tree() {
    let tris = triangles(2000, 7);
    for sah in [
        BuildSettings::default(),
        BuildSettings {
            max_leaf_size: 1,
            bins: 32,
            ..BuildSettings::default()
        },
    ] {
        let expect = build_binned_sah(&tris, &sah);
        let t = build_srdh(&tris, &RaySet::default(), &SrdhSettings::default(), &sah);
        assert_eq!(&*t.bvh.nodes, &*expect.nodes);
        assert_eq!(t.bvh.triangle_ids, expect.triangle_ids);
        assert_eq!(t.bvh.triangles, expect.triangles);
    }
}

#[test]
fn chosen_split_is_the_cheapest_candidate() {
    let sah = BuildSettings::default();
    for seed in 0..12u32 {
        let tris = triangles(12 + seed % 9, 100 + seed);
        let base = build_binned_sah(&tris, &sah);
        let set = RaySet::trace(&base, shadow_rays(20 + seed, 200 + seed));
        for kernels in [KernelSet::All, KernelSet::Constant, KernelSet::Directional] {
            let settings = SrdhSettings {
                bins: 2 + seed % 7,
                kernels,
                ..SrdhSettings::default()
            };
            let root = root_candidates(&tris, &set, &settings, &sah).unwrap();
            assert_eq!(root.scored.len() % kernels.kernels().len(), 0);
            let mut min = u64::MAX;
            for (c, left, right) in &root.scored {
                let cost = reference_cost(&tris, left, right, c.kernel, &set, &root.reaching);
                assert_eq!(c.cost, cost, "incremental and reference costs of {c:?}");
                assert_eq!(left.len() + right.len(), tris.len());
                min = min.min(cost);
            }
            assert_eq!(root.chosen.cost, min, "seed {seed}");
        }
    }
}

#[test]
fn cost_of_two_leaves_is_the_triangle_tests_of_the_traversal() {
    // Two triangles, one per leaf: the SRDH cost of the root split (counts 1 and 1) equals
    // the triangle tests that kernel-guided traversal performs.
    let sah = BuildSettings::default();
    for seed in 0..40u32 {
        let tris = triangles(2, 300 + seed);
        let base = build_binned_sah(&tris, &sah);
        let rays = shadow_rays(40, 400 + seed);
        let set = RaySet::trace(&base, rays.clone());
        for kernels in [KernelSet::Constant, KernelSet::Directional] {
            let settings = SrdhSettings {
                kernels,
                ..SrdhSettings::default()
            };
            let Some(root) = root_candidates(&tris, &set, &settings, &sah) else {
                continue;
            };
            let t = build_srdh(&tris, &set, &settings, &sah);
            let mut stats = TraversalStats::default();
            for &i in &root.reaching {
                t.occluded(&rays[i], &mut stats);
            }
            assert_eq!(stats.triangles, root.chosen.cost, "seed {seed}");
        }
    }
}
