use serde::{Deserialize, Serialize};

use super::Counters;
use crate::bvh::{Bvh, MAX_DEPTH};
use crate::geometry::{intersect_triangle, Ray, RayBoxPrecomp, WatertightRay};

/// The order in which the two children of a binary node are visited by an occlusion query.
/// The answer never depends on it; only the work does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum AnyHitOrder {
    /// Left child first, as the builder stored it.
    Stored,
    /// The child whose box the ray enters first (front to back).
    #[default]
    NearFirst,
}

/// True if any triangle intersects the ray in (t_min, t_max].
#[inline]
pub fn occluded<C: Counters>(bvh: &Bvh, ray: &Ray, order: AnyHitOrder, stats: &mut C) -> bool {
    let nodes = &bvh.nodes;
    let Some(root) = nodes.first() else {
        return false;
    };
    let pre = RayBoxPrecomp::new(ray);
    let wt = WatertightRay::new(ray);
    let t_min = ray.t_min;
    // Box tests reach a margin past the segment's end; triangle tests do not (see t_margin).
    let t_max = ray.t_max + pre.t_margin;
    stats.boxes(1);
    if pre.hit_packed(root.packed(), t_min, t_max).is_none() {
        return false;
    }
    let mut stack = [0u32; MAX_DEPTH];
    let mut sp = 0usize;
    let mut node = root;
    loop {
        if node.is_leaf() {
            stats.leaf();
            let first = node.first as usize;
            for slot in first..first + node.count as usize {
                stats.triangles(1);
                if intersect_triangle(&wt, &bvh.triangles[slot], t_min, ray.t_max).is_some() {
                    return true;
                }
            }
        } else {
            stats.inner();
            stats.boxes(2);
            let l = node.first as usize;
            let (a, b) = (&nodes[l], &nodes[l + 1]);
            let da = pre.hit_packed(a.packed(), t_min, t_max);
            let db = pre.hit_packed(b.packed(), t_min, t_max);
            match (da, db) {
                (Some(ta), Some(tb)) => {
                    let b_first = order == AnyHitOrder::NearFirst && tb < ta;
                    let (first, second) = if b_first { (l + 1, l) } else { (l, l + 1) };
                    stack[sp] = second as u32;
                    sp += 1;
                    node = &nodes[first];
                    continue;
                }
                (Some(_), None) => {
                    node = a;
                    continue;
                }
                (None, Some(_)) => {
                    node = b;
                    continue;
                }
                (None, None) => {}
            }
        }
        if sp == 0 {
            return false;
        }
        sp -= 1;
        node = &nodes[stack[sp] as usize];
    }
}
