//! The wide BVH: the collapse keeps every triangle in one leaf; every width, child order and box
//! kernel gives the brute-force answers; the SIMD kernels do exactly the scalar kernel's work;
//! the 2-wide tree does exactly the binary traversal's work; sorting changes work, not answers;
//! and the Q/C order minimises the node cost of equation (1) over all permutations.

use antumbra_core::build::{build_binned_sah, BuildSettings, CollapseMethod, CollapseSettings};
use antumbra_core::bvh::{Bvh, WideBvh, MAX_DEPTH};
use antumbra_core::geometry::Ray;
use antumbra_core::order::cost::{expected_cost, order_by_ratio};
use antumbra_core::order::{AnyHitOrder, ShadowOrder};
use antumbra_core::order::{OrderView, PreparedOrder};
use antumbra_core::sampling::{hash_u32, unit_float};
use antumbra_core::trace::wide::{BoxKernel, WideQueries};
use antumbra_core::trace::{
    brute_closest_hit, brute_occluded, NoStats, OrderedBinary, RayQuery, TraversalStats,
};
use glam::Vec3;
use proptest::prelude::*;

fn r(seed: u32) -> f32 {
    unit_float(hash_u32(seed))
}

fn rand3(seed: u32) -> Vec3 {
    Vec3::new(r(seed), r(seed ^ 0x5555_5555), r(seed ^ 0x3333_3333))
}

/// Random triangles plus a few large occluder walls, so shadow-like rays are often stopped.
fn scene(n: u32, seed: u32) -> Vec<[Vec3; 3]> {
    let mut tris: Vec<[Vec3; 3]> = (0..n)
        .map(|i| {
            let c = rand3(seed + 3 * i) * 10.0 - 5.0;
            let s = 0.05 + r(seed + 3 * i + 1) * 1.5;
            [
                c + (rand3(seed + 7 * i + 11) - 0.5) * s,
                c + (rand3(seed + 7 * i + 12) - 0.5) * s,
                c + (rand3(seed + 7 * i + 13) - 0.5) * s,
            ]
        })
        .collect();
    for z in [-2.0f32, 2.0] {
        tris.push([
            Vec3::new(-6.0, -6.0, z),
            Vec3::new(6.0, -6.0, z),
            Vec3::new(-6.0, 6.0, z),
        ]);
    }
    tris
}

fn rays(n: u32, seed: u32) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let o = rand3(seed + 2 * i) * 14.0 - 7.0;
            let mut d = rand3(seed + 2 * i + 1) * 2.0 - 1.0;
            match i % 8 {
                0 => d = Vec3::new(d.x, 0.0, -0.0),
                1 => d = Vec3::new(-0.0, d.y, 0.0),
                2 => d = Vec3::new(d.x, 1e-7, d.z),
                _ => {}
            }
            // Shadow-like segments (t in (0, 1]) and unbounded rays.
            let t_max = if i % 3 == 0 { 1.0 } else { f32::INFINITY };
            Ray::new(o, d * 4.0, 0.0, t_max)
        })
        .filter(|r| r.direction != Vec3::ZERO)
        .collect()
}

fn orders() -> Vec<ShadowOrder> {
    [
        "stored",
        "fbto",
        "sato",
        "rtsah",
        "random:seed=3",
        "sorted",
        "sorted:logging=fbto:p=area",
        "sorted:depth=2:budget=0.5",
    ]
    .iter()
    .map(|s| s.parse().unwrap())
    .collect()
}

const KERNELS: [BoxKernel; 4] = [
    BoxKernel::Scalar,
    BoxKernel::Sse,
    BoxKernel::Avx2,
    BoxKernel::Auto,
];

/// Both collapses of width N against brute force (see `check_tree`); occluded rays counted.
fn check_width<const N: usize>(bvh: &Bvh, tris: &[[Vec3; 3]], rays: &[Ray]) -> usize
where
    WideBvh<N>: WideQueries,
{
    CollapseMethod::ALL
        .into_iter()
        .map(|m| {
            check_tree(
                &WideBvh::<N>::collapse_with(bvh, &CollapseSettings::new(m)),
                tris,
                rays,
            )
        })
        .sum()
}

