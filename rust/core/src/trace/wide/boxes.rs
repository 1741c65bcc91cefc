//! Testing all N child boxes of a wide node against one ray: a scalar kernel that calls the
//! reference slab test once per child, and SIMD kernels (SSE 4 lanes, AVX2 8 lanes) that give the
//! same answers bit for bit.
//!
//! The SIMD kernels do the reference's arithmetic in the reference's order, per lane:
//! `(plane - origin) * inv_dir` per axis, NaN replaced by `t_min` (near) or `t_max` (far) with
//! the operand order of `minps`/`maxps` (which return the second operand when either is NaN),
//! the far distance scaled by `FAR_SCALE` before the clamp. Scaling by a positive constant is
//! monotone under rounding, so `min(a, b) * s == min(a * s, b * s)` exactly and the per-axis
//! scaling equals the reference's scaling of the minimum. The hit rule `t_near <= t_far` and the
//! returned entry distance are the reference's, which keeps `t_margin`'s exact-tie guarantee.

use glam::Vec3;

use super::leaf::LeafLanes;
use crate::bvh::WideNode;
use crate::geometry::{Ray, RayBoxPrecomp};

/// Which box-test implementation a traversal uses. All give identical answers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BoxKernel {
    /// The widest SIMD the CPU has (AVX2 for 8 lanes, SSE for 4; scalar for 2).
    #[default]
    Auto,
    /// One reference slab test per child.
    Scalar,
    /// SSE only, even where AVX2 exists (8 lanes as two halves).
    Sse,
}

/// Per-ray values of the wide box test.
#[derive(Clone, Copy, Debug)]
pub struct WideRay {
    pub pre: RayBoxPrecomp,
    /// Per axis: the bounds row holding the near plane (min row, or max row for a negative
    /// direction component) and the far plane.
    pub near_row: [usize; 3],
    pub far_row: [usize; 3],
    pub origin: [f32; 3],
    pub inv_dir: [f32; 3],
}

impl WideRay {
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        let pre = RayBoxPrecomp::new(ray);
        let neg = [pre.neg.x, pre.neg.y, pre.neg.z];
        WideRay {
            near_row: [0, 1, 2].map(|a| if neg[a] { 3 + a } else { a }),
            far_row: [0, 1, 2].map(|a| if neg[a] { a } else { 3 + a }),
            origin: pre.origin.to_array(),
            inv_dir: pre.inv_dir.to_array(),
            pre,
        }
    }
}

/// Tests the N child boxes of a node. Returns a bit mask of the children hit (bit i = slot i)
/// and writes each hit child's entry distance to `t_near[i]` (other lanes are unspecified).
pub trait ChildBoxTest<const N: usize> {
    /// How traversals with this kernel test leaf triangles: several at a time (the SIMD
    /// kernels) or one at a time (the scalar reference); all give the same answers.
    const LEAVES: LeafLanes;
    fn test(
        ray: &WideRay,
        node: &WideNode<N>,
        t_min: f32,
        t_max: f32,
        t_near: &mut [f32; N],
    ) -> u32;
}

/// The reference slab test, one child at a time.
pub struct Scalar;

