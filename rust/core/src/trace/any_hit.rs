//! The one any-hit traversal of binary trees (the SAH tree and a light's SRDH tree), generic over
//! the child order: every order is its own instance, so the timed loop reads no run-time choice.

use glam::Vec3;

use super::{Counters, HitFilter, Opaque};
use crate::bvh::{Bvh, BvhNode, MAX_DEPTH};
use crate::geometry::{intersect_triangle, Ray, RayBoxPrecomp, WatertightRay};
use crate::order::{centre, AnyHitOrder, ChildOrder, Children, FrontToBack, OrderRay, Stored};

/// True if any triangle intersects the ray in (t_min, t_max], visiting children in `order`.
#[inline]
pub(crate) fn occluded<C: Counters>(
    bvh: &Bvh,
    ray: &Ray,
    order: AnyHitOrder,
    stats: &mut C,
) -> bool {
    match order {
        AnyHitOrder::Stored => occluding_leaf(bvh, &Stored, ray, stats).is_some(),
        AnyHitOrder::NearFirst => occluding_leaf(bvh, &FrontToBack, ray, stats).is_some(),
    }
}

/// Two sibling nodes as an order reads them.
struct Siblings<'a> {
    t: [f32; 2],
    nodes: [&'a BvhNode; 2],
}

impl Children for Siblings<'_> {
    #[inline(always)]
    fn t_near(&self, slot: usize) -> f32 {
        self.t[slot]
    }
    #[inline(always)]
    fn centre(&self, slot: usize) -> Vec3 {
        centre(self.nodes[slot])
    }
}

/// The leaf (node index) whose triangle stopped the ray, `None` if nothing did (the walk is
/// [`any_hit_walk`]'s).
#[inline(always)]
pub fn occluding_leaf<O: ChildOrder, C: Counters>(
    bvh: &Bvh,
    order: &O,
    ray: &Ray,
    stats: &mut C,
) -> Option<usize> {
    occluding_leaf_filtered(bvh, order, ray, &mut Opaque, stats)
}

/// [`occluding_leaf`] with a rule for hits: the leaf whose hit `filter` stopped the ray at.
/// With [`Opaque`] this is today's traversal, instruction for instruction (the filter's
/// `OPAQUE` constant removes the other branch); any other filter is handed every hit with its
/// triangle id and barycentrics.
#[inline(always)]
pub(crate) fn occluding_leaf_filtered<O: ChildOrder, C: Counters, F: HitFilter>(
    bvh: &Bvh,
    order: &O,
    ray: &Ray,
    filter: &mut F,
    stats: &mut C,
) -> Option<usize> {
    let wt = WatertightRay::new(ray);
    let (t_min, t_max) = (ray.t_min, ray.t_max);
    any_hit_walk(&bvh.nodes, order, ray, stats, |leaf, stats| {
        let first = leaf.first as usize;
        for slot in first..first + leaf.count as usize {
            stats.triangles(1);
            if F::OPAQUE {
                if intersect_triangle(&wt, &bvh.triangles[slot], t_min, t_max).is_some() {
                    return true;
                }
            } else if let Some(h) = intersect_triangle(&wt, &bvh.triangles[slot], t_min, t_max) {
                let id = bvh.triangle_ids[slot];
                if filter.stops(id, h.t, [h.b0, h.b1, h.b2], stats) {
                    return true;
                }
            }
        }
        false
    })
}

