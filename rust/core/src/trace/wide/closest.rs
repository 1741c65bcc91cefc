//! Closest hit on a wide BVH: the children a ray hits are visited near to far, the farther
//! ones stacked with their entry distance and culled when a closer hit is known by the time they
//! come off the stack. Same tie rule and `t_margin` reach as the binary traversal.

use super::any_hit::{near_to_far, ChildRef};
use super::boxes::{ChildBoxTest, WideRay};
use super::leaf::{each_hit, LeafLanes};
use super::stack::Stack;
use crate::bvh::{WideBvh, WideNode};
use crate::geometry::{intersect_triangle, Ray, RayBoxPrecomp, WatertightRay};
use crate::trace::{Counters, Hit, HitFilter, Opaque};

/// A child waiting on the stack: a node index (`count` 0) or a leaf's first slot and size, and
/// where the ray enters it.
#[derive(Clone, Copy, Default)]
pub(crate) struct Entry {
    pub child: u32,
    pub count: u32,
    pub t_entry: f32,
}

/// The closest hit of the ray. `OCT` is the ray's octant or `ANY_OCTANT` (see
/// [`WideRay::for_octant`]).
#[inline(always)]
pub(crate) fn closest<const N: usize, K: ChildBoxTest<N>, C: Counters, const OCT: usize>(
    bvh: &WideBvh<N>,
    ray: &Ray,
    stats: &mut C,
) -> Option<Hit> {
    closest_filtered::<N, K, C, Opaque, OCT>(bvh, ray, &mut Opaque, stats)
}

/// [`closest`] over the hits `filter` accepts (see [`HitFilter`]; [`Opaque`] is today's).
#[inline(always)]
pub(crate) fn closest_filtered<
    const N: usize,
    K: ChildBoxTest<N>,
    C: Counters,
    F: HitFilter,
    const OCT: usize,
>(
    bvh: &WideBvh<N>,
    ray: &Ray,
    filter: &mut F,
    stats: &mut C,
) -> Option<Hit> {
    if bvh.nodes.is_empty() {
        return None;
    }
    // The root box only when counting (see `any_hit`: the root node's test rejects the same
    // rays).
    if C::COUNTING {
        stats.boxes(1);
        let pre = RayBoxPrecomp::new(ray);
        let r = &bvh.root_bounds;
        pre.hit(r.min, r.max, ray.t_min, ray.t_max + pre.t_margin)?;
    }
    closest_from_filtered::<N, K, C, F, OCT>(bvh, ray, ChildRef::ROOT, None, filter, stats)
}

/// [`closest`] in the subtree of `start` (a node or a leaf), without the root box, given the
/// closest hit found so far (its distance bounds the search): where a packet traversal hands
/// one of its rays over to single-ray traversal.
#[inline(always)]
pub(crate) fn closest_from<const N: usize, K: ChildBoxTest<N>, C: Counters, const OCT: usize>(
    bvh: &WideBvh<N>,
    ray: &Ray,
    start: ChildRef,
    best: Option<Hit>,
    stats: &mut C,
) -> Option<Hit> {
    closest_from_filtered::<N, K, C, Opaque, OCT>(bvh, ray, start, best, &mut Opaque, stats)
}

/// [`closest_from`] over the hits `filter` accepts.
#[inline(always)]
pub(crate) fn closest_from_filtered<
    const N: usize,
    K: ChildBoxTest<N>,
    C: Counters,
    F: HitFilter,
    const OCT: usize,
>(
    bvh: &WideBvh<N>,
    ray: &Ray,
    start: ChildRef,
    mut best: Option<Hit>,
    filter: &mut F,
    stats: &mut C,
) -> Option<Hit> {
    let wray = WideRay::<N>::for_octant::<OCT>(ray);
    let wt = WatertightRay::new(ray);
    let margin = wray.pre.t_margin;
    let t_min = ray.t_min;
    let mut t_max = best.map_or(ray.t_max, |b| b.t);
    let mut stack = Stack::<Entry>::new();
    let mut current = Entry {
        child: start.child,
        count: start.count,
        t_entry: 0.0,
    };
    let mut t_near = [0f32; N];
    loop {
        if current.count > 0 {
            stats.leaf();
            stats.triangles(current.count);
            let (first, count) = (current.child as usize, current.count as usize);
            if F::OPAQUE {
                closest_in_leaf::<N, K>(bvh, &wt, t_min, first, count, &mut t_max, &mut best);
            } else {
                let leaf = (first, count);
                closest_in_leaf_filtered::<N, K, C, F>(
                    bvh, &wt, t_min, leaf, &mut t_max, &mut best, filter, stats,
                );
            }
        } else {
            stats.inner();
            let node = &bvh.nodes[current.child as usize];
            if C::COUNTING {
                stats.boxes(node.arity() as u32);
            }
            let mask = K::test(&wray, node, t_min, t_max + margin, &mut t_near);
            if mask != 0 {
                current = enter_near_first::<N, K>(node, mask, &t_near, &mut stack);
                continue;
            }
        }
        // The next stacked child that can still hold a closer (or equally close) triangle.
        match pop_within(&mut stack, t_max + margin) {
            Some(e) => current = e,
            None => return best,
        }
    }
}

