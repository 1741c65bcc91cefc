//! Traversal of the N-wide BVH: SIMD child-box tests, closest hit near to far, and occlusion
//! with a chosen child order (front to back, or a per-node permutation such as the per-light
//! sorted order). The box kernel is picked at run time (AVX2 where the CPU has it, SSE otherwise,
//! scalar for 2-wide); every kernel gives the same answers and the same counts.

mod any_hit;
mod boxes;
mod child_sort;
mod closest;
pub mod cost;
mod leaf;
mod order;
mod prepared;
mod stack;
pub mod static_orders;

pub use boxes::{BoxKernel, ChildBoxTest, Scalar, WideRay, ANY_OCTANT};
pub use child_sort::{
    sort_for_light, ChildHitModel, LightOrder, LoggingOrder, SortSettings, SortTables,
};
pub use order::{OrderView, Permutation};
pub use prepared::PreparedOrder;

use super::{Counters, Hit};
use crate::bvh::WideBvh;
use crate::geometry::Ray;

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
}

impl WideQueries for WideBvh<2> {
    #[inline]
    fn occluder_leaf<C: Counters>(
        &self,
        ray: &Ray,
        order: OrderView,
        _: BoxKernel,
        stats: &mut C,
    ) -> Option<u32> {
        any_hit::any_hit::<2, Scalar, C, ANY_OCTANT>(self, ray, order, stats)
    }
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, _: BoxKernel, stats: &mut C) -> Option<Hit> {
        closest::closest::<2, Scalar, C, ANY_OCTANT>(self, ray, stats)
    }
}

#[cfg(not(target_arch = "x86_64"))]
impl WideQueries for WideBvh<4> {
    #[inline]
    fn occluder_leaf<C: Counters>(
        &self,
        ray: &Ray,
        order: OrderView,
        _: BoxKernel,
        stats: &mut C,
    ) -> Option<u32> {
        any_hit::any_hit::<4, Scalar, C, ANY_OCTANT>(self, ray, order, stats)
    }
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, _: BoxKernel, stats: &mut C) -> Option<Hit> {
        closest::closest::<4, Scalar, C, ANY_OCTANT>(self, ray, stats)
    }
}

#[cfg(not(target_arch = "x86_64"))]
impl WideQueries for WideBvh<8> {
    #[inline]
    fn occluder_leaf<C: Counters>(
        &self,
        ray: &Ray,
        order: OrderView,
        _: BoxKernel,
        stats: &mut C,
    ) -> Option<u32> {
        any_hit::any_hit::<8, Scalar, C, ANY_OCTANT>(self, ray, order, stats)
    }
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, _: BoxKernel, stats: &mut C) -> Option<Hit> {
        closest::closest::<8, Scalar, C, ANY_OCTANT>(self, ray, stats)
    }
}

#[cfg(target_arch = "x86_64")]
mod x86_dispatch {
    use super::boxes::{Avx2, Avx512, Scalar, Sse};
    use super::*;

    /// True when the AVX2 kernel may run (checked once per call; std caches the CPUID result).
    #[inline(always)]
    fn avx2() -> bool {
        std::arch::is_x86_feature_detected!("avx2")
    }

    /// True when the AVX-512VL kernel may run.
    #[inline(always)]
    fn avx512() -> bool {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
    }

    impl WideQueries for WideBvh<4> {
        #[inline]
        fn occluder_leaf<C: Counters>(
            &self,
            ray: &Ray,
            order: OrderView,
            kernel: BoxKernel,
            stats: &mut C,
        ) -> Option<u32> {
            match kernel {
                BoxKernel::Scalar => {
                    any_hit::any_hit::<4, Scalar, C, ANY_OCTANT>(self, ray, order, stats)
                }
                BoxKernel::Auto | BoxKernel::Sse | BoxKernel::Avx2 => {
                    any_hit::any_hit::<4, Sse, C, ANY_OCTANT>(self, ray, order, stats)
                }
            }
        }
        #[inline]
        fn closest_hit<C: Counters>(
            &self,
            ray: &Ray,
            kernel: BoxKernel,
            stats: &mut C,
        ) -> Option<Hit> {
            match kernel {
                BoxKernel::Scalar => closest::closest::<4, Scalar, C, ANY_OCTANT>(self, ray, stats),
                BoxKernel::Auto | BoxKernel::Sse | BoxKernel::Avx2 => {
                    closest::closest::<4, Sse, C, ANY_OCTANT>(self, ray, stats)
                }
            }
        }
    }

