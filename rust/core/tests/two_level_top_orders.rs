//! The top level's child orders for shadow rays ([`TopOrdered`], [`TopOrders`]): every order
//! answers as the brute-force reference, for single rays and runs; the walk follows the order's
//! permutation (the first instance to stop a ray is the first in the permutation's depth-first
//! order, and a run of one ray counts what its single walk counts); a light's sorted order puts
//! the subtree of the instance that stopped its rays first.

mod common;

use antumbra_core::build::{BuildSettings, CollapseSettings};
use antumbra_core::bvh::BvhWidth;
use antumbra_core::geometry::Ray;
use antumbra_core::order::{OrderView, Permutation, ShadowOrder, SortSettings};
use antumbra_core::render::{OrderedWideTree, WideTree};
use antumbra_core::scene::Scene;
use antumbra_core::trace::{NoStats, RayMode, RayQuery, TraversalStats};
use antumbra_core::two_level::{
    brute, Instance, MeshTree, TopLevel, TopOrdered, TopOrders, TwoLevel,
};

struct Built {
    meshes: Vec<MeshTree>,
    instances: Vec<Instance>,
    top: TopLevel,
}

fn two_level(scene: &Scene) -> Built {
    let settings = BuildSettings::default();
    let meshes: Vec<MeshTree> = (scene.meshes.iter())
        .map(|m| MeshTree::build(m, &settings))
        .collect();
    let (instances, top) = common::place_instances(scene, &meshes);
    Built {
        meshes,
        instances,
        top,
    }
}

fn collapse(b: &Built, width: BvhWidth) -> Vec<WideTree> {
    (b.meshes.iter())
        .map(|m| WideTree::collapse(&m.bvh, width, &CollapseSettings::default()))
        .collect()
}

fn front_to_back(trees: &[WideTree], rays: RayMode) -> Vec<OrderedWideTree<'_>> {
    (trees.iter())
        .map(|t| t.ordered(OrderView::FrontToBack).with_rays(rays))
        .collect()
}

/// Every node's used slots in reverse slot order: a permutation no other order here makes.
fn reversed(top: &TopLevel) -> Vec<Permutation> {
    (top.bvh.nodes.iter())
        .map(|n| {
            let used: Vec<usize> = (0..8).rev().filter(|&s| !n.is_empty_slot(s)).collect();
            Permutation::from_slots(&used)
        })
        .collect()
}

/// Shadow-like rays (segments) and whole lines through the scene.
fn rays() -> Vec<Ray> {
    common::render_space_rays(3000, 29)
}

/// The index (in the top level's instances) of the first instance in the depth-first order of
/// `perms` whose mesh tree occludes the ray, found without a box test: an occluding instance's
/// box is entered by the ray, so the ordered walk, which enters a subset of these leaves in
/// this order, must stop at the same instance.
fn first_in_order<Q: RayQuery>(
    top: &TopLevel,
    perms: &[Permutation],
    meshes: &[Q],
    ray: &Ray,
) -> Option<u32> {
    fn visit<Q: RayQuery>(
        top: &TopLevel,
        perms: &[Permutation],
        meshes: &[Q],
        ray: &Ray,
        node: usize,
    ) -> Option<u32> {
        let n = &top.bvh.nodes[node];
        let used = (0..8).filter(|&s| !n.is_empty_slot(s)).count();
        for k in 0..used {
            let s = perms[node].slot(k);
            let child = n.child[s] as usize;
            let found = if n.is_leaf_slot(s) {
                (child..child + n.count[s] as usize)
                    .find(|&i| {
                        let instance = &top.instances[i];
                        let mesh = &meshes[instance.mesh as usize];
                        mesh.occluded(&instance.ray_to_mesh(ray), &mut NoStats)
                    })
                    .map(|i| i as u32)
            } else {
                visit(top, perms, meshes, ray, child)
            };
            if found.is_some() {
                return found;
            }
        }
        None
    }
    visit(top, perms, meshes, ray, 0)
}

/// The orders to test over `top`: each static per-tree order, a reversed permutation, and one
/// sorted from the instances that stopped `rays` walking in SATO.
fn permutations(
    b: &Built,
    meshes: &[OrderedWideTree],
    rays: &[Ray],
) -> Vec<(String, Vec<Permutation>)> {
    let mut out = Vec::new();
    for order in [
        ShadowOrder::Sato,
        ShadowOrder::Rtsah,
        ShadowOrder::Random { seed: 5 },
    ] {
        let orders = TopOrders::prepare(&b.top, Some(&order), &[]);
        let OrderView::Permuted { perms, .. } = orders.view(&order) else {
            panic!("{order}: no permutation");
        };
        out.push((order.to_string(), perms.to_vec()));
    }
    out.push(("reversed".into(), reversed(&b.top)));
    let orders = TopOrders::default();
    let settings = SortSettings::default();
    let logging = TopOrdered {
        levels: TwoLevel {
            top: &b.top,
            meshes,
        },
        order: orders.tables(&b.top).logging_view(settings.logging),
    };
    let stoppers: Vec<u32> = (rays.iter())
        .filter_map(|r| {
            logging.first_stopper(r, |m, local| m.occluded(local, &mut NoStats).then_some(()))
        })
        .map(|(instance, _, _)| instance)
        .collect();
    assert!(
        stoppers.len() > rays.len() / 10,
        "{} rays stopped",
        stoppers.len()
    );
    let sorted = orders.sort_for_light(&b.top, &stoppers, &settings);
    assert!(sorted.nodes_sorted > 0);
    out.push(("sorted".into(), sorted.perms));
    out
}

