//! Occlusion (any hit) on a wide BVH, generic over the child order.

use glam::Vec3;

use super::boxes::{ChildBoxTest, WideRay};
use super::leaf::{first_hit, hits_until, LeafLanes};
use super::stack::Stack;
use crate::bvh::{WideBvh, WideNode};
use crate::geometry::{intersect_triangle, Ray, RayBoxPrecomp, WatertightRay};
use crate::order::{ChildOrder, Children, FrontToBack, OrderRay};
use crate::trace::{Counters, HitFilter, Opaque};

/// The children of a wide node as an order reads them.
pub(crate) struct WideChildren<'a, const N: usize> {
    pub t_near: &'a [f32; N],
    pub node: &'a WideNode<N>,
}

impl<const N: usize> Children for WideChildren<'_, N> {
    #[inline(always)]
    fn t_near(&self, slot: usize) -> f32 {
        self.t_near[slot]
    }
    #[inline(always)]
    fn centre(&self, slot: usize) -> Vec3 {
        let b = self.node.child_bounds(slot);
        (b.min + b.max) * 0.5
    }
}

/// A child reference on the stack: interior node index or first triangle, and the triangle
/// count (0 for interior nodes).
#[derive(Clone, Copy, Default)]
pub(crate) struct ChildRef {
    pub child: u32,
    pub count: u32,
}

impl ChildRef {
    /// The root node.
    pub const ROOT: ChildRef = ChildRef { child: 0, count: 0 };
}

/// Traces an occlusion ray. Returns the first triangle slot of the leaf that occluded the ray
/// (the logging pass of per-light sorting attributes the ray to that leaf), or `None`. `OCT` is
/// the ray's octant or `ANY_OCTANT` (see [`WideRay::for_octant`]).
#[inline(always)]
pub(crate) fn any_hit<
    const N: usize,
    K: ChildBoxTest<N>,
    O: ChildOrder,
    C: Counters,
    const OCT: usize,
>(
    bvh: &WideBvh<N>,
    ray: &Ray,
    order: &O,
    stats: &mut C,
) -> Option<u32> {
    any_hit_filtered::<N, K, O, C, Opaque, OCT>(bvh, ray, order, &mut Opaque, stats)
}

/// [`any_hit`] with a rule for hits (see [`HitFilter`]; [`Opaque`] is today's traversal).
#[inline(always)]
pub(crate) fn any_hit_filtered<
    const N: usize,
    K: ChildBoxTest<N>,
    O: ChildOrder,
    C: Counters,
    F: HitFilter,
    const OCT: usize,
>(
    bvh: &WideBvh<N>,
    ray: &Ray,
    order: &O,
    filter: &mut F,
    stats: &mut C,
) -> Option<u32> {
    if bvh.nodes.is_empty() {
        return None;
    }
    // The root box: counted as the binary traversal counts it, but only tested when counting.
    // A ray that misses it misses every child box (each lies inside it, and the slab test is
    // monotone in the planes under rounding), so the timed path lets the root node's test
    // reject it instead.
    if C::COUNTING {
        stats.boxes(1);
        let pre = RayBoxPrecomp::new(ray);
        let r = &bvh.root_bounds;
        pre.hit(r.min, r.max, ray.t_min, ray.t_max + pre.t_margin)?;
    }
    any_hit_from_filtered::<N, K, O, C, F, OCT>(bvh, ray, ChildRef::ROOT, order, filter, stats)
}

/// [`any_hit`] in the subtree of `start` (a node or a leaf), without the root box: where a
/// packet traversal hands one of its rays over to single-ray traversal.
#[inline(always)]
pub(crate) fn any_hit_from<
    const N: usize,
    K: ChildBoxTest<N>,
    O: ChildOrder,
    C: Counters,
    const OCT: usize,
>(
    bvh: &WideBvh<N>,
    ray: &Ray,
    start: ChildRef,
    order: &O,
    stats: &mut C,
) -> Option<u32> {
    any_hit_from_filtered::<N, K, O, C, Opaque, OCT>(bvh, ray, start, order, &mut Opaque, stats)
}

