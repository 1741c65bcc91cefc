//! The one child-order trait the any-hit traversals are generic over (as Embree's intersector
//! policy or tinybvh's template flags): each order is a type, monomorphised into the traversal.

use glam::Vec3;

use crate::geometry::Ray;
use crate::sampling::{hash_combine, hash_u32};

/// What an order may read of the children of one node: per slot, the entry distance of the
/// child's box (when the traversal tested it at the parent) and the centre of that box.
pub trait Children {
    fn t_near(&self, slot: usize) -> f32;
    fn centre(&self, slot: usize) -> Vec3;
}

/// What an order may read of the ray: its origin and, for orders with `NEEDS_KEY`, a hash of it.
#[derive(Clone, Copy, Debug)]
pub struct OrderRay {
    pub origin: Vec3,
    pub key: u32,
}

impl OrderRay {
    #[inline(always)]
    pub fn new<O: ChildOrder + ?Sized>(ray: &Ray) -> Self {
        OrderRay {
            origin: ray.origin,
            key: if O::NEEDS_KEY { ray_key(ray) } else { 0 },
        }
    }
}

/// A key that identifies a ray for orders that draw per ray (its bits hashed).
pub fn ray_key(ray: &Ray) -> u32 {
    let mut h = hash_u32(ray.t_max.to_bits());
    for v in [ray.origin, ray.direction] {
        for c in v.to_array() {
            h = hash_combine(h, c.to_bits());
        }
    }
    h
}

/// The order in which an any-hit traversal visits the children of a node that its ray enters.
/// The answer never depends on it; only the work does.
pub trait ChildOrder: Sync {
    /// True for orders that read no entry distance (the SRDH kernels): the binary traversal then
    /// tests a child's box only on entering it, so a ray stopped in the first child never tests
    /// the second's box.
    const TEST_ON_ENTRY: bool = false;
    /// Whether [`ChildOrder::second_first`] reads [`OrderRay::key`] (only then is it computed).
    const NEEDS_KEY: bool = false;

    /// Of the children in slots `a < b` of node `node`, both to be visited: whether `b` goes
    /// first. Ties keep slot order.
    fn second_first<K: Children>(
        &self,
        node: usize,
        a: usize,
        b: usize,
        ray: &OrderRay,
        children: &K,
    ) -> bool;

    /// Writes the slots of `mask` in visiting order to `out`; returns how many. By default an
    /// insertion by [`ChildOrder::second_first`]; the permutation orders place slots by rank.
    #[inline(always)]
    fn ordered_hits<const N: usize, K: Children>(
        &self,
        node: usize,
        mask: u32,
        ray: &OrderRay,
        children: &K,
        out: &mut [u8; N],
    ) -> usize {
        let mut n = 0;
        let mut m = mask;
        while m != 0 {
            let s = m.trailing_zeros() as usize;
            m &= m - 1;
            let mut k = n;
            while k > 0 && self.second_first(node, out[k - 1] as usize, s, ray, children) {
                out[k] = out[k - 1];
                k -= 1;
            }
            out[k] = s as u8;
            n += 1;
        }
        n
    }
}

/// Children in the order the builder (and the collapse) stored them.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stored;

impl ChildOrder for Stored {
    #[inline(always)]
    fn second_first<K: Children>(&self, _: usize, _: usize, _: usize, _: &OrderRay, _: &K) -> bool {
        false
    }
    #[inline(always)]
    fn ordered_hits<const N: usize, K: Children>(
        &self,
        _: usize,
        mask: u32,
        _: &OrderRay,
        _: &K,
        out: &mut [u8; N],
    ) -> usize {
        let mut n = 0;
        let mut m = mask;
        while m != 0 {
            out[n] = m.trailing_zeros() as u8;
            m &= m - 1;
            n += 1;
        }
        n
    }
}

/// Front to back by box entry distance (FBTO); equal distances keep slot order.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrontToBack;

impl ChildOrder for FrontToBack {
    #[inline(always)]
    fn second_first<K: Children>(
        &self,
        _: usize,
        a: usize,
        b: usize,
        _: &OrderRay,
        children: &K,
    ) -> bool {
        children.t_near(a) > children.t_near(b)
    }
}
