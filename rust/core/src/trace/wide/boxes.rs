//! Testing all N child boxes of a wide node against one ray: a scalar kernel that calls the
//! reference slab test once per child, and SIMD kernels (SSE 4 lanes, AVX2 and AVX-512VL 8
//! lanes) that give the same answers bit for bit.
//!
//! The SIMD kernels do the reference's arithmetic in the reference's order, per lane:
//! `(plane - origin) * inv_dir` per axis (`inv_dir_far`, the reciprocal scaled by `FAR_SCALE`,
//! for far planes), NaN replaced by `t_min` (near) or `t_max` (far) with the operand order of
//! `minps`/`maxps` (which return the second operand when either is NaN). The hit rule
//! `t_near <= t_far` and the returned entry distance are the reference's, which keeps
//! `t_margin`'s exact-tie guarantee.

use glam::Vec3;

use super::leaf::LeafLanes;
use crate::bvh::{WideNode, EMPTY_CHILD};
use crate::geometry::{Ray, RayBoxPrecomp};

/// Which box-test implementation a traversal uses. All give identical answers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BoxKernel {
    /// The best SIMD the CPU has (8 lanes: AVX-512VL, else AVX2, else SSE; 4 lanes: SSE;
    /// scalar for 2).
    #[default]
    Auto,
    /// One reference slab test per child.
    Scalar,
    /// SSE only, even where AVX2 exists (8 lanes as two halves).
    Sse,
    /// AVX2 for 8 lanes even where AVX-512 exists (SSE where AVX2 does not).
    Avx2,
}

/// The octant parameter of [`WideRay::for_octant`] for "read it from the ray".
pub const ANY_OCTANT: usize = 8;

/// Per-ray values of the wide box test.
#[derive(Clone, Copy, Debug)]
pub struct WideRay<const N: usize> {
    pub pre: RayBoxPrecomp,
    /// Per axis: the byte offset in a node's `bounds` of the row holding the near plane (the
    /// min row, or the max row for a direction component with its sign bit set) and of the
    /// row holding the far plane. Fixed by the ray's octant, so a node test loads each plane
    /// row at `bounds + offset` without choosing rows per node.
    pub near: [usize; 3],
    pub far: [usize; 3],
    pub origin: [f32; 3],
    pub inv_dir: [f32; 3],
    pub inv_dir_far: [f32; 3],
    /// No slab distance can be NaN: set for rays traced with a fixed octant, which
    /// [`WideRay::fixed_octant`] only gives rays whose reciprocals are all finite and non-zero.
    /// The SIMD kernels then combine the axes in a shallower min/max tree (one dependent
    /// operation less per node on the traversal's critical path).
    pub no_nan: bool,
}

/// Smallest direction component magnitude of a ray traced with a fixed octant: its reciprocal
/// (at most 1e37) and the far reciprocal (times `1 + 2 gamma(3)`) stay finite.
const MIN_FIXED_OCTANT_COMPONENT: f32 = 1e-37;

