//! [`AlphaQuery`]: the face the passes trace alpha scenes through, beside [`super::RayQuery`]:
//! a shadow ray's transmission (Cycles' transparent shadows) and a camera ray's closest hit
//! past transparent hits. Implemented by the binary and wide trees and their ordered forms;
//! single rays only (a batch is a loop; packets are not used with alpha).

use super::wide::{BoxKernel, WideQueries};
use super::{
    closest_hit_filtered, occluding_leaf_filtered, AlphaClip, AlphaScenes, Counters, Hit,
    HitFilter, OrderedBinary, OrderedWide, Transmission,
};
use crate::bvh::{Bvh, WideBvh};
use crate::geometry::Ray;
use crate::order::{AnyHitOrder, FrontToBack, OrderView, Stored};

/// Implements [`AlphaQuery`] for a type that holds one of several queries, as
/// [`super::forward_ray_query`] does for [`super::RayQuery`]: `$with!(self, q => ...)` picks.
macro_rules! forward_alpha_query {
    ($ty:ty, $with:ident) => {
        impl $crate::trace::AlphaQuery for $ty {
            #[inline]
            fn stopped<C: $crate::trace::Counters, F: $crate::trace::HitFilter>(
                &self,
                ray: &$crate::geometry::Ray,
                filter: &mut F,
                stats: &mut C,
            ) -> bool {
                $with!(self, q => q.stopped(ray, filter, stats))
            }
            #[inline]
            fn closest_hit_filtered<C: $crate::trace::Counters, F: $crate::trace::HitFilter>(
                &self,
                ray: &$crate::geometry::Ray,
                filter: &mut F,
                stats: &mut C,
            ) -> Option<$crate::trace::Hit> {
                $with!(self, q => q.closest_hit_filtered(ray, filter, stats))
            }
        }
    };
}
pub(crate) use forward_alpha_query;

