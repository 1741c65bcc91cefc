//! Per-node child permutations that depend only on the tree: SATO (largest child box first),
//! RTSAH (children by estimated termination probability over cost) and a seeded random order.

use super::cost::{expected_cost, order_by_ratio};
use super::Permutation;
use crate::bvh::WideBvh;
use crate::geometry::Aabb;
use crate::sampling::hash_combine;

fn used_slots<const N: usize>(bvh: &WideBvh<N>, node: usize) -> Vec<usize> {
    (0..N)
        .filter(|&s| !bvh.nodes[node].is_empty_slot(s))
        .collect()
}

fn area(b: &Aabb) -> f64 {
    b.half_area() as f64
}

/// Surface Area Traversal Order (Nah & Manocha 2014): the child with the largest box first
/// (ties by slot). Unused slots are never hit and are left out.
pub fn sato<const N: usize>(bvh: &WideBvh<N>) -> Vec<Permutation> {
    (0..bvh.nodes.len())
        .map(|i| Permutation::from_slots(&sato_slots(bvh, i)))
        .collect()
}

pub(crate) fn sato_slots<const N: usize>(bvh: &WideBvh<N>, node: usize) -> Vec<usize> {
    let n = &bvh.nodes[node];
    let mut slots = used_slots(bvh, node);
    slots.sort_by(|&a, &b| {
        area(&n.child_bounds(b))
            .total_cmp(&area(&n.child_bounds(a)))
            .then(a.cmp(&b))
    });
    slots
}

/// A random order per node, reproducible from `seed`.
pub fn random<const N: usize>(bvh: &WideBvh<N>, seed: u32) -> Vec<Permutation> {
    (0..bvh.nodes.len())
        .map(|i| {
            let mut slots = used_slots(bvh, i);
            // Fisher-Yates with a hash of (seed, node, step).
            let h = hash_combine(seed, i as u32);
            for k in (1..slots.len()).rev() {
                let j = hash_combine(h, k as u32) as usize % (k + 1);
                slots.swap(k, j);
            }
            Permutation::from_slots(&slots)
        })
        .collect()
}

/// What RTSAH estimates of a subtree, from geometry alone: the probability that a ray entering
/// its box is stopped inside it, and the expected cost of tracing it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StopEstimate {
    pub stop: f64,
    pub cost: f64,
}

/// RTSAH-style order (Ize & Hansen 2011), generalised to N children: each subtree gets an
/// estimated probability that a ray entering its box is stopped inside it, and an expected
/// cost, bottom-up from geometry alone (no rays):
/// - a leaf's triangles stop a ray entering its box with probability ~ sum of 2·A_tri / S_box
///   (a flat triangle's mean projected area is half its area, a convex box's a quarter of its
///   surface), capped at 1; visiting it costs 1 + its triangle count;
/// - a node's children are hit with probability P_i = S_i / S_node; child i stops the ray with
///   Q_i = P_i·α_i and costs C_i = P_i·C(child). Children are ordered by Q_i / C_i decreasing
///   (which minimises the expected cost, see `cost`), and the node's α and C follow from it.
pub fn rtsah<const N: usize>(bvh: &WideBvh<N>) -> Vec<Permutation> {
    rtsah_estimated(bvh).0
}

/// [`rtsah`] and the root's estimate (what an instance of the tree weighs in a top level's
/// RTSAH, [`rtsah_over`]).
pub fn rtsah_estimated<const N: usize>(bvh: &WideBvh<N>) -> (Vec<Permutation>, StopEstimate) {
    rtsah_over(bvh, |first, count, leaf_box| {
        let tri_area: f64 = bvh.triangles[first..first + count]
            .iter()
            .map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length() as f64)
            .sum();
        // half_area is half the surface: 2·A / S = A / half_area.
        StopEstimate {
            stop: (tri_area / area(leaf_box).max(f64::MIN_POSITIVE)).min(1.0),
            cost: 1.0 + count as f64,
        }
    })
}

/// RTSAH over any leaves: `leaf(first, count, box)` estimates a leaf slot's contents (a mesh
/// tree's triangles, or a top level's instances from their mesh trees' estimates). Returns the
/// permutations and the root's estimate (stop 0, cost 0 for an empty tree).
pub fn rtsah_over<const N: usize>(
    bvh: &WideBvh<N>,
    leaf: impl Fn(usize, usize, &Aabb) -> StopEstimate,
) -> (Vec<Permutation>, StopEstimate) {
    let mut perms = vec![Permutation::NONE; bvh.nodes.len()];
    // (termination probability, expected cost) per node, children before parents.
    let mut est = vec![(0.0f64, 0.0f64); bvh.nodes.len()];
    for i in (0..bvh.nodes.len()).rev() {
        let node = &bvh.nodes[i];
        let slots = used_slots(bvh, i);
        let mut union = Aabb::EMPTY;
        for &s in &slots {
            union.grow(&node.child_bounds(s));
        }
        let s_node = area(&union).max(f64::MIN_POSITIVE);
        let (mut q, mut c) = (Vec::new(), Vec::new());
        for &s in &slots {
            let b = node.child_bounds(s);
            let p = area(&b) / s_node;
            let (alpha, cost) = if node.is_leaf_slot(s) {
                let e = leaf(node.child[s] as usize, node.count[s] as usize, &b);
                (e.stop, e.cost)
            } else {
                est[node.child[s] as usize]
            };
            q.push(p * alpha);
            c.push(p * cost);
        }
        let ranks: Vec<usize> = (0..slots.len()).collect();
        let order = order_by_ratio(&q, &c, &ranks);
        let sq: Vec<f64> = order.iter().map(|&k| q[k]).collect();
        let sc: Vec<f64> = order.iter().map(|&k| c[k]).collect();
        let stop = 1.0 - q.iter().map(|qi| 1.0 - qi).product::<f64>();
        est[i] = (stop, 1.0 + expected_cost(&sq, &sc));
        perms[i] = Permutation::from_slots(&order.iter().map(|&k| slots[k]).collect::<Vec<_>>());
    }
    let root = est.first().map_or(
        StopEstimate {
            stop: 0.0,
            cost: 0.0,
        },
        |&(stop, cost)| StopEstimate { stop, cost },
    );
    (perms, root)
}
