use glam::{BVec3, Vec3, Vec3A};

use super::gamma;

/// A ray segment `origin + t * direction` for t in (`t_min`, `t_max`). The direction need not be
/// normalised: shadow rays use the vector to the light sample with `t_max` = 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub direction: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    pub fn new(origin: Vec3, direction: Vec3, t_min: f32, t_max: f32) -> Self {
        Ray {
            origin,
            direction,
            t_min,
            t_max,
        }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }
}

/// Per-ray values for the slab test, computed once per ray.
///
/// Near and far planes are chosen by the sign bit of each direction component (so -0.0 picks
/// the planes of a negative direction). A zero component gives an infinite reciprocal: the slab
/// distances are then -inf/+inf when the origin lies inside the slab, +inf/-inf (a miss) when
/// it lies outside, and NaN when it lies exactly on a plane. Such a NaN must not reject the box
/// (conservative: the triangle test makes the final decision), so every min/max below is
/// arranged to return its other, non-NaN operand (SSE's `minps`/`maxps` return the second
/// operand when either is NaN; `f32::min`/`max` return the non-NaN one). The far distance is
/// enlarged by 1 + 2·gamma(3) to cover the rounding of the subtraction and the multiplication
/// (pbrt-v4, section 6.8.2), folded into the reciprocal used for far planes: `(p - o) *
/// fl(inv * s)` is rounded four times (the reciprocal, the scaled reciprocal, the subtraction,
/// the product), as pbrt's `fl(fl(p - o) * inv) * s` is, so the same bound keeps it at or above
/// the exact distance, and it saves a multiplication per box.
#[derive(Clone, Copy, Debug)]
pub struct RayBoxPrecomp {
    pub origin: Vec3,
    pub inv_dir: Vec3,
    /// `inv_dir * FAR_SCALE`: the reciprocal for far planes.
    pub inv_dir_far: Vec3,
    /// Per axis: true if the direction component has its sign bit set.
    pub neg: BVec3,
    /// How far past a hit distance a box's entry distance may lie and still hold a triangle
    /// hit at that distance. A box's entry and a triangle's hit distance are rounded by
    /// different computations, so a triangle on a box's face can be hit at a `t` a few ulps
    /// below the box's computed entry. Traversals extend `t_max` by this margin in box tests
    /// (never in triangle tests) so that exact ties are found as brute force finds them. The
    /// bound is 2^-16 of the coordinates' magnitude (render space spans about [-1, 1]) over the
    /// direction's largest component (1 to sqrt(3) times the same over its length): hundreds of
    /// ulps, far above the tens the two computations can differ.
    pub t_margin: f32,
    #[cfg(target_arch = "x86_64")]
    simd: sse::Precomp,
}

const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