/// Implements [`AlphaQuery`] for one tree from its two searches under a filter, written as
/// expressions of `|tree, ray, filter, stats|`: `stopped`, the leaf that stopped the ray (an
/// `Option`), and `closest`, the closest hit the filter accepts. Generics go in `impl[...]`,
/// bounds in `where [...]`, doc comments before `impl`.
macro_rules! alpha_query_for {
    (
        $(#[$attr:meta])*
        impl[$($gen:tt)*] $ty:ty $(where [$($bound:tt)*])?,
        |$tree:ident, $ray:ident, $filter:ident, $stats:ident|
        stopped: $stopped:expr,
        closest: $closest:expr $(,)?
    ) => {
        $(#[$attr])*
        impl<$($gen)*> $crate::trace::AlphaQuery for $ty $(where $($bound)*)? {
            #[inline]
            fn stopped<C: $crate::trace::Counters, F: $crate::trace::HitFilter>(
                &self,
                $ray: &$crate::geometry::Ray,
                $filter: &mut F,
                $stats: &mut C,
            ) -> bool {
                let $tree = self;
                $stopped.is_some()
            }
            #[inline]
            fn closest_hit_filtered<C: $crate::trace::Counters, F: $crate::trace::HitFilter>(
                &self,
                $ray: &$crate::geometry::Ray,
                $filter: &mut F,
                $stats: &mut C,
            ) -> Option<$crate::trace::Hit> {
                let $tree = self;
                $closest
            }
        }
    };
}
pub(crate) use alpha_query_for;

/// Queries with a rule for hits ([`HitFilter`]), and the two alpha queries built on them.
pub trait AlphaQuery: Sync {
    /// Any hit under `filter`: true when the filter stopped the ray.
    fn stopped<C: Counters, F: HitFilter>(&self, ray: &Ray, filter: &mut F, stats: &mut C) -> bool;

    /// The closest hit in (t_min, t_max] that `filter` accepts, ties by the smaller triangle id.
    fn closest_hit_filtered<C: Counters, F: HitFilter>(
        &self,
        ray: &Ray,
        filter: &mut F,
        stats: &mut C,
    ) -> Option<Hit>;

    /// The fraction of light the segment (t_min, t_max] lets through, in [0, 1]: 0 when an
    /// opaque triangle (unflagged, or alpha 1) is hit or more than `max_hits` distinct
    /// transparent triangles are; otherwise the product of (1 - alpha) over the distinct
    /// transparent hits in (t, triangle) order (see [`Transmission`]).
    #[inline]
    fn transmission<C: Counters, S: AlphaScenes + ?Sized>(
        &self,
        ray: &Ray,
        alpha: &S,
        max_hits: u32,
        stats: &mut C,
    ) -> f32 {
        let mut filter = Transmission::new(alpha, max_hits);
        if self.stopped(ray, &mut filter, stats) {
            0.0
        } else {
            filter.value()
        }
    }

    /// `out[i] = transmission(&rays[i])`, counted into `counters[i]`; one hit list reused.
    fn transmission_batch<C: Counters, S: AlphaScenes + ?Sized>(
        &self,
        rays: &[Ray],
        alpha: &S,
        max_hits: u32,
        out: &mut [f32],
        counters: &mut [C],
    ) {
        assert!(out.len() == rays.len() && counters.len() == rays.len());
        let mut filter = Transmission::new(alpha, max_hits);
        for ((ray, o), c) in rays.iter().zip(out).zip(counters) {
            filter.hits.clear();
            *o = if self.stopped(ray, &mut filter, c) {
                0.0
            } else {
                filter.value()
            };
        }
    }

    /// The closest hit that is not transparent: an unflagged triangle, or a flagged one whose
    /// alpha is at least `clip` (see [`AlphaClip`]).
    #[inline]
    fn closest_hit_alpha<C: Counters, S: AlphaScenes + ?Sized>(
        &self,
        ray: &Ray,
        alpha: &S,
        clip: f32,
        stats: &mut C,
    ) -> Option<Hit> {
        self.closest_hit_filtered(ray, &mut AlphaClip::new(alpha, clip), stats)
    }
}

alpha_query_for!(
    /// The binary tree alone: front to back, as its [`super::RayQuery`].
    impl[] Bvh,
    |tree, ray, filter, stats|
    stopped: occluding_leaf_filtered(tree, &FrontToBack, ray, filter, stats),
    closest: closest_hit_filtered(tree, ray, filter, stats),
);

alpha_query_for!(
    impl[] OrderedBinary<'_>,
    |tree, ray, filter, stats|
    stopped: match tree.order {
        AnyHitOrder::Stored => occluding_leaf_filtered(tree.bvh, &Stored, ray, filter, stats),
        AnyHitOrder::NearFirst => {
            occluding_leaf_filtered(tree.bvh, &FrontToBack, ray, filter, stats)
        }
    },
    closest: closest_hit_filtered(tree.bvh, ray, filter, stats),
);

alpha_query_for!(
    /// A wide tree alone: front to back, the box kernel chosen at run time.
    impl[const N: usize] WideBvh<N> where [WideBvh<N>: WideQueries],
    |tree, ray, filter, stats|
    stopped: tree.occluder_leaf_filtered(
        ray,
        OrderView::FrontToBack,
        BoxKernel::Auto,
        filter,
        stats,
    ),
    closest: WideQueries::closest_hit_filtered(tree, ray, BoxKernel::Auto, filter, stats),
);

alpha_query_for!(
    /// A wide tree with its order and kernel; single rays whatever its `rays` mode.
    impl[const N: usize] OrderedWide<'_, N> where [WideBvh<N>: WideQueries],
    |tree, ray, filter, stats|
    stopped: tree
        .bvh
        .occluder_leaf_filtered(ray, tree.order, tree.kernel, filter, stats),
    closest: WideQueries::closest_hit_filtered(tree.bvh, ray, tree.kernel, filter, stats),
);
