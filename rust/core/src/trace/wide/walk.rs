//! Walks of a wide tree whose leaves the caller handles: the top level of two-level scenes,
//! whose leaves hold instances rather than triangles. The near-first walk's descent, stack and
//! culling are the closest-hit traversal's ([`enter_near_first`], [`pop_within`]), so it enters
//! exactly the nodes and leaves the wide closest hit would, in the same order; the ordered walk
//! ([`walk_in_order`]) is the any-hit traversal's descent, its children in a [`ChildOrder`].

use super::any_hit::{ChildRef, WideChildren};
use super::boxes::{BoxKernel, ChildBoxTest, WideRay};
use super::closest::{enter_near_first, pop_within, Entry};
use super::dispatch::{Dispatch, Kernels, Traversal};
use super::stack::Stack;
use crate::bvh::WideBvh;
use crate::geometry::{Ray, RayBoxPrecomp};
use crate::order::{ChildOrder, OrderRay};
use crate::trace::Counters;

/// Walks `tree` near child first with `kernel`, handing each entered leaf's range (`first`,
/// `count`) to `leaf` with the ray's current `t_max`; `leaf` returns the new `t_max` (lowered
/// by a closer hit), or `None` to stop. A child whose entry lies past `t_max` plus the box
/// margin (see `RayBoxPrecomp::t_margin`) is culled when it comes off the stack. Counts as the
/// wide traversals count: the root box, and per node entered one interior node and a box test
/// per used slot, per leaf entered one leaf.
#[inline(always)]
pub(crate) fn walk_near_first<const N: usize, C, L>(
    tree: &WideBvh<N>,
    ray: &Ray,
    kernel: BoxKernel,
    stats: &mut C,
    leaf: L,
) where
    Kernels: Dispatch<N>,
    C: Counters,
    L: FnMut(usize, usize, f32, &mut C) -> Option<f32>,
{
    let walk = Walk {
        tree,
        ray,
        stats,
        leaf,
    };
    Kernels::dispatch(walk, kernel)
}

/// One walk as a [`Traversal`], so the box kernel is chosen as for the wide queries.
struct Walk<'a, const N: usize, C, L> {
    tree: &'a WideBvh<N>,
    ray: &'a Ray,
    stats: &'a mut C,
    leaf: L,
}

impl<const N: usize, C, L> Traversal<N> for Walk<'_, N, C, L>
where
    C: Counters,
    L: FnMut(usize, usize, f32, &mut C) -> Option<f32>,
{
    type Out = ();
    const COUNTING: bool = C::COUNTING;
    // The leaf calls (a whole mesh traversal each) keep no box constants in registers, which
    // is what per-octant instances would save: one instance per kernel is enough.
    const PER_OCTANT: bool = false;
    #[inline(always)]
    fn ray(&self) -> &Ray {
        self.ray
    }
    #[inline(always)]
    fn run<K: ChildBoxTest<N>, const OCT: usize>(self) {
        walk::<N, K, C, L, OCT>(self.tree, self.ray, self.stats, self.leaf)
    }
}

#[inline(always)]
fn walk<const N: usize, K: ChildBoxTest<N>, C: Counters, L, const OCT: usize>(
    tree: &WideBvh<N>,
    ray: &Ray,
    stats: &mut C,
    mut leaf: L,
) where
    L: FnMut(usize, usize, f32, &mut C) -> Option<f32>,
{
    if tree.nodes.is_empty() || misses_counted_root(tree, ray, stats) {
        return;
    }
    let wray = WideRay::<N>::for_octant::<OCT>(ray);
    let margin = wray.pre.t_margin;
    let t_min = ray.t_min;
    let mut t_max = ray.t_max;
    let mut stack = Stack::<Entry>::new();
    // The root node.
    let mut current = Entry {
        child: 0,
        count: 0,
        t_entry: 0.0,
    };
    let mut t_near = [0f32; N];
    loop {
        if current.count > 0 {
            stats.leaf();
            match leaf(current.child as usize, current.count as usize, t_max, stats) {
                Some(t) => t_max = t,
                None => return,
            }
        } else {
            stats.inner();
            let node = &tree.nodes[current.child as usize];
            if C::COUNTING {
                stats.boxes(node.arity() as u32);
            }
            let mask = K::test(&wray, node, t_min, t_max + margin, &mut t_near);
            if mask != 0 {
                current = enter_near_first::<N, K>(node, mask, &t_near, &mut stack);
                continue;
            }
        }
        match pop_within(&mut stack, t_max + margin) {
            Some(e) => current = e,
            None => return,
        }
    }
}

