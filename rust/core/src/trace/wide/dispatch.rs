//! From the run-time [`BoxKernel`] to a traversal instance: per width, the box kernels it has
//! and, on x86_64, the instruction set each is compiled with (8-wide AVX2 and AVX-512 traversals
//! also per ray octant). Both traversals go through the same table.

#[cfg(target_arch = "x86_64")]
use super::boxes::{Avx2, Avx512, Sse, WideRay};
use super::boxes::{BoxKernel, ChildBoxTest, Scalar, ANY_OCTANT};
use super::packet::{self, Packet};
#[cfg(target_arch = "x86_64")]
use super::packet_boxes::{Avx2Packet, Avx512Packet};
use super::packet_boxes::{PacketBoxTest, ScalarPacket};
use super::{any_hit, closest};
use crate::bvh::WideBvh;
use crate::geometry::Ray;
use crate::order::OrderView;
use crate::trace::{Counters, Hit, HitFilter};

/// One query on one tree, run with a box kernel and a ray octant chosen by [`Dispatch`].
pub(crate) trait Traversal<const N: usize> {
    type Out;
    /// False when the counters compile away.
    const COUNTING: bool;
    /// Whether the 8-wide SIMD kernels run an instance per ray octant: by default when the
    /// counters compile away (counting traversals are not timed).
    const PER_OCTANT: bool = !Self::COUNTING;
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

/// [`AnyHit`] with a rule for hits (see [`HitFilter`]).
pub(crate) struct AnyHitFiltered<'a, const N: usize, C, F> {
    pub bvh: &'a WideBvh<N>,
    pub ray: &'a Ray,
    pub order: OrderView<'a>,
    pub filter: &'a mut F,
    pub stats: &'a mut C,
}

impl<const N: usize, C: Counters, F: HitFilter> Traversal<N> for AnyHitFiltered<'_, N, C, F> {
    type Out = Option<u32>;
    const COUNTING: bool = C::COUNTING;
    #[inline(always)]
    fn ray(&self) -> &Ray {
        self.ray
    }
    #[inline(always)]
    fn run<K: ChildBoxTest<N>, const OCT: usize>(self) -> Option<u32> {
        any_hit::any_hit_filtered::<N, K, OrderView, C, F, OCT>(
            self.bvh,
            self.ray,
            &self.order,
            self.filter,
            self.stats,
        )
    }
}

/// [`Closest`] over the hits a [`HitFilter`] accepts.
pub(crate) struct ClosestFiltered<'a, const N: usize, C, F> {
    pub bvh: &'a WideBvh<N>,
    pub ray: &'a Ray,
    pub filter: &'a mut F,
    pub stats: &'a mut C,
}