/// The children of `node` in `mask` (at least one; entries in `t_near`) visited near to far:
/// the nearest is returned, the others stacked so the next nearest comes off first (equal
/// entries by the lower slot, as [`near_to_far`]). The descent of every near-first walk.
#[inline(always)]
pub(crate) fn enter_near_first<const N: usize, K: ChildBoxTest<N>>(
    node: &WideNode<N>,
    mask: u32,
    t_near: &[f32; N],
    stack: &mut Stack<Entry>,
) -> Entry {
    let e = |s: u8| Entry {
        child: node.child[s as usize],
        count: node.count[s as usize] as u32,
        t_entry: t_near[s as usize],
    };
    // One or two children hit (most nodes) skip the general ordering loop.
    let (child_a, child_b) = K::lowest_children(node, mask);
    let first = mask.trailing_zeros() as usize;
    let rest = mask & (mask - 1);
    let entry = |s: usize, child: u32| Entry {
        child,
        count: node.count[s] as u32,
        t_entry: t_near[s],
    };
    if rest == 0 {
        return entry(first, child_a);
    }
    if rest & (rest - 1) == 0 {
        // Two children: the nearer first, the lower slot on a tie (as near_to_far).
        let second = rest.trailing_zeros() as usize;
        let (a, b) = (entry(first, child_a), entry(second, child_b));
        let (near, far) = if a.t_entry > b.t_entry {
            (b, a)
        } else {
            (a, b)
        };
        stack.push(far);
        return near;
    }
    let mut visit = [0u8; N];
    let hits = near_to_far(node, mask, t_near, &mut visit);
    for &s in visit[1..hits].iter().rev() {
        stack.push(e(s));
    }
    e(visit[0])
}

/// The next stacked entry that can still hold a hit at or before `reach` (`t_max` plus the box
/// margin); the ones past it are dropped.
#[inline(always)]
pub(crate) fn pop_within(stack: &mut Stack<Entry>, reach: f32) -> Option<Entry> {
    loop {
        match stack.pop() {
            None => return None,
            Some(e) if e.t_entry <= reach => return Some(e),
            Some(_) => {}
        }
    }
}

/// The leaf at slots `first..first + count`: `best` becomes its closest hit in (t_min, t_max]
/// where that is closer than `best` (ties by the smaller triangle id), and `t_max` that hit's
/// distance; the leaf step of single rays and of packet lanes.
#[inline(always)]
pub(crate) fn closest_in_leaf<const N: usize, K: ChildBoxTest<N>>(
    bvh: &WideBvh<N>,
    wt: &WatertightRay,
    t_min: f32,
    first: usize,
    count: usize,
    t_max: &mut f32,
    best: &mut Option<Hit>,
) {
    let range = first..first + count;
    let ids = &bvh.triangle_ids;
    if K::LEAVES != LeafLanes::Scalar {
        let (rows, tris) = (&bvh.triangle_rows, &bvh.triangles[..]);
        each_hit(
            K::LEAVES,
            rows,
            tris,
            wt,
            first,
            count,
            t_min,
            *t_max,
            |slot, t, [b0, b1, b2]| {
                let id = ids[slot];
                // The lane's values are the scalar test's, which does not depend on t_max
                // except to accept: the scalar loop, testing against the t_max left by the
                // triangles before this one, accepts exactly when t <= t_max.
                if t <= *t_max && Hit::closer_than(t, id, best) {
                    *t_max = t;
                    *best = Some(Hit {
                        t,
                        triangle: id,
                        instance: 0,
                        b0,
                        b1,
                        b2,
                    });
                }
                *t_max
            },
        );
    } else {
        for (tri, &id) in bvh.triangles[range.clone()].iter().zip(&ids[range]) {
            if let Some(h) = intersect_triangle(wt, tri, t_min, *t_max) {
                if Hit::closer_than(h.t, id, best) {
                    *t_max = h.t;
                    *best = Some(Hit {
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
    }
}

/// [`closest_in_leaf`] over the hits `filter` accepts, asked only about hits closer than
/// `best`; the scalar test's values in every lane, as there.
#[inline(always)]
#[allow(clippy::too_many_arguments)] // closest_in_leaf's arguments plus the filter's
pub(crate) fn closest_in_leaf_filtered<
    const N: usize,
    K: ChildBoxTest<N>,
    C: Counters,
    F: HitFilter,
>(
    bvh: &WideBvh<N>,
    wt: &WatertightRay,
    t_min: f32,
    (first, count): (usize, usize),
    t_max: &mut f32,
    best: &mut Option<Hit>,
    filter: &mut F,
    stats: &mut C,
) {
    let ids = &bvh.triangle_ids;
    let mut consider = |slot: usize, t: f32, b: [f32; 3], t_max: &mut f32| {
        let id = ids[slot];
        if t <= *t_max && Hit::closer_than(t, id, best) && filter.accepts(id, b, stats) {
            *t_max = t;
            *best = Some(Hit {
                t,
                triangle: id,
                instance: 0,
                b0: b[0],
                b1: b[1],
                b2: b[2],
            });
        }
    };
    if K::LEAVES != LeafLanes::Scalar {
        let (rows, tris) = (&bvh.triangle_rows, &bvh.triangles[..]);
        let mut current = *t_max;
        each_hit(
            K::LEAVES,
            rows,
            tris,
            wt,
            first,
            count,
            t_min,
            current,
            |slot, t, b| {
                consider(slot, t, b, &mut current);
                current
            },
        );
        *t_max = current;
    } else {
        for slot in first..first + count {
            if let Some(h) = intersect_triangle(wt, &bvh.triangles[slot], t_min, *t_max) {
                consider(slot, h.t, [h.b0, h.b1, h.b2], t_max);
            }
        }
    }
}