/// [`any_hit_from`] with a rule for hits.
#[inline(always)]
pub(crate) fn any_hit_from_filtered<
    const N: usize,
    K: ChildBoxTest<N>,
    O: ChildOrder,
    C: Counters,
    F: HitFilter,
    const OCT: usize,
>(
    bvh: &WideBvh<N>,
    ray: &Ray,
    start: ChildRef,
    order: &O,
    filter: &mut F,
    stats: &mut C,
) -> Option<u32> {
    let wray = WideRay::<N>::for_octant::<OCT>(ray);
    let oray = OrderRay::new::<O>(ray);
    // The triangle test's set-up is built at the first leaf: many shadow rays reach none, and
    // its values are then not live across the node loop.
    let mut wt_slot: Option<WatertightRay> = None;
    let t_min = ray.t_min;
    // Box tests reach a margin past the segment's end; triangle tests do not (see t_margin).
    let t_max = ray.t_max + wray.pre.t_margin;
    let mut stack = Stack::<ChildRef>::new();
    let mut current = start;
    let mut t_near = [0f32; N];
    loop {
        // Descend through interior nodes until a leaf: a tight loop of its own, so the box
        // test's per-ray constants can stay in registers across nodes.
        while current.count == 0 {
            stats.inner();
            let index = current.child as usize;
            let node = &bvh.nodes[index];
            if C::COUNTING {
                stats.boxes(node.arity() as u32);
            }
            let mask = K::test(&wray, node, t_min, t_max, &mut t_near);
            if mask == 0 {
                current = stack.pop()?;
                continue;
            }
            let r = |s: u8| ChildRef {
                child: node.child[s as usize],
                count: node.count[s as usize] as u32,
            };
            let (child_a, child_b) = K::lowest_children(node, mask);
            let a = mask.trailing_zeros() as u8;
            let rest = mask & (mask - 1);
            if rest == 0 {
                // One child hit: every order visits it next, so the order is not read (fewer
                // instructions and mispredicted branches on the commonest node step).
                current = ChildRef {
                    child: child_a,
                    count: node.count[a as usize] as u32,
                };
                continue;
            }
            if rest & (rest - 1) == 0 {
                // Two children hit: one comparison instead of the general ordering loops.
                let b = rest.trailing_zeros() as u8;
                let ref_a = ChildRef {
                    child: child_a,
                    count: node.count[a as usize] as u32,
                };
                let ref_b = ChildRef {
                    child: child_b,
                    count: node.count[b as usize] as u32,
                };
                let children = WideChildren {
                    t_near: &t_near,
                    node,
                };
                let (first, second) =
                    if order.second_first(index, a as usize, b as usize, &oray, &children) {
                        (ref_b, ref_a)
                    } else {
                        (ref_a, ref_b)
                    };
                stack.push(second);
                current = first;
                continue;
            }
            let mut visit = [0u8; N];
            let children = WideChildren {
                t_near: &t_near,
                node,
            };
            let hits = order.ordered_hits(index, mask, &oray, &children, &mut visit);
            for &s in visit[1..hits].iter().rev() {
                stack.push(r(s));
            }
            current = r(visit[0]);
        }
        stats.leaf();
        let wt = &*wt_slot.get_or_insert_with(|| WatertightRay::new(ray));
        let (first, count) = (current.child as usize, current.count as usize);
        let stopped = if F::OPAQUE {
            leaf_occludes::<N, K, C>(bvh, wt, ray, first, count, stats)
        } else {
            leaf_stops::<N, K, C, F>(bvh, wt, ray, first, count, filter, stats)
        };
        if stopped {
            return Some(current.child);
        }
        current = stack.pop()?;
    }
}