impl<const N: usize> WideRay<N> {
    /// Bytes of one bounds row.
    const ROW: usize = std::mem::size_of::<[f32; N]>();

    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        Self::for_octant::<ANY_OCTANT>(ray)
    }

    /// The ray's octant: bit a set when direction component a has its sign bit set (-0.0
    /// included, as the slab test reads it).
    #[inline(always)]
    pub fn octant(ray: &Ray) -> usize {
        let d = ray.direction.to_array();
        (0..3).map(|a| ((d[a].to_bits() >> 31) as usize) << a).sum()
    }

    /// The octant a traversal may be instantiated for ([`WideRay::for_octant`]): the ray's
    /// octant when every direction component has a magnitude of at least 1e-37, so that every
    /// slab distance `(plane - origin) * reciprocal` is a product of finite numbers with a
    /// non-zero one (never NaN; an empty slot's infinite planes give infinities). `None` for
    /// rays along an axis plane (a zero component), which take the [`ANY_OCTANT`] instance.
    #[inline(always)]
    pub fn fixed_octant(ray: &Ray) -> Option<usize> {
        let fixed = ray.direction.abs().min_element() >= MIN_FIXED_OCTANT_COMPONENT;
        fixed.then(|| Self::octant(ray))
    }

    /// The values for a ray of octant `OCT` ([`WideRay::fixed_octant`]), or of any octant with
    /// [`ANY_OCTANT`]. With a fixed octant the row offsets are constants, which the compiler
    /// folds into every node's loads: a traversal instantiated per octant then neither keeps
    /// six offsets in registers nor reloads them from the stack at every node.
    #[inline(always)]
    pub fn for_octant<const OCT: usize>(ray: &Ray) -> Self {
        let pre = RayBoxPrecomp::new(ray);
        // Sign bit of each component: 1 picks the max row as the near plane (as `pre.neg`).
        let neg: [usize; 3] = if OCT == ANY_OCTANT {
            let d = ray.direction.to_array();
            d.map(|c| (c.to_bits() >> 31) as usize)
        } else {
            debug_assert_eq!(
                Some(OCT),
                Self::fixed_octant(ray),
                "ray {ray:?} traced as octant {OCT}"
            );
            [OCT & 1, (OCT >> 1) & 1, (OCT >> 2) & 1]
        };
        WideRay {
            near: [0, 1, 2].map(|a| (a + 3 * neg[a]) * Self::ROW),
            far: [0, 1, 2].map(|a| (a + 3 - 3 * neg[a]) * Self::ROW),
            origin: pre.origin.to_array(),
            inv_dir: pre.inv_dir.to_array(),
            inv_dir_far: pre.inv_dir_far.to_array(),
            no_nan: OCT != ANY_OCTANT,
            pre,
        }
    }

    /// The row of `bounds` at byte offset `offset` (one of `near` or `far`), from lane `lane`.
    ///
    /// # Safety
    /// `offset` must be one of this ray's `near` / `far` offsets (a whole row inside the six)
    /// and `lane < N`.
    #[inline(always)]
    unsafe fn row(bounds: &[[f32; N]; 6], offset: usize, lane: usize) -> *const f32 {
        debug_assert!(offset.is_multiple_of(Self::ROW) && offset < 6 * Self::ROW && lane < N);
        bounds
            .as_ptr()
            .cast::<u8>()
            .add(offset)
            .cast::<f32>()
            .add(lane)
    }
}

/// Tests the N child boxes of a node. Returns a bit mask of the children hit (bit i = slot i)
/// and writes each hit child's entry distance to `t_near[i]` (other lanes are unspecified).
pub trait ChildBoxTest<const N: usize> {
    /// How traversals with this kernel test leaf triangles: several at a time (the SIMD
    /// kernels) or one at a time (the scalar reference); all give the same answers.
    const LEAVES: LeafLanes;
    fn test(
        ray: &WideRay<N>,
        node: &WideNode<N>,
        t_min: f32,
        t_max: f32,
        t_near: &mut [f32; N],
    ) -> u32;

    /// `node.child` of the lowest and second-lowest slots of `mask` (which has at least one,
    /// and for `.1` at least two, bits set). Most visited nodes have one or two children hit,
    /// and the next node's address is on the traversal's critical path: a kernel may read
    /// both from the child row compressed by the hit mask instead of indexing by bit scans.
    #[inline(always)]
    fn lowest_children(node: &WideNode<N>, mask: u32) -> (u32, u32) {
        let first = mask.trailing_zeros() as usize;
        let rest = mask & mask.wrapping_sub(1);
        // Slot N (no second bit) reads nothing: the caller does not use `.1` then.
        let second = node.child.get(rest.trailing_zeros() as usize);
        (node.child[first], second.copied().unwrap_or(EMPTY_CHILD))
    }
}

/// The reference slab test, one child at a time.
pub struct Scalar;

impl<const N: usize> ChildBoxTest<N> for Scalar {
    const LEAVES: LeafLanes = LeafLanes::Scalar;
    #[inline(always)]
    fn test(
        ray: &WideRay<N>,
        node: &WideNode<N>,
        t_min: f32,
        t_max: f32,
        t_near: &mut [f32; N],
    ) -> u32 {
        let b = &node.bounds;
        let mut mask = 0;
        for (i, t) in t_near.iter_mut().enumerate() {
            let lo = Vec3::new(b[0][i], b[1][i], b[2][i]);
            let hi = Vec3::new(b[3][i], b[4][i], b[5][i]);
            if let Some(tn) = ray.pre.hit(lo, hi, t_min, t_max) {
                *t = tn;
                mask |= 1 << i;
            }
        }
        mask
    }
}