/// The any-hit walk of a binary tree in `order`, whatever its leaves hold: `stops` is handed
/// each leaf entered (its range) and says whether the ray stopped there; the answer is that
/// leaf's node index. [`occluding_leaf_filtered`] tests triangles in it; a light's SRDH tree
/// over a top level's instances enters their mesh trees (`crate::two_level`).
///
/// A node is entered once its box is hit. Its box is tested at the parent, both siblings at
/// once, so that the order may read their entry distances; or, for orders that read none
/// ([`ChildOrder::TEST_ON_ENTRY`]: the SRDH kernels), only on entering it, so that a ray stopped
/// in the first child never tests the second's box. N_box counts the tests made either way;
/// the walk counts N_B and N_L, `stops` what it tests in a leaf.
#[inline(always)]
pub(crate) fn any_hit_walk<O: ChildOrder, C: Counters>(
    nodes: &[BvhNode],
    order: &O,
    ray: &Ray,
    stats: &mut C,
    mut stops: impl FnMut(&BvhNode, &mut C) -> bool,
) -> Option<usize> {
    let root = nodes.first()?;
    let pre = RayBoxPrecomp::new(ray);
    let oray = OrderRay::new::<O>(ray);
    let t_min = ray.t_min;
    // Box tests reach a margin past the segment's end; triangle tests do not (see t_margin).
    let t_max = ray.t_max + pre.t_margin;
    stats.boxes(1);
    pre.hit_packed(root.packed(), t_min, t_max)?;
    // Entries: hit children (tested at the parent) or children still to test (on entry).
    let mut stack = [0u32; MAX_DEPTH];
    let mut sp = 0usize;
    // The current node as a reference, as the single-hit step needs no index; its index is
    // only derived where an order or the answer reads it.
    let mut node = root;
    loop {
        if node.is_leaf() {
            stats.leaf();
            if stops(node, stats) {
                return Some(index_of(nodes, node));
            }
        } else {
            stats.inner();
            let l = node.first as usize;
            let (a, b) = (&nodes[l], &nodes[l + 1]);
            if O::TEST_ON_ENTRY {
                let pair = Siblings {
                    t: [0.0; 2],
                    nodes: [a, b],
                };
                let b_first = order.second_first(index_of(nodes, node), 0, 1, &oray, &pair);
                let (first, second) = if b_first { (b, l) } else { (a, l + 1) };
                stack[sp] = second as u32;
                sp += 1;
                stats.boxes(1);
                if pre.hit_packed(first.packed(), t_min, t_max).is_some() {
                    node = first;
                    continue;
                }
            } else {
                stats.boxes(2);
                let da = pre.hit_packed(a.packed(), t_min, t_max);
                let db = pre.hit_packed(b.packed(), t_min, t_max);
                match (da, db) {
                    (Some(ta), Some(tb)) => {
                        let pair = Siblings {
                            t: [ta, tb],
                            nodes: [a, b],
                        };
                        let b_first = order.second_first(index_of(nodes, node), 0, 1, &oray, &pair);
                        let (first, second) = if b_first { (b, l) } else { (a, l + 1) };
                        stack[sp] = second as u32;
                        sp += 1;
                        node = first;
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
        }
        // The next entry: hit already, or (entry tests) hit when tested now.
        loop {
            if sp == 0 {
                return None;
            }
            sp -= 1;
            node = &nodes[stack[sp] as usize];
            if !O::TEST_ON_ENTRY {
                break;
            }
            stats.boxes(1);
            if pre.hit_packed(node.packed(), t_min, t_max).is_some() {
                break;
            }
        }
    }
}

/// The index of `node` in `nodes` (a subtraction: cheaper than carrying it through the loop).
#[inline(always)]
fn index_of(nodes: &[BvhNode], node: &BvhNode) -> usize {
    (node as *const BvhNode as usize - nodes.as_ptr() as usize) / std::mem::size_of::<BvhNode>()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build::{build_binned_sah, BuildSettings};
    use crate::order::{rtsah_kernels, Kernel, RandomKernel, Uniform};
    use crate::sampling::{hash_u32, unit_float};
    use crate::trace::TraversalStats;

    /// The binary traversal before the merge, children tested at the parent.
    fn reference_parent_tests(
        bvh: &Bvh,
        ray: &Ray,
        near_first: bool,
        stats: &mut TraversalStats,
    ) -> Option<usize> {
        let nodes = &bvh.nodes;
        let root = nodes.first()?;
        let pre = RayBoxPrecomp::new(ray);
        let wt = WatertightRay::new(ray);
        let (t_min, t_max) = (ray.t_min, ray.t_max + pre.t_margin);
        stats.boxes(1);
        pre.hit_packed(root.packed(), t_min, t_max)?;
        let mut stack = vec![];
        let mut i = 0;
        loop {
            let node = &nodes[i];
            if node.is_leaf() {
                stats.leaf();
                for slot in node.first as usize..(node.first + node.count) as usize {
                    stats.triangles(1);
                    if intersect_triangle(&wt, &bvh.triangles[slot], t_min, ray.t_max).is_some() {
                        return Some(i);
                    }
                }
            } else {
                stats.inner();
                stats.boxes(2);
                let l = node.first as usize;
                let da = pre.hit_packed(nodes[l].packed(), t_min, t_max);
                let db = pre.hit_packed(nodes[l + 1].packed(), t_min, t_max);
                match (da, db) {
                    (Some(ta), Some(tb)) => {
                        let b_first = near_first && tb < ta;
                        let (f, s) = if b_first { (l + 1, l) } else { (l, l + 1) };
                        stack.push(s);
                        i = f;
                        continue;
                    }
                    (Some(_), None) => {
                        i = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        i = l + 1;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            i = stack.pop()?;
        }
    }

    /// SRDH's kernel-guided traversal before the merge, a box tested on entering it.
    fn reference_entry_tests(
        bvh: &Bvh,
        left_first: impl Fn(usize, &BvhNode, &BvhNode) -> bool,
        ray: &Ray,
        stats: &mut TraversalStats,
    ) -> Option<usize> {
        let nodes = &bvh.nodes;
        let pre = RayBoxPrecomp::new(ray);
        let wt = WatertightRay::new(ray);
        let (t_min, t_box) = (ray.t_min, ray.t_max + pre.t_margin);
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let node = &nodes[i as usize];
            stats.boxes(1);
            if pre.hit_packed(node.packed(), t_min, t_box).is_none() {
                continue;
            }
            if node.is_leaf() {
                stats.leaf();
                for slot in node.first as usize..(node.first + node.count) as usize {
                    stats.triangles(1);
                    if intersect_triangle(&wt, &bvh.triangles[slot], t_min, ray.t_max).is_some() {
                        return Some(i as usize);
                    }
                }
            } else {
                stats.inner();
                let l = node.first;
                let lf = left_first(i as usize, &nodes[l as usize], &nodes[l as usize + 1]);
                let (f, s) = if lf { (l, l + 1) } else { (l + 1, l) };
                stack.extend([s, f]);
            }
        }
        None
    }

    fn r(seed: u32) -> f32 {
        unit_float(hash_u32(seed))
    }

    fn v(seed: u32) -> Vec3 {
        Vec3::new(r(3 * seed), r(3 * seed + 1), r(3 * seed + 2)) * 2.0 - 1.0
    }

    /// Every order gives the former traversal's leaf and counts, ray for ray.
    #[test]
    fn one_traversal_equals_the_former_three() {
        let tris: Vec<[Vec3; 3]> = (0..400)
            .map(|i| {
                let c = v(i * 3);
                [c, c + 0.2 * v(i * 3 + 1), c + 0.2 * v(i * 3 + 2)]
            })
            .collect();
        let settings = BuildSettings {
            max_leaf_size: 2,
            ..BuildSettings::default()
        };
        let bvh = build_binned_sah(&tris, &settings);
        let rtsah = rtsah_kernels(&bvh);
        let (mut hits, mut rays) = (0, 0);
        for k in 0..600u32 {
            let o = 1.5 * v(10_000 + k);
            let d = v(20_000 + k) - o;
            let ray = Ray::new(o, d, 0.0, if k % 5 == 0 { f32::INFINITY } else { 1.0 });
            rays += 1;
            for near_first in [false, true] {
                let (mut want, mut got) = (TraversalStats::default(), TraversalStats::default());
                let expect = reference_parent_tests(&bvh, &ray, near_first, &mut want);
                let leaf = if near_first {
                    occluding_leaf(&bvh, &FrontToBack, &ray, &mut got)
                } else {
                    occluding_leaf(&bvh, &Stored, &ray, &mut got)
                };
                assert_eq!(
                    (leaf, got),
                    (expect, want),
                    "ray {k} near_first {near_first}"
                );
                hits += expect.is_some() as u32;
            }
            let oray = OrderRay::new::<RandomKernel>(&ray);
            let random = RandomKernel { seed: 5 };
            let check =
                |order: &dyn Fn(&mut TraversalStats) -> Option<usize>,
                 left_first: &dyn Fn(usize, &BvhNode, &BvhNode) -> bool| {
                    let (mut want, mut got) =
                        (TraversalStats::default(), TraversalStats::default());
                    let expect = reference_entry_tests(&bvh, left_first, &ray, &mut want);
                    assert_eq!((order(&mut got), got), (expect, want), "ray {k}");
                };
            for kernel in Kernel::ALL {
                check(
                    &|s| occluding_leaf(&bvh, &Uniform(kernel), &ray, s),
                    &|_, l, r| kernel.left_first_nodes(ray.origin, l, r),
                );
            }
            check(&|s| occluding_leaf(&bvh, &rtsah, &ray, s), &|i, l, r| {
                rtsah.get(i).left_first_nodes(ray.origin, l, r)
            });
            check(&|s| occluding_leaf(&bvh, &random, &ray, s), &|i, _, _| {
                crate::sampling::hash_combine(crate::sampling::hash_combine(5, oray.key), i as u32)
                    & 1
                    == 0
            });
        }
        assert!(hits > 100 && hits < 2 * rays - 100, "{hits} of {rays}");
    }
}
