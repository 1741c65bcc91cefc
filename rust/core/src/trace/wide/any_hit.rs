//! Occlusion (any hit) on a wide BVH with a chosen child order.

use super::boxes::{ChildBoxTest, WideRay};
use super::leaf::{first_hit, LeafLanes};
use super::order::{OrderView, Permutation};
use super::stack::Stack;
use crate::bvh::WideBvh;
use crate::geometry::{intersect_triangle, Ray, WatertightRay};
use crate::trace::Counters;

/// A child reference on the stack: interior node index or first triangle, and the triangle
/// count (0 for interior nodes).
#[derive(Clone, Copy, Default)]
struct ChildRef {
    child: u32,
    count: u32,
}

/// Traces an occlusion ray. Returns the first triangle slot of the leaf that occluded the ray
/// (the logging pass of per-light sorting attributes the ray to that leaf), or `None`. `OCT` is
/// the ray's octant or `ANY_OCTANT` (see [`WideRay::for_octant`]).
#[inline(always)]
pub(crate) fn any_hit<const N: usize, K: ChildBoxTest<N>, C: Counters, const OCT: usize>(
    bvh: &WideBvh<N>,
    ray: &Ray,
    order: OrderView,
    stats: &mut C,
) -> Option<u32> {
    if bvh.nodes.is_empty() {
        return None;
    }
    let wray = WideRay::<N>::for_octant::<OCT>(ray);
    // The triangle test's set-up is built at the first leaf, so its values are not live across
    // the node loop (fewer registers spilled there), and a ray that reaches no leaf skips it.
    let mut wt_slot: Option<WatertightRay> = None;
    let t_min = ray.t_min;
    // Box tests reach a margin past the segment's end; triangle tests do not (see t_margin).
    let t_max = ray.t_max + wray.pre.t_margin;
    // The root box: counted as the binary traversal counts it, but only tested when counting.
    // A ray that misses it misses every child box (each lies inside it, and the slab test is
    // monotone in the planes under rounding), so the timed path lets the root node's test
    // reject it instead and skips one box test per ray.
    if C::COUNTING {
        stats.boxes(1);
        let r = &bvh.root_bounds;
        wray.pre.hit(r.min, r.max, t_min, t_max)?;
    }
    let mut stack = Stack::<ChildRef>::new();
    let mut current = ChildRef { child: 0, count: 0 };
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
                // One child hit: every order visits it next, so in this common case the order
                // (the light's permutation) is not read at all.
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
                let (first, second) = if second_goes_first(index, a, b, &t_near, order) {
                    (ref_b, ref_a)
                } else {
                    (ref_a, ref_b)
                };
                stack.push(second);
                current = first;
                continue;
            }
            let mut visit = [0u8; N];
            let hits = ordered_hits(index, mask, &t_near, order, &mut visit);
            for &s in visit[1..hits].iter().rev() {
                stack.push(r(s));
            }
            current = r(visit[0]);
        }
        stats.leaf();
        let wt = &*wt_slot.get_or_insert_with(|| WatertightRay::new(ray));
        let first = current.child as usize;
        let count = current.count as usize;
        if K::LEAVES == LeafLanes::Scalar {
            for slot in first..first + count {
                stats.triangles(1);
                if intersect_triangle(wt, &bvh.triangles[slot], t_min, ray.t_max).is_some() {
                    return Some(current.child);
                }
            }
        } else {
            let (rows, tris) = (&bvh.triangle_rows, &bvh.triangles[..]);
            match first_hit(K::LEAVES, rows, tris, wt, first, count, t_min, ray.t_max) {
                Some(tested) => {
                    stats.triangles(tested);
                    return Some(current.child);
                }
                None => stats.triangles(count as u32),
            }
        }
        current = stack.pop()?;
    }
}

/// Whether slot `b` is visited before slot `a` (`a < b`, both hit): the order
/// [`ordered_hits`] gives two hit slots.
#[inline(always)]
fn second_goes_first<const N: usize>(
    node: usize,
    a: u8,
    b: u8,
    t_near: &[f32; N],
    order: OrderView,
) -> bool {
    match node_order(node, order) {
        NodeOrder::Permuted(p) => p.rank(b as usize) < p.rank(a as usize),
        NodeOrder::Slots => false,
        // Ties by slot: insertion moves `b` ahead only when strictly nearer.
        NodeOrder::FrontToBack => t_near[a as usize] > t_near[b as usize],
    }
}

/// How one node orders the children a ray hits.
enum NodeOrder {
    Permuted(Permutation),
    Slots,
    FrontToBack,
}