/// Every order and kernel of width N against brute force, and SIMD work == scalar work.
fn check_tree<const N: usize>(wide: &WideBvh<N>, tris: &[[Vec3; 3]], rays: &[Ray]) -> usize
where
    WideBvh<N>: WideQueries,
{
    wide.validate().unwrap();
    let brute: Vec<(Option<(u32, f32)>, bool)> = rays
        .iter()
        .map(|r| {
            (
                brute_closest_hit(tris, r).map(|h| (h.triangle, h.t)),
                brute_occluded(tris, r),
            )
        })
        .collect();
    let mut missed_root = 0;
    for (i, ray) in rays.iter().enumerate() {
        let mut work = Vec::new();
        // The whole hit, barycentrics included, is the scalar kernel's with every kernel.
        let scalar = WideQueries::closest_hit(wide, ray, BoxKernel::Scalar, &mut NoStats);
        for k in KERNELS {
            let mut st = TraversalStats::default();
            let hit = WideQueries::closest_hit(wide, ray, k, &mut st);
            assert_eq!(hit, scalar, "N={N} {k:?} closest hit, ray {i}: {ray:?}");
            let h = hit.map(|h| (h.triangle, h.t));
            assert_eq!(h, brute[i].0, "N={N} {k:?} closest, ray {i}: {ray:?}");
            // The timed path (no counters) skips the root box test: the same answers.
            let hit = WideQueries::closest_hit(wide, ray, k, &mut NoStats);
            assert_eq!(
                hit, scalar,
                "N={N} {k:?} closest uncounted, ray {i}: {ray:?}"
            );
            work.push(st);
        }
        assert!(
            work.windows(2).all(|w| w[0] == w[1]),
            "N={N} closest work {work:?}"
        );
        missed_root += (work[0].inner == 0) as usize;
    }
    // Some rays miss the root box, so the uncounted path's skipped root test is exercised.
    assert!(missed_root > 0, "N={N}: no ray misses the root box");
    let mut occluded_rays = 0;
    for order in orders() {
        let prepared =
            PreparedOrder::new(wide, &order, None, &rays[..rays.len() / 4], BoxKernel::Auto);
        for (i, ray) in rays.iter().enumerate() {
            let mut work = Vec::new();
            for k in KERNELS {
                let mut st = TraversalStats::default();
                let occ = WideQueries::occluded(wide, ray, prepared.view(), k, &mut st);
                assert_eq!(occ, brute[i].1, "N={N} {order} {k:?}, ray {i}: {ray:?}");
                let occ = WideQueries::occluded(wide, ray, prepared.view(), k, &mut NoStats);
                assert_eq!(occ, brute[i].1, "N={N} {order} {k:?} uncounted, ray {i}");
                work.push(st);
            }
            assert!(
                work.windows(2).all(|w| w[0] == w[1]),
                "N={N} {order}: {work:?}"
            );
            occluded_rays += brute[i].1 as usize;
        }
    }
    occluded_rays
}

#[test]
fn every_width_order_and_kernel_matches_brute_force() {
    for (seed, leaf) in [(1u32, 1usize), (2, 4), (3, 8)] {
        let tris = scene(2000, seed * 100_000);
        let bvh = build_binned_sah(
            &tris,
            &BuildSettings {
                max_leaf_size: leaf,
                ..BuildSettings::default()
            },
        );
        let rays = rays(1500, seed * 7_000_000);
        let occ = check_width::<2>(&bvh, &tris, &rays)
            + check_width::<4>(&bvh, &tris, &rays)
            + check_width::<8>(&bvh, &tris, &rays);
        assert!(
            occ > rays.len(),
            "too few occluded rays ({occ}) to mean anything"
        );
    }
}