/// A slab test's entry and exit, `(t_near, t_far)`, from the per-axis distances `$near!(a)`
/// and `$far!(a)` and the segment's ends, with one vector width's `max` and `min`: the one
/// combination every SIMD box test (one ray, or a packet's lanes) uses. `$no_nan` (no distance
/// can be NaN) allows the shallower tree; otherwise a NaN distance (0 * inf) takes t_min or
/// t_max, as `max`/`min` return their second operand when either is NaN.
#[cfg(target_arch = "x86_64")]
macro_rules! slab_interval {
    ($no_nan:expr, $near:ident, $far:ident, $tmin:expr, $tmax:expr; $max:ident, $min:ident) => {{
        let (tmin, tmax) = ($tmin, $tmax);
        if $no_nan {
            // Two levels: with no NaN, max and min are associative and commutative (up to the
            // sign of a zero distance, which no comparison sees).
            (
                $max($max($near!(0), $near!(1)), $max($near!(2), tmin)),
                $min($min($far!(0), $far!(1)), $min($far!(2), tmax)),
            )
        } else {
            (
                $max(
                    $max($max($near!(0), tmin), $max($near!(1), tmin)),
                    $max($near!(2), tmin),
                ),
                $min(
                    $min($min($far!(0), tmax), $min($far!(1), tmax)),
                    $min($far!(2), tmax),
                ),
            )
        }
    }};
}
#[cfg(target_arch = "x86_64")]
pub(super) use slab_interval;

