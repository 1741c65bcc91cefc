//! Traversal of the N-wide BVH: SIMD child-box tests, closest hit near to far, and occlusion
//! generic over the child order (see [`crate::order`]). The box kernel is picked at run time
//! (AVX-512VL or AVX2 where the CPU has it, SSE otherwise, scalar for 2-wide); every kernel
//! gives the same answers and the same counts.

mod any_hit;
mod boxes;
mod closest;
mod dispatch;
mod leaf;
mod packet;
mod packet_boxes;
mod stack;
mod walk;

pub(crate) use any_hit::in_order;
pub use boxes::{BoxKernel, ChildBoxTest, Scalar, WideRay, ANY_OCTANT};
pub(crate) use dispatch::{Kernels, PacketDispatch, PacketTraversal};
pub(crate) use packet::lanes;
#[cfg(test)]
pub(crate) use packet_boxes::ScalarPacket;
pub use packet_boxes::LANES as PACKET_LANES;
#[cfg(all(test, target_arch = "x86_64"))]
pub(crate) use packet_boxes::{Avx2Packet, Avx512Packet};
pub(crate) use packet_boxes::{PacketBoxTest, PacketRays};
pub(crate) use walk::{walk_in_order, walk_near_first};

use super::{Counters, Hit, HitFilter, NoStats};
use crate::bvh::WideBvh;
use crate::geometry::Ray;
use crate::order::{OrderView, PreparedOrder, ShadowOrder, SortTables};
use dispatch::{
    AnyHit, AnyHitFiltered, AnyHitPacket, Closest, ClosestFiltered, ClosestPacket, Dispatch,
};

/// The queries of a wide BVH of one width, dispatched to a box kernel.
pub trait WideQueries {
    /// True if any triangle intersects the ray in (t_min, t_max].
    fn occluded<C: Counters>(
        &self,
        ray: &Ray,
        order: OrderView,
        kernel: BoxKernel,
        stats: &mut C,
    ) -> bool {
        self.occluder_leaf(ray, order, kernel, stats).is_some()
    }
    /// The first triangle slot of the leaf that occluded the ray, if any.
    fn occluder_leaf<C: Counters>(
        &self,
        ray: &Ray,
        order: OrderView,
        kernel: BoxKernel,
        stats: &mut C,
    ) -> Option<u32>;
    /// The closest hit, ties broken by the smaller triangle id.
    fn closest_hit<C: Counters>(&self, ray: &Ray, kernel: BoxKernel, stats: &mut C) -> Option<Hit>;

    /// [`WideQueries::occluder_leaf`] with a rule for hits: the first slot of the leaf where
    /// `filter` stopped the ray (single rays: see `docs/alpha.md`).
    fn occluder_leaf_filtered<C: Counters, F: HitFilter>(
        &self,
        ray: &Ray,
        order: OrderView,
        kernel: BoxKernel,
        filter: &mut F,
        stats: &mut C,
    ) -> Option<u32>;

    /// [`WideQueries::closest_hit`] over the hits `filter` accepts.
    fn closest_hit_filtered<C: Counters, F: HitFilter>(
        &self,
        ray: &Ray,
        kernel: BoxKernel,
        filter: &mut F,
        stats: &mut C,
    ) -> Option<Hit>;

    /// [`WideQueries::occluded`] of every ray, traced in packets of neighbouring rays.
    fn occluded_packets<C: Counters>(
        &self,
        rays: &[Ray],
        order: OrderView,
        kernel: BoxKernel,
        out: &mut [bool],
        counters: &mut [C],
    );

    /// [`WideQueries::closest_hit`] of every ray, traced in packets of neighbouring rays.
    fn closest_hit_packets<C: Counters>(
        &self,
        rays: &[Ray],
        kernel: BoxKernel,
        out: &mut [Option<Hit>],
        counters: &mut [C],
    );
}

/// One implementation for every width: the traversal is generic over the width, and
/// [`Dispatch`] maps the run-time [`BoxKernel`] to the box kernels each width has.
impl<const N: usize> WideQueries for WideBvh<N>
where
    Kernels: Dispatch<N> + PacketDispatch<N>,
{
    fn occluded_packets<C: Counters>(
        &self,
        rays: &[Ray],
        order: OrderView,
        kernel: BoxKernel,
        out: &mut [bool],
        counters: &mut [C],
    ) {
        assert!(out.len() == rays.len() && counters.len() == rays.len());
        out.fill(false);
        packet::each_packet(rays, |packet| {
            let call = AnyHitPacket {
                bvh: self,
                packet,
                order: &order,
                out: &mut *out,
                counters: &mut *counters,
            };
            Kernels::dispatch_packet(call, kernel)
        });
    }

    fn closest_hit_packets<C: Counters>(
        &self,
        rays: &[Ray],
        kernel: BoxKernel,
        out: &mut [Option<Hit>],
        counters: &mut [C],
    ) {
        assert!(out.len() == rays.len() && counters.len() == rays.len());
        out.fill(None);
        packet::each_packet(rays, |packet| {
            let call = ClosestPacket {
                bvh: self,
                packet,
                out: &mut *out,
                counters: &mut *counters,
            };
            Kernels::dispatch_packet(call, kernel)
        });
    }

    #[inline]
    fn occluder_leaf<C: Counters>(
        &self,
        ray: &Ray,
        order: OrderView,
        kernel: BoxKernel,
        stats: &mut C,
    ) -> Option<u32> {
        let call = AnyHit {
            bvh: self,
            ray,
            order,
            stats,
        };
        Kernels::dispatch(call, kernel)
    }
    #[inline]
    fn occluder_leaf_filtered<C: Counters, F: HitFilter>(
        &self,
        ray: &Ray,
        order: OrderView,
        kernel: BoxKernel,
        filter: &mut F,
        stats: &mut C,
    ) -> Option<u32> {
        let call = AnyHitFiltered {
            bvh: self,
            ray,
            order,
            filter,
            stats,
        };
        Kernels::dispatch(call, kernel)
    }
    #[inline]
    fn closest_hit_filtered<C: Counters, F: HitFilter>(
        &self,
        ray: &Ray,
        kernel: BoxKernel,
        filter: &mut F,
        stats: &mut C,
    ) -> Option<Hit> {
        let call = ClosestFiltered {
            bvh: self,
            ray,
            filter,
            stats,
        };
        Kernels::dispatch(call, kernel)
    }
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, kernel: BoxKernel, stats: &mut C) -> Option<Hit> {
        Kernels::dispatch(
            Closest {
                bvh: self,
                ray,
                stats,
            },
            kernel,
        )
    }
}

impl PreparedOrder {
    /// Prepares `order` on `bvh`, the sorted order's logging pass traced with `kernel` (see
    /// [`PreparedOrder::with_occluder`]).
    pub fn new<const N: usize>(
        bvh: &WideBvh<N>,
        order: &ShadowOrder,
        tables: Option<&SortTables>,
        representative: &[Ray],
        kernel: BoxKernel,
    ) -> Self
    where
        WideBvh<N>: WideQueries,
    {
        PreparedOrder::with_occluder(bvh, order, tables, representative, |ray, view| {
            bvh.occluder_leaf(ray, view, kernel, &mut NoStats)
        })
    }
}