impl RayBoxPrecomp {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.direction;
        let (inv_dir, inv_dir_far, t_margin) = Self::reciprocals(ray);
        let neg = BVec3::new(
            d.x.is_sign_negative(),
            d.y.is_sign_negative(),
            d.z.is_sign_negative(),
        );
        RayBoxPrecomp {
            origin: ray.origin,
            inv_dir,
            inv_dir_far,
            neg,
            t_margin,
            #[cfg(target_arch = "x86_64")]
            simd: sse::Precomp::new(ray.origin, inv_dir, inv_dir_far, neg),
        }
    }

    /// `inv_dir`, `inv_dir_far` and `t_margin` of `ray`: the one definition the single-ray
    /// and the packet box tests share.
    #[inline(always)]
    pub fn reciprocals(ray: &Ray) -> (Vec3, Vec3, f32) {
        // One packed division instead of three (each lane is the same IEEE quotient).
        let inv_dir = Vec3::from(Vec3A::ONE / Vec3A::from(ray.direction));
        let magnitude = 2.0 + ray.origin.abs().max_element();
        // 1 / |d| <= 1 / max |d_i| = min |1 / d_i|: from the reciprocals at hand, so the first
        // node's test does not wait for a square root and a division.
        let inv_length_bound = inv_dir.abs().min_element();
        let t_margin = magnitude * (1.0 / 65536.0) * inv_length_bound;
        (inv_dir, inv_dir * FAR_SCALE, t_margin)
    }

    /// Entry distance of the box when the segment (t_min, t_max) overlaps it, else `None`.
    #[inline(always)]
    pub fn hit(&self, min: Vec3, max: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let near = (Vec3::select(self.neg, max, min) - self.origin) * self.inv_dir;
        let far = (Vec3::select(self.neg, min, max) - self.origin) * self.inv_dir_far;
        let t_near = near.x.max(near.y).max(near.z).max(t_min);
        let t_far = far.x.min(far.y).min(far.z).min(t_max);
        (t_near <= t_far).then_some(t_near)
    }

    /// The same test on bounds stored as `[min.x, min.y, min.z, _, max.x, max.y, max.z, _]`
    /// (the BVH node layout), with SSE where available. Gives exactly the answers of [`hit`].
    ///
    /// [`hit`]: RayBoxPrecomp::hit
    #[inline(always)]
    pub fn hit_packed(&self, bounds: &[f32; 8], t_min: f32, t_max: f32) -> Option<f32> {
        #[cfg(target_arch = "x86_64")]
        {
            self.simd.hit(bounds, t_min, t_max)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.hit(
                Vec3::new(bounds[0], bounds[1], bounds[2]),
                Vec3::new(bounds[4], bounds[5], bounds[6]),
                t_min,
                t_max,
            )
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod sse {
    use std::arch::x86_64::*;

    use glam::{BVec3, Vec3};

    #[derive(Clone, Copy, Debug)]
    pub(super) struct Precomp {
        origin: __m128,
        inv: __m128,
        inv_far: __m128,
        /// All bits set in the lanes whose direction is negative.
        neg: __m128,
    }

    impl Precomp {
        #[inline(always)]
        pub(super) fn new(o: Vec3, inv: Vec3, inv_far: Vec3, neg: BVec3) -> Self {
            let m = |b: bool| if b { f32::from_bits(u32::MAX) } else { 0.0 };
            // SAFETY: SSE2 is part of the x86_64 baseline.
            unsafe {
                Precomp {
                    origin: _mm_set_ps(0.0, o.z, o.y, o.x),
                    inv: _mm_set_ps(0.0, inv.z, inv.y, inv.x),
                    inv_far: _mm_set_ps(0.0, inv_far.z, inv_far.y, inv_far.x),
                    neg: _mm_set_ps(0.0, m(neg.z), m(neg.y), m(neg.x)),
                }
            }
        }

        #[inline(always)]
        pub(super) fn hit(&self, b: &[f32; 8], t_min: f32, t_max: f32) -> Option<f32> {
            // SAFETY: SSE2 is part of the x86_64 baseline; the loads read 8 in-bounds floats.
            unsafe {
                let lo = _mm_loadu_ps(b.as_ptr());
                let hi = _mm_loadu_ps(b.as_ptr().add(4));
                let near_plane = _mm_or_ps(_mm_and_ps(self.neg, hi), _mm_andnot_ps(self.neg, lo));
                let far_plane = _mm_or_ps(_mm_and_ps(self.neg, lo), _mm_andnot_ps(self.neg, hi));
                let tn = _mm_mul_ps(_mm_sub_ps(near_plane, self.origin), self.inv);
                let tf = _mm_mul_ps(_mm_sub_ps(far_plane, self.origin), self.inv_far);
                // NaN lanes (origin on a plane of a zero-direction axis) become t_min / t_max.
                let tn = _mm_max_ps(tn, _mm_set1_ps(t_min));
                let tf = _mm_min_ps(tf, _mm_set1_ps(t_max));
                // Horizontal max/min over lanes 0..3 only (lane 3 holds node data).
                let n = _mm_max_ps(tn, _mm_shuffle_ps(tn, tn, 0b00_00_10_10));
                let n = _mm_max_ss(n, _mm_shuffle_ps(n, n, 0b00_00_00_01));
                let f = _mm_min_ps(tf, _mm_shuffle_ps(tf, tf, 0b00_00_10_10));
                let f = _mm_min_ss(f, _mm_shuffle_ps(f, f, 0b00_00_00_01));
                let t_near = _mm_cvtss_f32(n);
                (t_near <= _mm_cvtss_f32(f)).then_some(t_near)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> (Vec3, Vec3) {
        (Vec3::ZERO, Vec3::ONE)
    }

    #[test]
    fn axis_parallel_rays_with_zero_and_negative_zero() {
        let (lo, hi) = unit();
        for dz in [0.0f32, -0.0] {
            for dy in [0.0f32, -0.0] {
                let ray = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::new(1.0, dy, dz), 0.0, 10.0);
                assert!(RayBoxPrecomp::new(&ray).hit(lo, hi, 0.0, 10.0).is_some());
                let miss = Ray::new(Vec3::new(-1.0, 1.5, 0.5), Vec3::new(1.0, dy, dz), 0.0, 10.0);
                assert!(RayBoxPrecomp::new(&miss).hit(lo, hi, 0.0, 10.0).is_none());
            }
        }
    }

    #[test]
    fn ray_on_the_slab_plane_is_not_culled() {
        let (lo, hi) = unit();
        // Origin exactly on the y = 0 face, direction with y = 0: 0 * inf = NaN.
        let ray = Ray::new(
            Vec3::new(-1.0, 0.0, 0.5),
            Vec3::new(1.0, 0.0, 0.0),
            0.0,
            10.0,
        );
        assert!(RayBoxPrecomp::new(&ray).hit(lo, hi, 0.0, 10.0).is_some());
        // A flat box (zero thickness in y) is hit by a ray crossing it.
        let flat_hi = Vec3::new(1.0, 0.0, 1.0);
        let down = Ray::new(
            Vec3::new(0.5, 1.0, 0.5),
            Vec3::new(0.0, -1.0, -0.0),
            0.0,
            10.0,
        );
        assert!(RayBoxPrecomp::new(&down)
            .hit(lo, flat_hi, 0.0, 10.0)
            .is_some());
    }

    #[test]
    fn segment_limits() {
        let (lo, hi) = unit();
        let ray = Ray::new(Vec3::new(-2.0, 0.5, 0.5), Vec3::X, 0.0, 1.5);
        assert!(RayBoxPrecomp::new(&ray).hit(lo, hi, 0.0, 1.5).is_none());
        assert!(RayBoxPrecomp::new(&ray).hit(lo, hi, 0.0, 2.0).is_some());
        assert!(RayBoxPrecomp::new(&ray).hit(lo, hi, 3.5, 5.0).is_none());
    }

    /// The packed reciprocal is the per-component `1.0 / d` bit for bit, zeros of both signs,
    /// subnormals, huge and tiny components included.
    #[test]
    fn packed_reciprocal_equals_three_divisions() {
        let vals = [
            0.0f32,
            -0.0,
            1.0,
            -3.0,
            1e-40,
            -1e-45,
            3e38,
            -1e-38,
            0.1,
            f32::MIN_POSITIVE,
            7.5e-8,
        ];
        for &x in &vals {
            for &y in &vals {
                for &z in &vals {
                    let d = Vec3::new(x, y, z);
                    let ray = Ray::new(Vec3::ZERO, d, 0.0, 1.0);
                    let inv = RayBoxPrecomp::new(&ray).inv_dir;
                    for a in 0..3 {
                        assert_eq!(inv[a].to_bits(), (1.0 / d[a]).to_bits(), "{d:?} axis {a}");
                    }
                }
            }
        }
    }

    #[test]
    fn packed_test_gives_the_scalar_answers() {
        let vals = [-1.0f32, -0.0, 0.0, 0.5, 1.0, 2.0];
        let dirs = [-1.0f32, -0.0, 0.0, 0.25, 1.0];
        let mut n = 0;
        for ox in vals {
            for oy in vals {
                for dx in dirs {
                    for dy in dirs {
                        for dz in [-1.0f32, 0.0, 1.0] {
                            let d = Vec3::new(dx, dy, dz);
                            if d == Vec3::ZERO {
                                continue;
                            }
                            let ray = Ray::new(Vec3::new(ox, oy, 0.5), d, 0.0, 3.0);
                            let p = RayBoxPrecomp::new(&ray);
                            let packed =
                                [0.0, 0.0, 0.0, f32::NAN, 1.0, 1.0, 1.0, f32::from_bits(7)];
                            assert_eq!(
                                p.hit(Vec3::ZERO, Vec3::ONE, 0.0, 3.0),
                                p.hit_packed(&packed, 0.0, 3.0),
                                "{ray:?}"
                            );
                            n += 1;
                        }
                    }
                }
            }
        }
        assert!(n > 1000);
    }

    /// The far-plane distance `(p - o) * inv_dir_far` is never below the exact distance
    /// `(p - o) / d` (computed in f64, where the subtraction is exact and the division's error
    /// is far below f32's), over origins, planes and directions from 1e-30 to 1e30. (With the
    /// scale 1 it fails: the bound is what makes the box test conservative.)
    /// A xorshift32 stream from `seed` (non-zero).
    fn xorshift(mut state: u32) -> impl FnMut() -> u32 {
        move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        }
    }

    #[test]
    fn far_distances_are_never_below_the_exact_ones() {
        let mut next = xorshift(0x2545_f491);
        let value = |next: &mut dyn FnMut() -> u32| {
            let mantissa = 1.0 + (next() >> 8) as f32 / (1u32 << 24) as f32;
            let exponent = (next() % 61) as i32 - 30;
            let sign = if next() & 1 == 0 { 1.0 } else { -1.0 };
            sign * mantissa * 10f32.powi(exponent)
        };
        let mut checked = 0;
        for _ in 0..200_000 {
            let (o, p, d) = (value(&mut next), value(&mut next), value(&mut next));
            let ray = Ray::new(Vec3::splat(o), Vec3::splat(d), 0.0, 1.0);
            let pre = RayBoxPrecomp::new(&ray);
            let far = (p - o) * pre.inv_dir_far.x;
            let exact = (p as f64 - o as f64) / d as f64;
            // Distances in f32's normal range: below it the product underflows in any formula.
            let normal = f32::MIN_POSITIVE as f64..f32::MAX as f64;
            if normal.contains(&exact) && far.is_finite() {
                assert!(far as f64 >= exact, "o {o} p {p} d {d}: {far} < {exact}");
                checked += 1;
            }
        }
        assert!(checked > 50_000, "{checked}");
    }

    /// The box tests' reach past the segment is never below its stated bound, 2^-16 of the
    /// coordinates' magnitude over the direction's length, and at most sqrt(3) times it.
    #[test]
    fn margin_covers_its_bound_over_the_direction_length() {
        let mut bits = xorshift(0x9e37_79b9);
        let mut next = || (bits() >> 8) as f32 / (1u32 << 24) as f32;
        for k in 0..10_000 {
            let mut v = || Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
            let (origin, mut d) = (v() * 40.0, v() * 10f32.powi(k % 7 - 3));
            if k % 5 == 0 {
                d.y = 0.0; // a component of zero: an infinite reciprocal
            }
            let pre = RayBoxPrecomp::new(&Ray::new(origin, d, 0.0, 1.0));
            let magnitude = 2.0 + origin.abs().max_element() as f64;
            let bound = magnitude / 65536.0 / d.as_dvec3().length();
            let margin = pre.t_margin as f64;
            assert!(
                margin >= bound * (1.0 - 1e-6),
                "{origin} {d}: {margin} < {bound}"
            );
            assert!(
                margin <= bound * 3f64.sqrt() * (1.0 + 1e-6),
                "{origin} {d}: {margin}"
            );
        }
    }
}