impl<const N: usize> ChildBoxTest<N> for Scalar {
    const LEAVES: LeafLanes = LeafLanes::Scalar;
    #[inline(always)]
    fn test(
        ray: &WideRay,
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

#[cfg(target_arch = "x86_64")]
pub use x86::{Avx2, Sse};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;

    use super::{ChildBoxTest, LeafLanes, WideRay};
    use crate::bvh::WideNode;
    use crate::geometry::FAR_SCALE;

    /// Four lanes with SSE (baseline on x86_64); eight as two halves.
    pub struct Sse;

    /// Eight lanes with AVX. Only call through a function compiled with AVX2 enabled, after
    /// runtime detection (see `any_hit` / `closest`).
    pub struct Avx2;

    /// Four lanes starting at `lane` of each row.
    #[inline(always)]
    fn sse4<const N: usize>(
        ray: &WideRay,
        node: &WideNode<N>,
        lane: usize,
        t_min: f32,
        t_max: f32,
        out: &mut [f32; N],
    ) -> u32 {
        debug_assert!(lane + 4 <= N);
        let b = &node.bounds;
        // SAFETY: SSE/SSE2 are part of the x86_64 baseline; every load reads lanes
        // `lane..lane + 4` of a row of N >= lane + 4 floats, and the store writes the same lanes
        // of `out`.
        unsafe {
            let tmin = _mm_set1_ps(t_min);
            let tmax = _mm_set1_ps(t_max);
            let scale = _mm_set1_ps(FAR_SCALE);
            // Macros rather than closures so every intrinsic is inlined into the caller.
            macro_rules! axis {
                ($a:expr, $row:expr) => {
                    _mm_mul_ps(
                        _mm_sub_ps(
                            _mm_loadu_ps(b[$row].as_ptr().add(lane)),
                            _mm_set1_ps(ray.origin[$a]),
                        ),
                        _mm_set1_ps(ray.inv_dir[$a]),
                    )
                };
            }
            macro_rules! near {
                ($a:expr) => {
                    _mm_max_ps(axis!($a, ray.near_row[$a]), tmin)
                };
            }
            macro_rules! far {
                ($a:expr) => {
                    _mm_min_ps(_mm_mul_ps(axis!($a, ray.far_row[$a]), scale), tmax)
                };
            }
            let tn = _mm_max_ps(_mm_max_ps(near!(0), near!(1)), near!(2));
            let tf = _mm_min_ps(_mm_min_ps(far!(0), far!(1)), far!(2));
            _mm_storeu_ps(out.as_mut_ptr().add(lane), tn);
            _mm_movemask_ps(_mm_cmple_ps(tn, tf)) as u32
        }
    }

    impl ChildBoxTest<4> for Sse {
        const LEAVES: LeafLanes = LeafLanes::Four;
        #[inline(always)]
        fn test(
            ray: &WideRay,
            node: &WideNode<4>,
            t_min: f32,
            t_max: f32,
            out: &mut [f32; 4],
        ) -> u32 {
            sse4(ray, node, 0, t_min, t_max, out)
        }
    }

    impl ChildBoxTest<8> for Sse {
        const LEAVES: LeafLanes = LeafLanes::Four;
        #[inline(always)]
        fn test(
            ray: &WideRay,
            node: &WideNode<8>,
            t_min: f32,
            t_max: f32,
            out: &mut [f32; 8],
        ) -> u32 {
            sse4(ray, node, 0, t_min, t_max, out) | sse4(ray, node, 4, t_min, t_max, out) << 4
        }
    }

    impl ChildBoxTest<8> for Avx2 {
        const LEAVES: LeafLanes = LeafLanes::Eight;
        #[inline(always)]
        fn test(
            ray: &WideRay,
            node: &WideNode<8>,
            t_min: f32,
            t_max: f32,
            out: &mut [f32; 8],
        ) -> u32 {
            let b = &node.bounds;
            // SAFETY: this kernel is only instantiated inside functions compiled with
            // `target_feature(enable = "avx2")` and called after `is_x86_feature_detected!("avx2")`;
            // loads read whole 8-float rows, the store writes all of `out`.
            unsafe {
                let tmin = _mm256_set1_ps(t_min);
                let tmax = _mm256_set1_ps(t_max);
                let scale = _mm256_set1_ps(FAR_SCALE);
                macro_rules! axis {
                    ($a:expr, $row:expr) => {
                        _mm256_mul_ps(
                            _mm256_sub_ps(
                                _mm256_loadu_ps(b[$row].as_ptr()),
                                _mm256_set1_ps(ray.origin[$a]),
                            ),
                            _mm256_set1_ps(ray.inv_dir[$a]),
                        )
                    };
                }
                macro_rules! near {
                    ($a:expr) => {
                        _mm256_max_ps(axis!($a, ray.near_row[$a]), tmin)
                    };
                }
                macro_rules! far {
                    ($a:expr) => {
                        _mm256_min_ps(_mm256_mul_ps(axis!($a, ray.far_row[$a]), scale), tmax)
                    };
                }
                let tn = _mm256_max_ps(_mm256_max_ps(near!(0), near!(1)), near!(2));
                let tf = _mm256_min_ps(_mm256_min_ps(far!(0), far!(1)), far!(2));
                _mm256_storeu_ps(out.as_mut_ptr(), tn);
                _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32
            }
        }
    }
}
