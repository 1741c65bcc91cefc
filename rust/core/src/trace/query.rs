//! The two queries a pass needs, as traits, so the passes run on any tree: the binary BVH, a
//! wide BVH of any width, with any child order.

use super::wide::{BoxKernel, WideQueries};
use super::{closest_hit, occluded, Counters, Hit};
use crate::bvh::{Bvh, WideBvh};
use crate::geometry::Ray;
use crate::order::{AnyHitOrder, OrderView};

/// Closest hit, ties broken by the smaller triangle id.
pub trait ClosestHitQuery: Sync {
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit>;
}

/// Occlusion with an order fixed by the implementor.
pub trait OcclusionQuery: Sync {
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool;
}

impl ClosestHitQuery for Bvh {
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        closest_hit(self, ray, stats)
    }
}

impl<const N: usize> ClosestHitQuery for WideBvh<N>
where
    WideBvh<N>: WideQueries,
{
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        WideQueries::closest_hit(self, ray, BoxKernel::Auto, stats)
    }
}

/// The binary BVH with one of its two orders.
#[derive(Clone, Copy)]
pub struct BinaryOcclusion<'a> {
    pub bvh: &'a Bvh,
    pub order: AnyHitOrder,
}

impl OcclusionQuery for BinaryOcclusion<'_> {
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        occluded(self.bvh, ray, self.order, stats)
    }
}

/// A wide BVH with a prepared child order and a box kernel.
#[derive(Clone, Copy)]
pub struct WideOcclusion<'a, const N: usize> {
    pub bvh: &'a WideBvh<N>,
    pub order: OrderView<'a>,
    pub kernel: BoxKernel,
}

impl<const N: usize> OcclusionQuery for WideOcclusion<'_, N>
where
    WideBvh<N>: WideQueries,
{
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        WideQueries::occluded(self.bvh, ray, self.order, self.kernel, stats)
    }
}
