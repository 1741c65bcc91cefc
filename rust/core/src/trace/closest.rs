use super::{Counters, Hit, HitFilter, Opaque};
use crate::bvh::{Bvh, BvhNode, MAX_DEPTH};
use crate::geometry::{intersect_triangle, Ray, RayBoxPrecomp, WatertightRay};

/// The closest hit along the ray in (t_min, t_max], ties broken by the smaller triangle id.
/// Children are visited near to far; a node whose entry distance exceeds the current hit is
/// culled when it comes off the stack. Box tests and culling reach a margin past the current hit
/// (see `RayBoxPrecomp::t_margin`), so a triangle at exactly the current distance with a smaller
/// id is still found.
#[inline]
pub(crate) fn closest_hit<C: Counters>(bvh: &Bvh, ray: &Ray, stats: &mut C) -> Option<Hit> {
    closest_hit_filtered(bvh, ray, &mut Opaque, stats)
}

/// [`closest_hit`] over the hits `filter` accepts: a rejected hit neither ends the search nor
/// shortens the ray. With [`Opaque`] this is today's traversal (the filter call is a constant
/// true); the filter is asked only about hits closer than the best so far.
#[inline(always)]
pub(crate) fn closest_hit_filtered<C: Counters, F: HitFilter>(
    bvh: &Bvh,
    ray: &Ray,
    filter: &mut F,
    stats: &mut C,
) -> Option<Hit> {
    let wt = WatertightRay::new(ray);
    let t_min = ray.t_min;
    let mut best: Option<Hit> = None;
    walk_near_first(&bvh.nodes, ray, stats, |first, count, mut t_max, stats| {
        stats.triangles(count as u32);
        for slot in first..first + count {
            if let Some(h) = intersect_triangle(&wt, &bvh.triangles[slot], t_min, t_max) {
                let id = bvh.triangle_ids[slot];
                if Hit::closer_than(h.t, id, &best) && filter.accepts(id, [h.b0, h.b1, h.b2], stats)
                {
                    t_max = h.t;
                    best = Some(Hit {
                        t: h.t,
                        triangle: id,
                        instance: 0,
                        b0: h.b0,
                        b1: h.b1,
                        b2: h.b2,
                    });
                }
            }
        }
        Some(t_max)
    });
    best
}

/// Walks a binary tree near child first from its root, handing each entered leaf's range
/// (`first`, `count`) to `leaf` with the ray's current `t_max`; `leaf` returns the new `t_max`
/// (lowered by a closer hit), or `None` to stop. A node whose entry lies past `t_max` (plus the
/// box margin, see `RayBoxPrecomp::t_margin`) is culled when it comes off the stack. The loop
/// of the binary closest hit (the wide top level over instances has its own,
/// `wide::walk_near_first`).
#[inline(always)]
fn walk_near_first<C: Counters>(
    nodes: &[BvhNode],
    ray: &Ray,
    stats: &mut C,
    mut leaf: impl FnMut(usize, usize, f32, &mut C) -> Option<f32>,
) {
    let Some(root) = nodes.first() else {
        return;
    };
    let pre = RayBoxPrecomp::new(ray);
    let t_min = ray.t_min;
    let mut t_max = ray.t_max;
    stats.boxes(1);
    if pre
        .hit_packed(root.packed(), t_min, t_max + pre.t_margin)
        .is_none()
    {
        return;
    }
    let mut stack = [(0u32, 0f32); MAX_DEPTH];
    let mut sp = 0usize;
    let mut node = root;
    loop {
        if node.is_leaf() {
            stats.leaf();
            match leaf(node.first as usize, node.count as usize, t_max, stats) {
                Some(t) => t_max = t,
                None => return,
            }
        } else {
            stats.inner();
            stats.boxes(2);
            let l = node.first as usize;
            let (a, b) = (&nodes[l], &nodes[l + 1]);
            let box_max = t_max + pre.t_margin;
            let da = pre.hit_packed(a.packed(), t_min, box_max);
            let db = pre.hit_packed(b.packed(), t_min, box_max);
            match (da, db) {
                (Some(ta), Some(tb)) => {
                    let (near, far, tfar) = if tb < ta {
                        (l + 1, l, ta)
                    } else {
                        (l, l + 1, tb)
                    };
                    stack[sp] = (far as u32, tfar);
                    sp += 1;
                    node = &nodes[near];
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
        // Take the next node that can still hold a closer (or equally close) hit.
        loop {
            if sp == 0 {
                return;
            }
            sp -= 1;
            let (i, t_entry) = stack[sp];
            if t_entry <= t_max + pre.t_margin {
                node = &nodes[i as usize];
                break;
            }
        }
    }
}