#[test]
fn every_top_order_answers_as_brute_force_for_single_rays_and_runs() {
    let b = two_level(&common::instanced_scene(300));
    let rays = rays();
    let expected: Vec<bool> = (rays.iter())
        .map(|r| brute::brute_occluded(&b.instances, &b.meshes, r))
        .collect();
    assert!(expected.iter().filter(|o| **o).count() > rays.len() / 10);
    for width in [BvhWidth::Four, BvhWidth::Eight] {
        let trees = collapse(&b, width);
        let meshes = front_to_back(&trees, RayMode::Packet);
        let levels = TwoLevel {
            top: &b.top,
            meshes: &meshes,
        };
        let mut views = vec![("stored".to_string(), None)];
        for (name, perms) in permutations(&b, &meshes, &rays) {
            views.push((name, Some(perms)));
        }
        for (name, perms) in &views {
            let order = match perms {
                Some(perms) => OrderView::Permuted {
                    perms,
                    fallback_fbto: false,
                },
                None => OrderView::Stored,
            };
            let q = TopOrdered { levels, order };
            let single: Vec<bool> = rays.iter().map(|r| q.occluded(r, &mut NoStats)).collect();
            assert!(single == expected, "{width} {name}: single rays");
            let mut batch = vec![false; rays.len()];
            let mut counters = vec![NoStats; rays.len()];
            q.occluded_batch(&rays, &mut batch, &mut counters);
            assert!(batch == expected, "{width} {name}: runs");
            // Closest hits keep front to back whatever the order.
            for r in rays.iter().step_by(7) {
                assert_eq!(
                    q.closest_hit(r, &mut NoStats),
                    levels.closest_hit(r, &mut NoStats)
                );
            }
        }
    }
}

#[test]
fn the_walk_follows_the_permutation_for_single_rays_and_runs_of_one() {
    let b = two_level(&common::instanced_scene(300));
    let rays = rays();
    let trees = collapse(&b, BvhWidth::Eight);
    let meshes = front_to_back(&trees, RayMode::Packet);
    let levels = TwoLevel {
        top: &b.top,
        meshes: &meshes,
    };
    let orders = permutations(&b, &meshes, &rays);
    let mut firsts: Vec<Vec<Option<u32>>> = Vec::new();
    for (name, perms) in &orders {
        let q = TopOrdered {
            levels,
            order: OrderView::Permuted {
                perms,
                fallback_fbto: false,
            },
        };
        let mut first = Vec::new();
        for (i, r) in rays.iter().enumerate() {
            let stopper = q
                .first_stopper(r, |m, local| m.occluded(local, &mut NoStats).then_some(()))
                .map(|(instance, _, _)| instance);
            assert_eq!(
                stopper,
                first_in_order(&b.top, perms, &meshes, r),
                "{name}: ray {i}"
            );
            // A run of one ray enters the children in its single walk's order: the same work.
            let mut single = TraversalStats::default();
            q.occluded(r, &mut single);
            let mut run = [TraversalStats::default()];
            q.occluded_batch(std::slice::from_ref(r), &mut [false], &mut run);
            assert_eq!(run[0], single, "{name}: ray {i}");
            first.push(stopper);
        }
        firsts.push(first);
    }
    // The orders stop rays at different instances: the test sees which order is walked.
    let reversed = orders.iter().position(|(n, _)| n == "reversed").unwrap();
    for (k, (name, _)) in orders.iter().enumerate().filter(|(k, _)| *k != reversed) {
        let differ = (firsts[k].iter().zip(&firsts[reversed]))
            .filter(|(a, b)| a != b)
            .count();
        assert!(differ > 10, "{name} and reversed stop {differ} rays apart");
    }
}

#[test]
fn a_lights_sorted_top_level_enters_the_subtree_of_its_stopper_first() {
    let b = two_level(&common::instanced_scene(300));
    let orders = TopOrders::default();
    let nodes = &b.top.bvh.nodes;
    // Every ray stopped in one instance, chosen deep in the tree.
    let target = b.top.len() as u32 / 2 + 3;
    let sorted = orders.sort_for_light(&b.top, &[target; 50], &SortSettings::default());
    // The path from the root down to the target's leaf: each node must enter it first.
    let mut node = 0usize;
    let mut depth = 0;
    loop {
        let n = &nodes[node];
        let slot = (0..8)
            .filter(|&s| !n.is_empty_slot(s))
            .find(|&s| {
                let (first, last) =
                    leaf_range(&b.top, n.child[s] as usize, n.is_leaf_slot(s), n.count[s]);
                (first..last).contains(&target)
            })
            .expect("the target is below its node");
        assert_eq!(
            sorted.perms[node].slot(0),
            slot,
            "node {node} at depth {depth}"
        );
        if n.is_leaf_slot(slot) {
            break;
        }
        node = n.child[slot] as usize;
        depth += 1;
    }
    assert!(depth > 0, "the target lies below the root");
    assert_eq!(sorted.nodes_sorted, depth + 1, "only the path is sorted");
    assert_eq!(sorted.occluded_rays, 50);
}

/// The instances below a child: a leaf's range, or an interior node's leaves' union (the
/// instances are in leaf order, so a subtree's are a contiguous range).
fn leaf_range(top: &TopLevel, child: usize, leaf: bool, count: u8) -> (u32, u32) {
    if leaf {
        return (child as u32, child as u32 + count as u32);
    }
    let n = &top.bvh.nodes[child];
    let (mut lo, mut hi) = (u32::MAX, 0);
    for s in (0..8).filter(|&s| !n.is_empty_slot(s)) {
        let (a, b) = leaf_range(top, n.child[s] as usize, n.is_leaf_slot(s), n.count[s]);
        lo = lo.min(a);
        hi = hi.max(b);
    }
    (lo, hi)
}
