//! [`RayQuery`]: the one face every tree layout answers rays through (binary, wide of any width,
//! a light's SRDH tree, and what a pass traces), for one ray and for a batch. A new kernel
//! (packets) or a new tree (a top level over instances) is one more implementation of it.

use super::any_hit::{occluded, occluding_leaf};
use super::closest::closest_hit;
use super::wide::{BoxKernel, WideQueries};
use super::{Counters, Hit};
use crate::bvh::{Bvh, WideBvh};
use crate::geometry::Ray;
use crate::order::{AnyHitOrder, ChildOrder, OrderView};

/// Implements [`RayQuery`] for a type that holds one of several queries by handing every call,
/// single ray or batch, to the query `$with!(self, q => ...)` picks: the choice is made once per
/// call, so a batch pays it once. `$with` is a macro of the implementing module.
macro_rules! forward_ray_query {
    ($ty:ty, $with:ident) => {
        impl $crate::trace::RayQuery for $ty {
            #[inline]
            fn occluded<C: $crate::trace::Counters>(
                &self,
                ray: &$crate::geometry::Ray,
                stats: &mut C,
            ) -> bool {
                $with!(self, q => q.occluded(ray, stats))
            }
            #[inline]
            fn closest_hit<C: $crate::trace::Counters>(
                &self,
                ray: &$crate::geometry::Ray,
                stats: &mut C,
            ) -> Option<$crate::trace::Hit> {
                $with!(self, q => q.closest_hit(ray, stats))
            }
            #[inline]
            fn occluded_batch<C: $crate::trace::Counters>(
                &self,
                rays: &[$crate::geometry::Ray],
                out: &mut [bool],
                counters: &mut [C],
            ) {
                $with!(self, q => q.occluded_batch(rays, out, counters))
            }
            #[inline]
            fn closest_hit_batch<C: $crate::trace::Counters>(
                &self,
                rays: &[$crate::geometry::Ray],
                out: &mut [Option<$crate::trace::Hit>],
                counters: &mut [C],
            ) {
                $with!(self, q => q.closest_hit_batch(rays, out, counters))
            }
        }
    };
}
pub(crate) use forward_ray_query;

/// Any hit and closest hit, for one ray or a batch. The any-hit order is the implementor's
/// (a tree alone goes front to back); a closest hit ignores it and breaks ties by the smaller
/// triangle id, so every implementation gives the same answers.
///
/// The batch forms take one counter per ray (`counters.len() == rays.len()`): a slice rather
/// than a callback, so a packet kernel may count its lanes in any order and the passes read each
/// pixel's rays back from contiguous slots; a slice of [`super::NoStats`] is zero-sized.
pub trait RayQuery: Sync {
    /// True if any triangle intersects the ray in (t_min, t_max].
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool;

    /// The closest hit in (t_min, t_max], ties broken by the smaller triangle id.
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit>;

    /// `out[i] = occluded(&rays[i])`, counted into `counters[i]`.
    #[inline]
    fn occluded_batch<C: Counters>(&self, rays: &[Ray], out: &mut [bool], counters: &mut [C]) {
        occluded_each(self, rays, out, counters);
    }

    /// `out[i] = closest_hit(&rays[i])`, counted into `counters[i]`.
    #[inline]
    fn closest_hit_batch<C: Counters>(
        &self,
        rays: &[Ray],
        out: &mut [Option<Hit>],
        counters: &mut [C],
    ) {
        closest_hit_each(self, rays, out, counters);
    }
}

/// A batch's any hits one ray at a time: the default batch, and what an implementation
/// with a packet mode does in single mode.
#[inline]
pub(crate) fn occluded_each<Q: RayQuery + ?Sized, C: Counters>(
    q: &Q,
    rays: &[Ray],
    out: &mut [bool],
    counters: &mut [C],
) {
    debug_assert!(out.len() == rays.len() && counters.len() == rays.len());
    for ((ray, o), c) in rays.iter().zip(out).zip(counters) {
        *o = q.occluded(ray, c);
    }
}