    /// Calls `$f::<C, OCT>` with the ray's octant as `OCT`: the 8-wide AVX2 and AVX-512
    /// traversals are instantiated per octant, so each node's plane rows are loaded at constant
    /// offsets and no slab distance is NaN (see `WideRay::fixed_octant`). Counting traversals
    /// (not timed) and rays with a zero direction component take the `ANY_OCTANT` instance.
    macro_rules! per_octant {
        ($ray:expr, $f:ident::<$c:ident>($($arg:expr),*)) => {
            match WideRay::<8>::fixed_octant($ray) {
                _ if $c::COUNTING => $f::<$c, ANY_OCTANT>($($arg),*),
                Some(0) => $f::<$c, 0>($($arg),*),
                Some(1) => $f::<$c, 1>($($arg),*),
                Some(2) => $f::<$c, 2>($($arg),*),
                Some(3) => $f::<$c, 3>($($arg),*),
                Some(4) => $f::<$c, 4>($($arg),*),
                Some(5) => $f::<$c, 5>($($arg),*),
                Some(6) => $f::<$c, 6>($($arg),*),
                Some(7) => $f::<$c, 7>($($arg),*),
                _ => $f::<$c, ANY_OCTANT>($($arg),*),
            }
        };
    }

    impl WideQueries for WideBvh<8> {
        #[inline]
        fn occluder_leaf<C: Counters>(
            &self,
            ray: &Ray,
            order: OrderView,
            kernel: BoxKernel,
            stats: &mut C,
        ) -> Option<u32> {
            match kernel {
                BoxKernel::Scalar => {
                    any_hit::any_hit::<8, Scalar, C, ANY_OCTANT>(self, ray, order, stats)
                }
                BoxKernel::Auto if avx512() => {
                    // SAFETY: AVX-512F and VL were detected on this CPU just above.
                    unsafe { per_octant!(ray, any_hit_avx512::<C>(self, ray, order, stats)) }
                }
                BoxKernel::Auto | BoxKernel::Avx2 if avx2() => {
                    // SAFETY: AVX2 was detected on this CPU just above.
                    unsafe { per_octant!(ray, any_hit_avx2::<C>(self, ray, order, stats)) }
                }
                _ => any_hit::any_hit::<8, Sse, C, ANY_OCTANT>(self, ray, order, stats),
            }
        }
        #[inline]
        fn closest_hit<C: Counters>(
            &self,
            ray: &Ray,
            kernel: BoxKernel,
            stats: &mut C,
        ) -> Option<Hit> {
            match kernel {
                BoxKernel::Scalar => closest::closest::<8, Scalar, C, ANY_OCTANT>(self, ray, stats),
                BoxKernel::Auto if avx512() => {
                    // SAFETY: AVX-512F and VL were detected on this CPU just above.
                    unsafe { per_octant!(ray, closest_avx512::<C>(self, ray, stats)) }
                }
                BoxKernel::Auto | BoxKernel::Avx2 if avx2() => {
                    // SAFETY: AVX2 was detected on this CPU just above.
                    unsafe { per_octant!(ray, closest_avx2::<C>(self, ray, stats)) }
                }
                _ => closest::closest::<8, Sse, C, ANY_OCTANT>(self, ray, stats),
            }
        }
    }

    /// The whole traversal compiled with AVX2, so the kernel's intrinsics inline into it.
    #[target_feature(enable = "avx2")]
    unsafe fn any_hit_avx2<C: Counters, const OCT: usize>(
        bvh: &WideBvh<8>,
        ray: &Ray,
        order: OrderView,
        stats: &mut C,
    ) -> Option<u32> {
        any_hit::any_hit::<8, Avx2, C, OCT>(bvh, ray, order, stats)
    }

    #[target_feature(enable = "avx2")]
    unsafe fn closest_avx2<C: Counters, const OCT: usize>(
        bvh: &WideBvh<8>,
        ray: &Ray,
        stats: &mut C,
    ) -> Option<Hit> {
        closest::closest::<8, Avx2, C, OCT>(bvh, ray, stats)
    }

    /// The whole traversal compiled with AVX-512VL (32 vector registers, mask compares).
    #[target_feature(enable = "avx512f,avx512vl")]
    unsafe fn any_hit_avx512<C: Counters, const OCT: usize>(
        bvh: &WideBvh<8>,
        ray: &Ray,
        order: OrderView,
        stats: &mut C,
    ) -> Option<u32> {
        any_hit::any_hit::<8, Avx512, C, OCT>(bvh, ray, order, stats)
    }

    #[target_feature(enable = "avx512f,avx512vl")]
    unsafe fn closest_avx512<C: Counters, const OCT: usize>(
        bvh: &WideBvh<8>,
        ray: &Ray,
        stats: &mut C,
    ) -> Option<Hit> {
        closest::closest::<8, Avx512, C, OCT>(bvh, ray, stats)
    }
}