/// A deep tree (the builder peels triangles off a geometric sequence a few at a time) collapses
/// into wide trees no deeper than `MAX_DEPTH`, which the traversal stack is sized for, and
/// traces correctly at every width with rays that pass every triangle.
#[test]
fn deepest_trees_fit_the_traversal_stack() {
    let tris: Vec<[Vec3; 3]> = (0..2000)
        .map(|k| {
            let x = 1e30f32 * 0.9f32.powi(k);
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
                Vec3::new(x, 0.0, 1.0),
            ]
        })
        .collect();
    let bvh = build_binned_sah(
        &tris,
        &BuildSettings {
            max_leaf_size: 1,
            ..BuildSettings::default()
        },
    );
    assert!(bvh.depth() > 40, "binary depth {}", bvh.depth());
    // Rays along the sequence (each passes every triangle), across it, and some that miss.
    let rays: Vec<Ray> = (0..300u32)
        .map(|i| {
            let (y, z) = (r(3 * i) * 0.7 - 0.1, r(3 * i + 1) * 0.7 - 0.1);
            let x = 1e30 * 0.9f32.powi((r(3 * i + 2) * 2000.0) as i32);
            match i % 3 {
                0 => Ray::new(Vec3::new(-1.0, y, z), Vec3::X, 0.0, f32::INFINITY),
                1 => Ray::new(Vec3::new(2e30, y, z), -Vec3::X, 0.0, 2e30 - x),
                _ => Ray::new(Vec3::new(x, y, -5.0), Vec3::Y, 0.0, 10.0),
            }
        })
        .collect();
    fn levels<const N: usize>(w: &WideBvh<N>) -> usize {
        *w.depth.last().unwrap() as usize + 1
    }
    for m in CollapseMethod::ALL {
        let s = CollapseSettings::new(m);
        let (w4, w8) = (
            WideBvh::<4>::collapse_with(&bvh, &s),
            WideBvh::<8>::collapse_with(&bvh, &s),
        );
        assert!(levels(&w4) <= MAX_DEPTH && levels(&w8) <= MAX_DEPTH);
        assert!(levels(&w8) > 12, "8-wide levels {}", levels(&w8));
        check_tree(&w4, &tris, &rays);
        check_tree(&w8, &tris, &rays);
    }
}

#[test]
fn two_wide_tree_does_the_binary_traversals_work() {
    let tris = scene(3000, 42);
    let bvh = build_binned_sah(&tris, &BuildSettings::default());
    let wide = WideBvh::<2>::collapse(&bvh);
    let interior = bvh.nodes.iter().skip(2).filter(|n| !n.is_leaf()).count() + 1;
    assert_eq!(wide.nodes.len(), interior);
    for ray in rays(3000, 9) {
        for (binary, order) in [
            (AnyHitOrder::Stored, OrderView::Stored),
            (AnyHitOrder::NearFirst, OrderView::FrontToBack),
        ] {
            let (mut a, mut b) = (TraversalStats::default(), TraversalStats::default());
            assert_eq!(
                OrderedBinary {
                    bvh: &bvh,
                    order: binary
                }
                .occluded(&ray, &mut a),
                WideQueries::occluded(&wide, &ray, order, BoxKernel::Auto, &mut b)
            );
            assert_eq!(a, b, "{binary:?} {ray:?}");
        }
        let (mut a, mut b) = (TraversalStats::default(), TraversalStats::default());
        assert_eq!(
            bvh.closest_hit(&ray, &mut a).map(|h| h.triangle),
            WideQueries::closest_hit(&wide, &ray, BoxKernel::Auto, &mut b).map(|h| h.triangle)
        );
        assert_eq!(a, b, "closest {ray:?}");
    }
}