impl<const N: usize, C: Counters, F: HitFilter> Traversal<N> for ClosestFiltered<'_, N, C, F> {
    type Out = Option<Hit>;
    const COUNTING: bool = C::COUNTING;
    #[inline(always)]
    fn ray(&self) -> &Ray {
        self.ray
    }
    #[inline(always)]
    fn run<K: ChildBoxTest<N>, const OCT: usize>(self) -> Option<Hit> {
        closest::closest_filtered::<N, K, C, F, OCT>(self.bvh, self.ray, self.filter, self.stats)
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
/// offsets and no slab distance is NaN (see `WideRay::fixed_octant`). Traversals without
/// [`Traversal::PER_OCTANT`] and rays with a zero direction component take the `ANY_OCTANT`
/// instance.
#[cfg(target_arch = "x86_64")]
macro_rules! per_octant {
    ($f:ident::<$ty:ident>($t:expr)) => {{
        let t = $t;
        match WideRay::<8>::fixed_octant(t.ray()) {
            _ if !$ty::PER_OCTANT => $f::<$ty, ANY_OCTANT>(t),
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

/// One packet query on one tree, run with a single-ray kernel `K` (for the lanes that go on
/// alone and the leaf tests), a packet box test `P` and an octant, chosen by
/// [`PacketDispatch`].
pub(crate) trait PacketTraversal<const N: usize> {
    /// False when the counters compile away.
    const COUNTING: bool;
    /// Whether the 8-wide SIMD kernels run an instance per packet octant: by default when the
    /// counters compile away (counting traversals are not timed).
    const PER_OCTANT: bool = !Self::COUNTING;
    /// The packet's octant when every ray in it has that fixed octant.
    fn fixed_octant(&self) -> Option<usize>;
    fn run<K: ChildBoxTest<N>, P: PacketBoxTest, const OCT: usize>(self);
}

pub(crate) struct AnyHitPacket<'a, const N: usize, C> {
    pub bvh: &'a WideBvh<N>,
    pub packet: &'a Packet<'a>,
    pub order: &'a OrderView<'a>,
    pub out: &'a mut [bool],
    pub counters: &'a mut [C],
}

impl<const N: usize, C: Counters> PacketTraversal<N> for AnyHitPacket<'_, N, C> {
    const COUNTING: bool = C::COUNTING;
    #[inline(always)]
    fn fixed_octant(&self) -> Option<usize> {
        self.packet.no_nan.then_some(self.packet.octant)
    }
    #[inline(always)]
    fn run<K: ChildBoxTest<N>, P: PacketBoxTest, const OCT: usize>(self) {
        packet::occluded_packet::<N, K, P, OrderView, C, OCT>(
            self.bvh,
            self.packet,
            self.order,
            self.out,
            self.counters,
        )
    }
}

pub(crate) struct ClosestPacket<'a, const N: usize, C> {
    pub bvh: &'a WideBvh<N>,
    pub packet: &'a Packet<'a>,
    pub out: &'a mut [Option<Hit>],
    pub counters: &'a mut [C],
}

impl<const N: usize, C: Counters> PacketTraversal<N> for ClosestPacket<'_, N, C> {
    const COUNTING: bool = C::COUNTING;
    #[inline(always)]
    fn fixed_octant(&self) -> Option<usize> {
        self.packet.no_nan.then_some(self.packet.octant)
    }
    #[inline(always)]
    fn run<K: ChildBoxTest<N>, P: PacketBoxTest, const OCT: usize>(self) {
        packet::closest_packet::<N, K, P, C, OCT>(self.bvh, self.packet, self.out, self.counters)
    }
}

/// The packet kernels of width N.
pub(crate) trait PacketDispatch<const N: usize> {
    fn dispatch_packet<T: PacketTraversal<N>>(t: T, kernel: BoxKernel);
}

#[cfg(not(target_arch = "x86_64"))]
impl<const N: usize> PacketDispatch<N> for Kernels {
    #[inline(always)]
    fn dispatch_packet<T: PacketTraversal<N>>(t: T, _: BoxKernel) {
        t.run::<Scalar, ScalarPacket, ANY_OCTANT>()
    }
}

/// The packet dispatch of one width on x86_64: `$single512`, `$single2` and `$sse` are the
/// single-ray kernels that go with the AVX-512, AVX2 and SSE packet paths; `$octants`
/// (`per_octant` or `any_octant`) says whether this width's traversals are instantiated per
/// octant, as the single-ray dispatch's are.
#[cfg(target_arch = "x86_64")]
macro_rules! packet_dispatch {
    ($n:literal, $octants:ident, $single512:ty, $single2:ty, $sse:ty) => {
        impl PacketDispatch<$n> for Kernels {
            #[inline(always)]
            fn dispatch_packet<T: PacketTraversal<$n>>(t: T, kernel: BoxKernel) {
                /// The whole packet traversal compiled with AVX-512.
                #[target_feature(enable = "avx512f,avx512vl")]
                unsafe fn with_avx512<T: PacketTraversal<$n>, const OCT: usize>(t: T) {
                    t.run::<$single512, Avx512Packet, OCT>()
                }
                /// The whole packet traversal compiled with AVX2.
                #[target_feature(enable = "avx2")]
                unsafe fn with_avx2<T: PacketTraversal<$n>, const OCT: usize>(t: T) {
                    t.run::<$single2, Avx2Packet, OCT>()
                }
                match kernel {
                    BoxKernel::Scalar => t.run::<Scalar, ScalarPacket, ANY_OCTANT>(),
                    // SAFETY: AVX-512F and VL were detected on this CPU just above.
                    BoxKernel::Auto if avx512() => unsafe {
                        packet_per_octant!($octants, with_avx512::<T>(t))
                    },
                    // SAFETY: AVX2 was detected on this CPU just above.
                    BoxKernel::Auto | BoxKernel::Avx2 if avx2() => unsafe {
                        packet_per_octant!($octants, with_avx2::<T>(t))
                    },
                    _ => t.run::<$sse, ScalarPacket, ANY_OCTANT>(),
                }
            }
        }
    };
}

/// Calls `$f::<T, OCT>($t)` with the packet's fixed octant as `OCT` (`per_octant`, as
/// `per_octant!`; traversals without `PER_OCTANT` take `ANY_OCTANT`), or always with
/// `ANY_OCTANT`.
#[cfg(target_arch = "x86_64")]
macro_rules! packet_per_octant {
    (per_octant, $f:ident::<$ty:ident>($t:expr)) => {{
        let t = $t;
        match t.fixed_octant() {
            _ if !$ty::PER_OCTANT => $f::<$ty, ANY_OCTANT>(t),
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
    (any_octant, $f:ident::<$ty:ident>($t:expr)) => {
        $f::<$ty, ANY_OCTANT>($t)
    };
}

#[cfg(target_arch = "x86_64")]
packet_dispatch!(2, any_octant, Scalar, Scalar, Scalar);
#[cfg(target_arch = "x86_64")]
packet_dispatch!(4, any_octant, Sse, Sse, Sse);
#[cfg(target_arch = "x86_64")]
packet_dispatch!(8, per_octant, Avx512, Avx2, Sse);