/// A batch's closest hits one ray at a time, as [`occluded_each`].
#[inline]
pub(crate) fn closest_hit_each<Q: RayQuery + ?Sized, C: Counters>(
    q: &Q,
    rays: &[Ray],
    out: &mut [Option<Hit>],
    counters: &mut [C],
) {
    debug_assert!(out.len() == rays.len() && counters.len() == rays.len());
    for ((ray, o), c) in rays.iter().zip(out).zip(counters) {
        *o = q.closest_hit(ray, c);
    }
}

/// The binary tree alone: any hit front to back.
impl RayQuery for Bvh {
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        occluded(self, ray, AnyHitOrder::NearFirst, stats)
    }
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        closest_hit(self, ray, stats)
    }
}

/// A wide tree alone: any hit front to back, the box kernel chosen at run time.
impl<const N: usize> RayQuery for WideBvh<N>
where
    WideBvh<N>: WideQueries,
{
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        WideQueries::occluded(self, ray, OrderView::FrontToBack, BoxKernel::Auto, stats)
    }
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        WideQueries::closest_hit(self, ray, BoxKernel::Auto, stats)
    }
}

/// The binary tree with one of its two any-hit orders.
#[derive(Clone, Copy)]
pub struct OrderedBinary<'a> {
    pub bvh: &'a Bvh,
    pub order: AnyHitOrder,
}

impl RayQuery for OrderedBinary<'_> {
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        occluded(self.bvh, ray, self.order, stats)
    }
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        closest_hit(self.bvh, ray, stats)
    }
}

/// The binary tree with any child order type: the research orders (a light's SRDH kernels
/// over another tree, RTSAH, random, one kernel everywhere) that [`AnyHitOrder`] does not name.
#[derive(Clone, Copy)]
pub struct BinaryInOrder<'a, O> {
    pub bvh: &'a Bvh,
    pub order: &'a O,
}

impl<O: ChildOrder + Sync> RayQuery for BinaryInOrder<'_, O> {
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        occluding_leaf(self.bvh, self.order, ray, stats).is_some()
    }
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        closest_hit(self.bvh, ray, stats)
    }
}

/// How a batch of rays is traced: one ray at a time, or in packets of neighbouring rays (SIMD
/// across rays). Both give the same answers; packets pay off where neighbouring rays are
/// coherent (a tile's camera rays, its shadow rays toward one light).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum RayMode {
    #[default]
    Single,
    Packet,
}

impl RayMode {
    pub const ALL: [RayMode; 2] = [RayMode::Single, RayMode::Packet];

    pub fn name(self) -> &'static str {
        match self {
            RayMode::Single => "single",
            RayMode::Packet => "packet",
        }
    }
}

impl std::fmt::Display for RayMode {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for RayMode {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<Self> {
        RayMode::ALL
            .into_iter()
            .find(|m| m.name() == s.trim())
            .ok_or_else(|| {
                crate::Error::invalid("rays", format!("must be single, packet or auto, got '{s}'"))
            })
    }
}

/// A wide tree with a prepared any-hit order, a box kernel, and single rays or packets for
/// batches.
#[derive(Clone, Copy)]
pub struct OrderedWide<'a, const N: usize> {
    pub bvh: &'a WideBvh<N>,
    pub order: OrderView<'a>,
    pub kernel: BoxKernel,
    pub rays: RayMode,
}

impl<const N: usize> RayQuery for OrderedWide<'_, N>
where
    WideBvh<N>: WideQueries,
{
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        WideQueries::occluded(self.bvh, ray, self.order, self.kernel, stats)
    }
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        WideQueries::closest_hit(self.bvh, ray, self.kernel, stats)
    }
    #[inline]
    fn occluded_batch<C: Counters>(&self, rays: &[Ray], out: &mut [bool], counters: &mut [C]) {
        match self.rays {
            RayMode::Single => occluded_each(self, rays, out, counters),
            RayMode::Packet => {
                self.bvh
                    .occluded_packets(rays, self.order, self.kernel, out, counters)
            }
        }
    }
    #[inline]
    fn closest_hit_batch<C: Counters>(
        &self,
        rays: &[Ray],
        out: &mut [Option<Hit>],
        counters: &mut [C],
    ) {
        match self.rays {
            RayMode::Single => closest_hit_each(self, rays, out, counters),
            RayMode::Packet => self
                .bvh
                .closest_hit_packets(rays, self.kernel, out, counters),
        }
    }
}