/// Whether a triangle of the leaf at slots `first..first + count` hits the ray in
/// (t_min, t_max], its triangles counted as the scalar loop tests them (up to the first hit):
/// the leaf step of single rays and of packet lanes.
#[inline(always)]
pub(crate) fn leaf_occludes<const N: usize, K: ChildBoxTest<N>, C: Counters>(
    bvh: &WideBvh<N>,
    wt: &WatertightRay,
    ray: &Ray,
    first: usize,
    count: usize,
    stats: &mut C,
) -> bool {
    let (t_min, t_max) = (ray.t_min, ray.t_max);
    if K::LEAVES == LeafLanes::Scalar {
        for tri in &bvh.triangles[first..first + count] {
            stats.triangles(1);
            if intersect_triangle(wt, tri, t_min, t_max).is_some() {
                return true;
            }
        }
        false
    } else {
        let (rows, tris) = (&bvh.triangle_rows, &bvh.triangles[..]);
        match first_hit(K::LEAVES, rows, tris, wt, first, count, t_min, t_max) {
            Some(tested) => {
                stats.triangles(tested);
                true
            }
            None => {
                stats.triangles(count as u32);
                false
            }
        }
    }
}

/// [`leaf_occludes`] with a filter: every hit of the leaf, in slot order with its triangle id
/// and barycentrics, until the filter stops the ray; triangles counted as the scalar loop
/// tests them.
#[inline(always)]
pub(crate) fn leaf_stops<const N: usize, K: ChildBoxTest<N>, C: Counters, F: HitFilter>(
    bvh: &WideBvh<N>,
    wt: &WatertightRay,
    ray: &Ray,
    first: usize,
    count: usize,
    filter: &mut F,
    stats: &mut C,
) -> bool {
    let (t_min, t_max) = (ray.t_min, ray.t_max);
    let ids = &bvh.triangle_ids;
    if K::LEAVES == LeafLanes::Scalar {
        let range = first..first + count;
        for (tri, &id) in bvh.triangles[range.clone()].iter().zip(&ids[range]) {
            stats.triangles(1);
            if let Some(h) = intersect_triangle(wt, tri, t_min, t_max) {
                if filter.stops(id, h.t, [h.b0, h.b1, h.b2], stats) {
                    return true;
                }
            }
        }
        false
    } else {
        let (rows, tris) = (&bvh.triangle_rows, &bvh.triangles[..]);
        // The filter counts its lookups into a counter of its own, added after the leaf
        // (the closure cannot borrow `stats` while the count below needs it).
        let mut lookups = C::default();
        let (tested, stopped) = hits_until(
            K::LEAVES,
            rows,
            tris,
            wt,
            first,
            count,
            t_min,
            t_max,
            |slot, t, b| filter.stops(ids[slot], t, b, &mut lookups),
        );
        stats.triangles(tested);
        *stats += lookups;
        stopped
    }
}

/// Slots of `mask` of node `index` in `order`: a walk whose leaves are the caller's (the top
/// level's runs) orders a node's children as the any-hit traversal does.
#[inline(always)]
pub(crate) fn in_order<const N: usize, O: ChildOrder>(
    order: &O,
    index: usize,
    node: &WideNode<N>,
    mask: u32,
    t_near: &[f32; N],
    out: &mut [u8; N],
) -> usize {
    let ray = OrderRay {
        origin: Vec3::ZERO,
        key: 0,
    };
    debug_assert!(!O::NEEDS_KEY, "a run orders its children without a ray key");
    order.ordered_hits(index, mask, &ray, &WideChildren { t_near, node }, out)
}

/// Slots of `mask` ordered near to far (ties by slot), for the closest-hit traversal.
#[inline(always)]
pub(crate) fn near_to_far<const N: usize>(
    node: &WideNode<N>,
    mask: u32,
    t_near: &[f32; N],
    out: &mut [u8; N],
) -> usize {
    let ray = OrderRay {
        origin: Vec3::ZERO,
        key: 0,
    };
    FrontToBack.ordered_hits(0, mask, &ray, &WideChildren { t_near, node }, out)
}