#[inline(always)]
fn node_order(node: usize, order: OrderView) -> NodeOrder {
    match order {
        OrderView::Stored => NodeOrder::Slots,
        OrderView::FrontToBack => NodeOrder::FrontToBack,
        OrderView::Permuted {
            perms,
            fallback_fbto,
        } => {
            let p = perms[node];
            if p.is_present() {
                NodeOrder::Permuted(p)
            } else if fallback_fbto {
                NodeOrder::FrontToBack
            } else {
                NodeOrder::Slots
            }
        }
    }
}

/// Writes the slots of `mask` in visiting order to `out`; returns how many.
#[inline(always)]
fn ordered_hits<const N: usize>(
    node: usize,
    mask: u32,
    t_near: &[f32; N],
    order: OrderView,
    out: &mut [u8; N],
) -> usize {
    let fbto = match node_order(node, order) {
        NodeOrder::Slots => false,
        NodeOrder::FrontToBack => true,
        NodeOrder::Permuted(p) => {
            // Place each hit slot at its rank, then read the ranks in order: work in the
            // number of children hit, not in N.
            let mut by_rank = [0u8; 8];
            let mut ranks = 0u32;
            let mut m = mask;
            while m != 0 {
                let s = m.trailing_zeros() as usize;
                m &= m - 1;
                let r = p.rank(s);
                // Permutations list every used slot, and only used slots are hit.
                debug_assert!(ranks & (1 << r) == 0, "slot {s} not in the permutation");
                by_rank[r] = s as u8;
                ranks |= 1 << r;
            }
            let mut n = 0;
            while ranks != 0 {
                out[n] = by_rank[ranks.trailing_zeros() as usize];
                ranks &= ranks - 1;
                n += 1;
            }
            return n;
        }
    };
    let mut n = 0;
    let mut m = mask;
    while m != 0 {
        let s = m.trailing_zeros() as usize;
        m &= m - 1;
        // Insertion by entry distance; equal distances keep slot order.
        let mut k = n;
        if fbto {
            while k > 0 && t_near[out[k - 1] as usize] > t_near[s] {
                out[k] = out[k - 1];
                k -= 1;
            }
        }
        out[k] = s as u8;
        n += 1;
    }
    n
}

/// Slots of `mask` ordered near to far (ties by slot), for the closest-hit traversal.
#[inline(always)]
pub(crate) fn near_to_far<const N: usize>(
    mask: u32,
    t_near: &[f32; N],
    out: &mut [u8; N],
) -> usize {
    ordered_hits(0, mask, t_near, OrderView::FrontToBack, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::wide::Permutation;

    /// A node with fewer children than N visits each hit child once, in the permutation's
    /// order (unused positions once decoded as slot 0 and queued it a second time).
    #[test]
    fn permuted_order_lists_each_hit_child_once() {
        let perms = [Permutation::from_slots(&[2, 0, 1])];
        let order = OrderView::Permuted {
            perms: &perms,
            fallback_fbto: false,
        };
        let mut out = [0u8; 8];
        let n = ordered_hits(0, 0b111, &[0.0; 8], order, &mut out);
        assert_eq!(&out[..n], &[2, 0, 1]);
        let n = ordered_hits(0, 0b011, &[0.0; 8], order, &mut out);
        assert_eq!(&out[..n], &[0, 1]);
    }

    /// The two-hit shortcut orders every pair of slots as the general loops do, in every
    /// order view (with and without a permutation, ties and strict distances).
    #[test]
    fn two_hit_shortcut_equals_the_general_order() {
        let perms = [
            Permutation::from_slots(&[5, 2, 7, 0, 3, 1, 6, 4]),
            Permutation::NONE,
        ];
        let t_near = [3.0, 1.0, 1.0, 7.0, 0.5, 3.0, 2.0, 0.5];
        let views = [
            OrderView::Stored,
            OrderView::FrontToBack,
            OrderView::Permuted {
                perms: &perms,
                fallback_fbto: false,
            },
            OrderView::Permuted {
                perms: &perms,
                fallback_fbto: true,
            },
        ];
        for view in views {
            for node in 0..2 {
                for a in 0..8u8 {
                    for b in a + 1..8 {
                        let mut out = [0u8; 8];
                        let n = ordered_hits(node, 1 << a | 1 << b, &t_near, view, &mut out);
                        assert_eq!(n, 2);
                        let swapped = second_goes_first(node, a, b, &t_near, view);
                        let expect = if swapped { [b, a] } else { [a, b] };
                        assert_eq!(out[..2], expect, "{view:?} node {node} slots {a} {b}");
                    }
                }
            }
        }
    }
}