#[test]
fn wider_trees_have_fewer_nodes_and_full_slots() {
    let tris = scene(5000, 5);
    let bvh = build_binned_sah(&tris, &BuildSettings::default());
    let w4 = WideBvh::<4>::collapse(&bvh);
    let w8 = WideBvh::<8>::collapse(&bvh);
    assert!(w8.nodes.len() < w4.nodes.len());
    // The default (SAH-optimal) collapse keeps the nodes well filled (the greedy one measured
    // 4.6 children per 8-wide node on this scene).
    let slots: usize = w8.nodes.iter().map(|n| n.arity()).sum();
    let mean = slots as f64 / w8.nodes.len() as f64;
    assert!(mean > 4.0, "mean arity {mean}");
    assert!(WideBvh::<8>::collapse(&build_binned_sah(&[], &BuildSettings::default())).is_empty());
}

#[test]
fn sorting_changes_work_not_answers_and_learns_the_occluder() {
    // The two walls stop most of the shadow rays; sorting by logged occlusion must find them
    // sooner than the stored order does.
    let tris = scene(4000, 77);
    let bvh = build_binned_sah(&tris, &BuildSettings::default());
    let wide = WideBvh::<8>::collapse(&bvh);
    let shadow: Vec<Ray> = (0..4000)
        .map(|i| {
            let o = rand3(i * 3 + 1) * 10.0 - 5.0;
            let o = Vec3::new(o.x, o.y, -5.5);
            Ray::new(o, Vec3::new(0.0, 0.0, 11.0) + rand3(i) - 0.5, 0.0, 1.0)
        })
        .collect();
    let work = |order: &str| {
        let order: ShadowOrder = order.parse().unwrap();
        let p = PreparedOrder::new(&wide, &order, None, &shadow, BoxKernel::Auto);
        let mut st = TraversalStats::default();
        let answers: Vec<bool> = shadow
            .iter()
            .map(|r| WideQueries::occluded(&wide, r, p.view(), BoxKernel::Auto, &mut st))
            .collect();
        (answers, st)
    };
    let (stored, stored_work) = work("stored");
    let (sato, sato_work) = work("sato");
    let (sorted, sorted_work) = work("sorted:budget=1");
    assert_eq!(stored, sorted);
    assert_eq!(sato, sorted);
    assert!(sorted.iter().filter(|o| **o).count() > shadow.len() / 2);
    assert!(
        sorted_work.inner < sato_work.inner && sorted_work.inner < stored_work.inner,
        "sorted {sorted_work:?} sato {sato_work:?} stored {stored_work:?}"
    );
}

fn permutations(n: usize) -> Vec<Vec<usize>> {
    if n == 0 {
        return vec![vec![]];
    }
    let mut out = Vec::new();
    for p in permutations(n - 1) {
        for i in 0..=p.len() {
            let mut q = p.clone();
            q.insert(i, n - 1);
            out.push(q);
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Equation (1) evaluated for every permutation is never below the Q/C order's value.
    #[test]
    fn ratio_order_minimises_equation_one(
        qc in prop::collection::vec((0.0f64..=1.0, 0.0f64..10.0), 1..=8),
        normalise in any::<bool>(),
    ) {
        let mut q: Vec<f64> = qc.iter().map(|x| x.0).collect();
        let c: Vec<f64> = qc.iter().map(|x| x.1).collect();
        let total: f64 = q.iter().sum();
        if normalise && total > 0.0 {
            // The paper's Q_i = |R_i| / |R|.
            q.iter_mut().for_each(|x| *x /= total);
        }
        let ranks: Vec<usize> = (0..q.len()).collect();
        let best = order_by_ratio(&q, &c, &ranks);
        let cost = |p: &[usize]| {
            let pq: Vec<f64> = p.iter().map(|&i| q[i]).collect();
            let pc: Vec<f64> = p.iter().map(|&i| c[i]).collect();
            expected_cost(&pq, &pc)
        };
        let ours = cost(&best);
        let brute = permutations(q.len()).iter().map(|p| cost(p)).fold(f64::INFINITY, f64::min);
        prop_assert!(ours <= brute + 1e-9 * (1.0 + brute.abs()), "ours {ours} brute {brute}");
    }
}
