//! From the run-time [`BoxKernel`] to a traversal instance: per width, the box kernels it has
//! and, on x86_64, the instruction set each is compiled with (8-wide AVX2 and AVX-512 traversals
//! also per ray octant). Both traversals go through the same table.

#[cfg(target_arch = "x86_64")]
use super::boxes::{Avx2, Avx512, Sse, WideRay};
use super::boxes::{BoxKernel, ChildBoxTest, Scalar, ANY_OCTANT};
use super::{any_hit, closest};
use crate::bvh::WideBvh;
use crate::geometry::Ray;
use crate::order::OrderView;
use crate::trace::{Counters, Hit};

/// One query on one tree, run with a box kernel and a ray octant chosen by [`Dispatch`].
pub(crate) trait Traversal<const N: usize> {
    type Out;
    /// False when the counters compile away (only then are per-octant instances used).
    const COUNTING: bool;
    fn ray(&self) -> &Ray;
    fn run<K: ChildBoxTest<N>, const OCT: usize>(self) -> Self::Out;
}

pub(crate) struct AnyHit<'a, const N: usize, C> {
    pub bvh: &'a WideBvh<N>,
    pub ray: &'a Ray,
    pub order: OrderView<'a>,
    pub stats: &'a mut C,
}

impl<const N: usize, C: Counters> Traversal<N> for AnyHit<'_, N, C> {
    type Out = Option<u32>;
    const COUNTING: bool = C::COUNTING;
    #[inline(always)]
    fn ray(&self) -> &Ray {
        self.ray
    }
    #[inline(always)]
    fn run<K: ChildBoxTest<N>, const OCT: usize>(self) -> Option<u32> {
        any_hit::any_hit::<N, K, OrderView, C, OCT>(self.bvh, self.ray, &self.order, self.stats)
    }
}

pub(crate) struct Closest<'a, const N: usize, C> {
    pub bvh: &'a WideBvh<N>,
    pub ray: &'a Ray,
    pub stats: &'a mut C,
}

impl<const N: usize, C: Counters> Traversal<N> for Closest<'_, N, C> {
    type Out = Option<Hit>;
    const COUNTING: bool = C::COUNTING;
    #[inline(always)]
    fn ray(&self) -> &Ray {
        self.ray
    }
    #[inline(always)]
    fn run<K: ChildBoxTest<N>, const OCT: usize>(self) -> Option<Hit> {
        closest::closest::<N, K, C, OCT>(self.bvh, self.ray, self.stats)
    }
}

/// The box kernels of width N.
pub(crate) trait Dispatch<const N: usize> {
    fn dispatch<T: Traversal<N>>(t: T, kernel: BoxKernel) -> T::Out;
}

/// The table of kernels per width (a type so that one generic `WideQueries` impl covers all).
pub struct Kernels;

impl Dispatch<2> for Kernels {
    #[inline(always)]
    fn dispatch<T: Traversal<2>>(t: T, _: BoxKernel) -> T::Out {
        t.run::<Scalar, ANY_OCTANT>()
    }
}

#[cfg(not(target_arch = "x86_64"))]
impl Dispatch<4> for Kernels {
    #[inline(always)]
    fn dispatch<T: Traversal<4>>(t: T, _: BoxKernel) -> T::Out {
        t.run::<Scalar, ANY_OCTANT>()
    }
}

#[cfg(not(target_arch = "x86_64"))]
impl Dispatch<8> for Kernels {
    #[inline(always)]
    fn dispatch<T: Traversal<8>>(t: T, _: BoxKernel) -> T::Out {
        t.run::<Scalar, ANY_OCTANT>()
    }
}

#[cfg(target_arch = "x86_64")]
impl Dispatch<4> for Kernels {
    #[inline(always)]
    fn dispatch<T: Traversal<4>>(t: T, kernel: BoxKernel) -> T::Out {
        match kernel {
            BoxKernel::Scalar => t.run::<Scalar, ANY_OCTANT>(),
            BoxKernel::Auto | BoxKernel::Sse | BoxKernel::Avx2 => t.run::<Sse, ANY_OCTANT>(),
        }
    }
}

/// True when the AVX2 kernel may run (checked once per call; std caches the CPUID result).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

/// True when the AVX-512VL kernel may run.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn avx512() -> bool {
    std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512vl")
}

/// Calls `$f::<T, OCT>($t)` with the ray's octant as `OCT`: the 8-wide AVX2 and AVX-512
/// traversals are instantiated per octant, so each node's plane rows are loaded at constant
/// offsets and no slab distance is NaN (see `WideRay::fixed_octant`). Counting traversals
/// (not timed) and rays with a zero direction component take the `ANY_OCTANT` instance.
#[cfg(target_arch = "x86_64")]
macro_rules! per_octant {
    ($f:ident::<$ty:ident>($t:expr)) => {{
        let t = $t;
        match WideRay::<8>::fixed_octant(t.ray()) {
            _ if $ty::COUNTING => $f::<$ty, ANY_OCTANT>(t),
            Some(0) => $f::<$ty, 0>(t),
            Some(1) => $f::<$ty, 1>(t),
            Some(2) => $f::<$ty, 2>(t),
            Some(3) => $f::<$ty, 3>(t),
            Some(4) => $f::<$ty, 4>(t),
            Some(5) => $f::<$ty, 5>(t),
            Some(6) => $f::<$ty, 6>(t),
            Some(7) => $f::<$ty, 7>(t),
            _ => $f::<$ty, ANY_OCTANT>(t),
        }
    }};
}

#[cfg(target_arch = "x86_64")]
impl Dispatch<8> for Kernels {
    #[inline(always)]
    fn dispatch<T: Traversal<8>>(t: T, kernel: BoxKernel) -> T::Out {
        match kernel {
            BoxKernel::Scalar => t.run::<Scalar, ANY_OCTANT>(),
            // SAFETY: AVX-512F and VL were detected on this CPU just above.
            BoxKernel::Auto if avx512() => unsafe { per_octant!(with_avx512::<T>(t)) },
            // SAFETY: AVX2 was detected on this CPU just above.
            BoxKernel::Auto | BoxKernel::Avx2 if avx2() => unsafe {
                per_octant!(with_avx2::<T>(t))
            },
            _ => t.run::<Sse, ANY_OCTANT>(),
        }
    }
}

/// The whole traversal compiled with AVX2, so the kernel's intrinsics inline into it.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn with_avx2<T: Traversal<8>, const OCT: usize>(t: T) -> T::Out {
    t.run::<Avx2, OCT>()
}

/// The whole traversal compiled with AVX-512VL (32 vector registers, mask compares).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl")]
unsafe fn with_avx512<T: Traversal<8>, const OCT: usize>(t: T) -> T::Out {
    t.run::<Avx512, OCT>()
}