#[cfg(target_arch = "x86_64")]
pub use x86::{Avx2, Avx512, Sse};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;

    use super::{ChildBoxTest, LeafLanes, WideRay};
    use crate::bvh::WideNode;

    /// Four lanes with SSE (baseline on x86_64); eight as two halves.
    pub struct Sse;

    /// Eight lanes with AVX. Only call through a function compiled with AVX2 enabled, after
    /// runtime detection (see `any_hit` / `closest`).
    pub struct Avx2;

    /// Eight lanes with AVX-512VL: the AVX2 arithmetic, the hit test straight into a mask
    /// register. The gain is less this kernel than the traversal compiled around it with
    /// AVX-512VL, which has 32 vector registers, so the ray's constants stay in registers
    /// instead of being reloaded from the stack at every node. Only call through a function
    /// compiled with `avx512f,avx512vl`, after runtime detection.
    pub struct Avx512;

    /// The entry and exit distances `(tn, tf)` of the child boxes in the lanes from `lane` of
    /// each bounds row, written once for both vector widths with their intrinsics: per axis
    /// `(plane - origin) * inv_dir` of the ray's near rows and `* inv_dir_far` of its far rows,
    /// clamped to `[t_min, t_max]`. A macro, not a function generic over the
    /// width, so every intrinsic is inlined into a caller compiled with the features it needs.
    macro_rules! slab_distances {
        ($ray:expr, $bounds:expr, $lane:expr, $t_min:expr, $t_max:expr, $n:expr;
         $load:ident, $set1:ident, $sub:ident, $mul:ident, $max:ident, $min:ident) => {{
            let (ray, b, lane) = ($ray, $bounds, $lane);
            let (tmin, tmax) = ($set1($t_min), $set1($t_max));
            macro_rules! axis {
                ($a:expr, $off:expr, $inv:expr) => {
                    $mul(
                        $sub(
                            $load(WideRay::<$n>::row(b, $off, lane)),
                            $set1(ray.origin[$a]),
                        ),
                        $set1($inv[$a]),
                    )
                };
            }
            macro_rules! near {
                ($a:expr) => {
                    axis!($a, ray.near[$a], ray.inv_dir)
                };
            }
            macro_rules! far {
                ($a:expr) => {
                    axis!($a, ray.far[$a], ray.inv_dir_far)
                };
            }
            slab_interval!(ray.no_nan, near, far, tmin, tmax; $max, $min)
        }};
    }

    /// Four lanes starting at `lane` of each row.
    #[inline(always)]
    fn sse4<const N: usize>(
        ray: &WideRay<N>,
        node: &WideNode<N>,
        lane: usize,
        t_min: f32,
        t_max: f32,
        out: &mut [f32; N],
    ) -> u32 {
        debug_assert!(lane + 4 <= N);
        let b = &node.bounds;
        // SAFETY: SSE/SSE2 are part of the x86_64 baseline; every load reads lanes
        // `lane..lane + 4` of a row (at one of the ray's own offsets) of N >= lane + 4 floats,
        // and the store writes the same lanes of `out`.
        unsafe {
            let (tn, tf) = slab_distances!(
                ray, b, lane, t_min, t_max, N;
                _mm_loadu_ps, _mm_set1_ps, _mm_sub_ps, _mm_mul_ps, _mm_max_ps, _mm_min_ps
            );
            _mm_storeu_ps(out.as_mut_ptr().add(lane), tn);
            _mm_movemask_ps(_mm_cmple_ps(tn, tf)) as u32
        }
    }

    /// Four lanes at a time: one call for N = 4, two halves for N = 8.
    impl<const N: usize> ChildBoxTest<N> for Sse {
        const LEAVES: LeafLanes = LeafLanes::Four;
        #[inline(always)]
        fn test(
            ray: &WideRay<N>,
            node: &WideNode<N>,
            t_min: f32,
            t_max: f32,
            out: &mut [f32; N],
        ) -> u32 {
            const { assert!(N.is_multiple_of(4), "SSE tests 4 or 8 children") };
            let mut mask = 0;
            for lane in (0..N).step_by(4) {
                mask |= sse4(ray, node, lane, t_min, t_max, out) << lane;
            }
            mask
        }
    }

    /// Entry and exit distances of the eight children (before the hit test).
    #[inline(always)]
    fn distances8(
        ray: &WideRay<8>,
        node: &WideNode<8>,
        t_min: f32,
        t_max: f32,
    ) -> (__m256, __m256) {
        let b = &node.bounds;
        // SAFETY: only instantiated inside functions compiled with at least
        // `target_feature(enable = "avx2")` and called after runtime detection; loads read
        // whole 8-float rows at the ray's own row offsets.
        unsafe {
            let (tn, tf) = slab_distances!(
                ray, b, 0, t_min, t_max, 8;
                _mm256_loadu_ps, _mm256_set1_ps, _mm256_sub_ps, _mm256_mul_ps, _mm256_max_ps,
                _mm256_min_ps
            );
            (tn, tf)
        }
    }

    /// The 8-lane kernels: the same distances, the hit mask by `$mask`, and any other items
    /// of the kernel.
    macro_rules! eight_lanes {
        ($kernel:ty, |$tn:ident, $tf:ident| $mask:expr $(, $item:item)*) => {
            impl ChildBoxTest<8> for $kernel {
                const LEAVES: LeafLanes = LeafLanes::Eight;
                #[inline(always)]
                fn test(
                    ray: &WideRay<8>,
                    node: &WideNode<8>,
                    t_min: f32,
                    t_max: f32,
                    out: &mut [f32; 8],
                ) -> u32 {
                    let ($tn, $tf) = distances8(ray, node, t_min, t_max);
                    // SAFETY: only instantiated inside functions compiled with the kernel's
                    // features (see `distances8`); the store writes all of `out`.
                    unsafe {
                        _mm256_storeu_ps(out.as_mut_ptr(), $tn);
                        $mask
                    }
                }
                $($item)*
            }
        };
    }

    eight_lanes!(
        Avx2,
        |tn, tf| _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32
    );

    eight_lanes!(
        Avx512,
        |tn, tf| _mm256_cmp_ps_mask::<_CMP_LE_OQ>(tn, tf) as u32,
        /// The hit children's references packed to the low lanes by the hit mask: the next
        /// node's index is ready a compress and a move after the compare (a mask move, a bit
        /// scan, an address computation and a load before).
        #[inline(always)]
        fn lowest_children(node: &WideNode<8>, mask: u32) -> (u32, u32) {
            // SAFETY: as in `test`; the load reads the node's eight child references.
            unsafe {
                let children = _mm256_loadu_si256(node.child.as_ptr().cast());
                let packed = _mm256_maskz_compress_epi32(mask as __mmask8, children);
                let low = _mm256_castsi256_si128(packed);
                (
                    _mm_cvtsi128_si32(low) as u32,
                    _mm_extract_epi32::<1>(low) as u32,
                )
            }
        }
    );
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::sampling::hash_combine;

    fn unit(h: u32) -> f32 {
        (h >> 8) as f32 / (1u32 << 24) as f32
    }

    /// Mask and entry distances of one kernel, compiled with the features it needs.
    #[target_feature(enable = "avx2")]
    unsafe fn avx2(ray: &WideRay<8>, node: &WideNode<8>, t: &mut [f32; 8]) -> u32 {
        Avx2::test(ray, node, 0.0, 10.0, t)
    }

    #[target_feature(enable = "avx512f,avx512vl")]
    unsafe fn avx512(ray: &WideRay<8>, node: &WideNode<8>, t: &mut [f32; 8]) -> u32 {
        Avx512::test(ray, node, 0.0, 10.0, t)
    }

    #[target_feature(enable = "avx512f,avx512vl")]
    unsafe fn avx512_children(node: &WideNode<8>, mask: u32) -> (u32, u32) {
        Avx512::lowest_children(node, mask)
    }

    /// The child references of the lowest hit slots are those the mask's bits index, for
    /// every mask with one or more bits (the second only where there are two or more).
    #[test]
    fn lowest_children_are_the_children_of_the_lowest_mask_bits() {
        let mut node = WideNode::<8>::default();
        for s in 0..8 {
            node.child[s] = 1000 + 37 * s as u32;
        }
        let has_avx512 = std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl");
        for mask in 1u32..256 {
            let bits: Vec<usize> = (0..8).filter(|s| mask & (1 << s) != 0).collect();
            let check = |(a, b): (u32, u32)| {
                assert_eq!(a, node.child[bits[0]], "mask {mask:08b}");
                if bits.len() > 1 {
                    assert_eq!(b, node.child[bits[1]], "mask {mask:08b}");
                }
            };
            check(<Scalar as ChildBoxTest<8>>::lowest_children(&node, mask));
            check(<Avx2 as ChildBoxTest<8>>::lowest_children(&node, mask));
            if has_avx512 {
                // SAFETY: AVX-512F and VL were detected.
                check(unsafe { avx512_children(&node, mask) });
            }
        }
    }

    /// The row offsets fixed by an octant are those read from the ray; rays with a zero (of
    /// either sign) or tiny direction component get no fixed octant, and their reciprocals
    /// are the only ones that can be infinite.
    #[test]
    fn octant_offsets_equal_the_offsets_read_from_the_ray() {
        type Offsets = ([usize; 3], [usize; 3]);
        fn fixed<const OCT: usize>(ray: &Ray) -> Offsets {
            let w = WideRay::<8>::for_octant::<OCT>(ray);
            assert!(w.no_nan);
            (w.near, w.far)
        }
        let table: [fn(&Ray) -> Offsets; 8] = [
            fixed::<0>, fixed::<1>, fixed::<2>, fixed::<3>, fixed::<4>, fixed::<5>, fixed::<6>,
            fixed::<7>,
        ];
        let values = [
            1.0f32,
            -2.0,
            1e-37,
            -1e-37,
            0.0,
            -0.0,
            9e-38,
            f32::MIN_POSITIVE,
        ];
        let mut octants_seen = [false; 8];
        for x in values {
            for y in values {
                for z in values {
                    let ray = Ray::new(Vec3::ZERO, Vec3::new(x, y, z), 0.0, 1.0);
                    let dynamic = WideRay::<8>::new(&ray);
                    assert!(!dynamic.no_nan);
                    let oct = WideRay::<8>::octant(&ray);
                    let neg = [x, y, z].map(|c| c.is_sign_negative() as usize);
                    assert_eq!(oct, neg[0] | neg[1] << 1 | neg[2] << 2);
                    let finite = [dynamic.inv_dir, dynamic.inv_dir_far]
                        .iter()
                        .all(|inv| inv.iter().all(|r| r.is_finite() && *r != 0.0));
                    let tiny = [x, y, z].iter().any(|c| c.abs() < 1e-37);
                    match WideRay::<8>::fixed_octant(&ray) {
                        Some(o) => {
                            assert!(!tiny && finite, "{ray:?}");
                            assert_eq!(o, oct);
                            assert_eq!(table[oct](&ray), (dynamic.near, dynamic.far), "{ray:?}");
                            octants_seen[oct] = true;
                        }
                        None => assert!(tiny, "{ray:?}"),
                    }
                }
            }
        }
        assert!(octants_seen.iter().all(|&s| s));
    }

    /// Every 8-lane kernel the CPU has gives the scalar kernel's mask and entry distances bit
    /// for bit: random boxes (some slots empty, some flat) against rays with zero direction
    /// components and origins on box planes.
    #[test]
    fn eight_lane_kernels_equal_the_scalar_kernel() {
        let has_avx2 = std::arch::is_x86_feature_detected!("avx2");
        let has_avx512 = std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl");
        let (mut hits, mut compared, mut fixed) = (0, 0, 0);
        for k in 0..4000u32 {
            let r = |i: u32| unit(hash_combine(k, i));
            let mut node = WideNode::<8>::default();
            for s in 0..8 {
                if r(100 + s) < 0.15 {
                    continue; // empty slot
                }
                let lo = [0, 1, 2].map(|a| 4.0 * r(10 * s + a) - 2.0);
                let ext = [0, 1, 2].map(|a| {
                    if r(10 * s + 3 + a) < 0.1 {
                        0.0
                    } else {
                        r(10 * s + 6 + a)
                    }
                });
                node.child[s as usize] = s;
                for a in 0..3 {
                    node.bounds[a][s as usize] = lo[a];
                    node.bounds[3 + a][s as usize] = lo[a] + ext[a];
                }
            }
            let mut origin = Vec3::new(6.0 * r(230) - 3.0, 6.0 * r(231) - 3.0, 6.0 * r(232) - 3.0);
            if r(240) < 0.2 {
                origin.x = node.bounds[0][0]; // on a plane
            }
            // Mostly aimed at a point of one child's box, so that many lanes hit.
            let s = (k % 8) as usize;
            let target = Vec3::new(
                node.bounds[0][s] + r(203) * (node.bounds[3][s] - node.bounds[0][s]),
                node.bounds[1][s] + r(204) * (node.bounds[4][s] - node.bounds[1][s]),
                node.bounds[2][s] + r(205) * (node.bounds[5][s] - node.bounds[2][s]),
            );
            let mut dir = if node.is_empty_slot(s) || r(206) < 0.2 {
                Vec3::new(r(200) - 0.5, r(201) - 0.5, r(202) - 0.5)
            } else {
                target - origin
            };
            for a in 0..3 {
                if r(210 + a as u32) < 0.2 {
                    dir[a] = if r(220) < 0.5 { 0.0 } else { -0.0 };
                }
            }
            if dir == Vec3::ZERO {
                dir.x = 1.0;
            }
            let plain = Ray::new(origin, dir, 0.0, 10.0);
            let ray = WideRay::new(&plain);
            let mut want = [0f32; 8];
            let expected = Scalar::test(&ray, &node, 0.0, 10.0, &mut want);
            let mut check = |mask: u32, got: [f32; 8], no_nan: bool| {
                assert_eq!(mask, expected, "case {k} no_nan {no_nan}");
                for s in (0..8).filter(|s| expected & (1 << s) != 0) {
                    assert_eq!(got[s].to_bits(), want[s].to_bits(), "case {k} slot {s}");
                }
                compared += 1;
                fixed += no_nan as u32;
            };
            // Rays a traversal may trace with a fixed octant also through the shallower
            // min/max tree of the per-octant instances.
            let mut variants = vec![ray];
            if WideRay::<8>::fixed_octant(&plain).is_some() {
                variants.push(WideRay {
                    no_nan: true,
                    ..ray
                });
            }
            for ray in &variants {
                let mut t = [0f32; 8];
                check(Sse::test(ray, &node, 0.0, 10.0, &mut t), t, ray.no_nan);
                if has_avx2 {
                    // SAFETY: AVX2 was detected.
                    check(unsafe { avx2(ray, &node, &mut t) }, t, ray.no_nan);
                }
                if has_avx512 {
                    // SAFETY: AVX-512F and VL were detected.
                    check(unsafe { avx512(ray, &node, &mut t) }, t, ray.no_nan);
                }
            }
            hits += expected.count_ones();
        }
        assert!(
            compared >= 4000 && hits > 1000 && fixed > 1000,
            "{compared} comparisons ({fixed} without NaN), {hits} hits"
        );
    }
}