/// Walks `tree` for an any-hit query, entering the children the ray hits in `order` (a static
/// or per-light permutation of the top level), handing each entered leaf's range (`first`,
/// `count`) to `leaf`, which returns true to stop (the ray answered). Nothing is culled on the
/// way back up: an any-hit ray's `t_max` never lowers, so every stacked child still lies within
/// it. Counts as [`walk_near_first`] does.
#[inline(always)]
pub(crate) fn walk_in_order<const N: usize, O, C, L>(
    tree: &WideBvh<N>,
    ray: &Ray,
    kernel: BoxKernel,
    order: &O,
    stats: &mut C,
    leaf: L,
) where
    Kernels: Dispatch<N>,
    O: ChildOrder,
    C: Counters,
    L: FnMut(usize, usize, &mut C) -> bool,
{
    let walk = OrderedWalk {
        tree,
        ray,
        order,
        stats,
        leaf,
    };
    Kernels::dispatch(walk, kernel)
}

/// One ordered walk as a [`Traversal`].
struct OrderedWalk<'a, const N: usize, O, C, L> {
    tree: &'a WideBvh<N>,
    ray: &'a Ray,
    order: &'a O,
    stats: &'a mut C,
    leaf: L,
}

impl<const N: usize, O, C, L> Traversal<N> for OrderedWalk<'_, N, O, C, L>
where
    O: ChildOrder,
    C: Counters,
    L: FnMut(usize, usize, &mut C) -> bool,
{
    type Out = ();
    const COUNTING: bool = C::COUNTING;
    // As the near-first walk: the leaf calls keep no box constants in registers.
    const PER_OCTANT: bool = false;
    #[inline(always)]
    fn ray(&self) -> &Ray {
        self.ray
    }
    #[inline(always)]
    fn run<K: ChildBoxTest<N>, const OCT: usize>(self) {
        ordered_walk::<N, K, O, C, L, OCT>(self.tree, self.ray, self.order, self.stats, self.leaf)
    }
}

#[inline(always)]
fn ordered_walk<const N: usize, K: ChildBoxTest<N>, O, C, L, const OCT: usize>(
    tree: &WideBvh<N>,
    ray: &Ray,
    order: &O,
    stats: &mut C,
    mut leaf: L,
) where
    O: ChildOrder,
    C: Counters,
    L: FnMut(usize, usize, &mut C) -> bool,
{
    if tree.nodes.is_empty() || misses_counted_root(tree, ray, stats) {
        return;
    }
    let wray = WideRay::<N>::for_octant::<OCT>(ray);
    let oray = OrderRay::new::<O>(ray);
    let (t_min, reach) = (ray.t_min, ray.t_max + wray.pre.t_margin);
    let mut stack = Stack::<ChildRef>::new();
    let mut current = ChildRef::ROOT;
    let mut t_near = [0f32; N];
    loop {
        if current.count > 0 {
            stats.leaf();
            if leaf(current.child as usize, current.count as usize, stats) {
                return;
            }
        } else {
            stats.inner();
            let index = current.child as usize;
            let node = &tree.nodes[index];
            if C::COUNTING {
                stats.boxes(node.arity() as u32);
            }
            let mask = K::test(&wray, node, t_min, reach, &mut t_near);
            if mask != 0 {
                let r = |s: usize| ChildRef {
                    child: node.child[s],
                    count: node.count[s] as u32,
                };
                let a = mask.trailing_zeros() as usize;
                let rest = mask & (mask - 1);
                // One child hit (the commonest step): every order enters it, the order unread.
                if rest == 0 {
                    current = r(a);
                    continue;
                }
                let children = WideChildren {
                    t_near: &t_near,
                    node,
                };
                // Two children: one comparison instead of the general ordering loop.
                if rest & (rest - 1) == 0 {
                    let b = rest.trailing_zeros() as usize;
                    let (first, second) = if order.second_first(index, a, b, &oray, &children) {
                        (b, a)
                    } else {
                        (a, b)
                    };
                    stack.push(r(second));
                    current = r(first);
                    continue;
                }
                let mut visit = [0u8; N];
                let hits = order.ordered_hits(index, mask, &oray, &children, &mut visit);
                for &s in visit[1..hits].iter().rev() {
                    stack.push(r(s as usize));
                }
                current = r(visit[0] as usize);
                continue;
            }
        }
        match stack.pop() {
            Some(c) => current = c,
            None => return,
        }
    }
}

/// Whether a counted walk's ray misses the root box, the test counted (see `any_hit`: only
/// counted walks test the root box, whose node's own test rejects the same rays).
#[inline(always)]
fn misses_counted_root<const N: usize, C: Counters>(
    tree: &WideBvh<N>,
    ray: &Ray,
    stats: &mut C,
) -> bool {
    if !C::COUNTING {
        return false;
    }
    stats.boxes(1);
    let pre = RayBoxPrecomp::new(ray);
    let r = &tree.root_bounds;
    pre.hit(r.min, r.max, ray.t_min, ray.t_max + pre.t_margin)
        .is_none()
}
