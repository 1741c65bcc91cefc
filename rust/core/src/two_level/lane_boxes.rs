//! One box (a wide top-level node's child slot, or the root's box) against a run's lanes at once
//! (SIMD across lanes, four a step with SSE2). The run mixes ray octants, so each lane picks
//! its own near and far planes. Each lane's arithmetic is `RayBoxPrecomp::hit_packed`'s,
//! operation for operation and operand for operand (NaN planes and all): a lane enters exactly
//! the boxes its single-ray test enters, at the same entry distance (the wide kernels' `hit`
//! order gives the same maximum and minimum).

use crate::bvh::WideNode;
use crate::geometry::{Aabb, Ray, RayBoxPrecomp};
use crate::trace::wide::PACKET_LANES as LANES;

/// Per lane, by axis: the values of its [`RayBoxPrecomp`], and how far its box tests reach.
pub(super) struct LaneBoxes {
    origin: [[f32; LANES]; 3],
    inv: [[f32; LANES]; 3],
    inv_far: [[f32; LANES]; 3],
    /// All bits set where the direction is negative (the far plane is the box's min).
    neg: [[f32; LANES]; 3],
    t_min: [f32; LANES],
    /// `t_max + t_margin`: the single-ray test's reach.
    reach: [f32; LANES],
    t_margin: [f32; LANES],
}

impl LaneBoxes {
    /// The lanes of `rays` (1 to [`LANES`]); lanes past them repeat the last ray.
    pub(super) fn new(rays: &[Ray]) -> Self {
        let mut b = LaneBoxes {
            origin: [[0.0; LANES]; 3],
            inv: [[0.0; LANES]; 3],
            inv_far: [[0.0; LANES]; 3],
            neg: [[0.0; LANES]; 3],
            t_min: [0.0; LANES],
            reach: [0.0; LANES],
            t_margin: [0.0; LANES],
        };
        let last = rays.len() - 1;
        for lane in 0..LANES {
            let ray = &rays[lane.min(last)];
            let pre = RayBoxPrecomp::new(ray);
            let neg = [pre.neg.x, pre.neg.y, pre.neg.z];
            for (axis, negative) in neg.into_iter().enumerate() {
                b.origin[axis][lane] = pre.origin[axis];
                b.inv[axis][lane] = pre.inv_dir[axis];
                b.inv_far[axis][lane] = pre.inv_dir_far[axis];
                b.neg[axis][lane] = f32::from_bits(if negative { u32::MAX } else { 0 });
            }
            b.t_min[lane] = ray.t_min;
            b.t_margin[lane] = pre.t_margin;
            b.reach[lane] = ray.t_max + pre.t_margin;
        }
        b
    }

    /// The lane's segment now ends at `t_max` (a closer hit).
    #[inline(always)]
    pub(super) fn set_t_max(&mut self, lane: usize, t_max: f32) {
        self.reach[lane] = t_max + self.t_margin[lane];
    }

    /// How far the lane's box tests reach.
    #[inline(always)]
    pub(super) fn reach(&self, lane: usize) -> f32 {
        self.reach[lane]
    }

    /// The lanes of `mask` whose box test passes on `b` (a [`packed`] box), each one's entry
    /// in `t_entry` (other lanes' entries are left as any value).
    #[inline(always)]
    pub(super) fn test(&self, b: &[f32; 8], mask: u32, t_entry: &mut [f32; LANES]) -> u32 {
        let mut hits = 0;
        for group in 0..LANES / 4 {
            let lanes = (mask >> (4 * group)) & 0xF;
            if lanes != 0 {
                hits |= (self.test4(b, 4 * group, t_entry) & lanes) << (4 * group);
            }
        }
        hits
    }

    /// Lanes `first..first + 4`: `hit_packed`'s SSE sequence with the lanes across a register
    /// instead of the axes.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn test4(&self, b: &[f32; 8], first: usize, t_entry: &mut [f32; LANES]) -> u32 {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86_64 baseline; every load and store reads or writes 4
        // in-bounds floats (`first + 4 <= LANES`).
        unsafe {
            let at = |a: &[f32; LANES]| _mm_loadu_ps(a.as_ptr().add(first));
            let axis = |k: usize| {
                let (lo, hi) = (_mm_set1_ps(b[k]), _mm_set1_ps(b[k + 4]));
                let neg = at(&self.neg[k]);
                let near_plane = _mm_or_ps(_mm_and_ps(neg, hi), _mm_andnot_ps(neg, lo));
                let far_plane = _mm_or_ps(_mm_and_ps(neg, lo), _mm_andnot_ps(neg, hi));
                let o = at(&self.origin[k]);
                let tn = _mm_mul_ps(_mm_sub_ps(near_plane, o), at(&self.inv[k]));
                let tf = _mm_mul_ps(_mm_sub_ps(far_plane, o), at(&self.inv_far[k]));
                // NaN lanes (origin on a plane of a zero-direction axis) become t_min / reach.
                (
                    _mm_max_ps(tn, at(&self.t_min)),
                    _mm_min_ps(tf, at(&self.reach)),
                )
            };
            let ((nx, fx), (ny, fy), (nz, fz)) = (axis(0), axis(1), axis(2));
            // `hit_packed`'s horizontal order: max(max(x, z), max(y, z)), and so for min.
            let n = _mm_max_ps(_mm_max_ps(nx, nz), _mm_max_ps(ny, nz));
            let f = _mm_min_ps(_mm_min_ps(fx, fz), _mm_min_ps(fy, fz));
            _mm_storeu_ps(t_entry.as_mut_ptr().add(first), n);
            _mm_movemask_ps(_mm_cmple_ps(n, f)) as u32
        }
    }

    /// Lanes `first..first + 4`, each by `RayBoxPrecomp::hit`'s formula (what `hit_packed`
    /// computes off x86_64).
    #[cfg(not(target_arch = "x86_64"))]
    #[inline(always)]
    fn test4(&self, b: &[f32; 8], first: usize, t_entry: &mut [f32; LANES]) -> u32 {
        use glam::{BVec3, Vec3};
        let (min, max) = (Vec3::new(b[0], b[1], b[2]), Vec3::new(b[4], b[5], b[6]));
        let mut hits = 0;
        for i in 0..4 {
            let l = first + i;
            let v = |a: &[[f32; LANES]; 3]| Vec3::new(a[0][l], a[1][l], a[2][l]);
            let n = self.neg.map(|a| a[l].to_bits() != 0);
            let neg = BVec3::new(n[0], n[1], n[2]);
            let near = (Vec3::select(neg, max, min) - v(&self.origin)) * v(&self.inv);
            let far = (Vec3::select(neg, min, max) - v(&self.origin)) * v(&self.inv_far);
            let t_near = near.x.max(near.y).max(near.z).max(self.t_min[l]);
            let t_far = far.x.min(far.y).min(far.z).min(self.reach[l]);
            t_entry[l] = t_near;
            hits |= ((t_near <= t_far) as u32) << i;
        }
        hits
    }
}

/// A box as `hit_packed` reads it: `[min.x, min.y, min.z, _, max.x, max.y, max.z, _]`.
#[inline(always)]
pub(super) fn packed(b: &Aabb) -> [f32; 8] {
    [
        b.min.x, b.min.y, b.min.z, 0.0, b.max.x, b.max.y, b.max.z, 0.0,
    ]
}

/// Child `slot` of a wide node as a [`packed`] box.
#[inline(always)]
pub(super) fn slot_box<const N: usize>(node: &WideNode<N>, slot: usize) -> [f32; 8] {
    let b = &node.bounds;
    [
        b[0][slot], b[1][slot], b[2][slot], 0.0, b[3][slot], b[4][slot], b[5][slot], 0.0,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Values that reach every branch of the slab test: zero and negative-zero directions,
    /// origins on box planes (NaN slabs), boxes behind, around and past the segment.
    const VALUES: [f32; 7] = [-1.0, -0.0, 0.0, 0.25, 0.5, 1.0, 2.0];

    fn pick(seed: usize, k: usize) -> f32 {
        VALUES[(seed / 7usize.pow(k as u32)) % VALUES.len()]
    }

    #[test]
    fn lanes_enter_what_their_single_ray_tests_enter_at_the_same_distance() {
        let (mut entered_both, mut missed_both) = (0, 0);
        for seed in 0..4000usize {
            let rays: Vec<Ray> = (0..LANES)
                .map(|l| {
                    let s = seed * 31 + l * 7919;
                    let o = Vec3::new(pick(s, 0), pick(s, 1), pick(s, 2));
                    let d = Vec3::new(pick(s, 3), pick(s, 4), pick(s, 5)) - 0.2 * l as f32 % 0.6;
                    let t_max = [1.0, f32::INFINITY, 0.3][l % 3];
                    Ray::new(o, d, [0.0, 1e-4][l % 2], t_max)
                })
                .collect();
            let n = 1 + seed % LANES;
            let boxes = LaneBoxes::new(&rays[..n]);
            let lo = Vec3::new(pick(seed, 1), pick(seed, 3), pick(seed, 5));
            // Every third box is flat on one axis (a zero-width slab).
            let mut size = Vec3::new(1.5, 2.0, 1.25);
            if seed % 3 == 0 {
                size[seed / 3 % 3] = 0.0;
            }
            // A wide node's slot, read as the walk reads it.
            let mut node = WideNode::<8>::default();
            let slot = seed % 8;
            node.set_child_bounds(slot, &Aabb::new(lo, lo + size));
            let b = slot_box(&node, slot);
            let mut t_entry = [0f32; LANES];
            // Some lanes left out of the mask (they must not enter).
            let mask = ((1u32 << n) - 1) & !((seed as u32).wrapping_mul(0x9e37_79b9) >> 20);
            let hits = boxes.test(&b, mask, &mut t_entry);
            for (lane, ray) in rays[..n].iter().enumerate() {
                let pre = RayBoxPrecomp::new(ray);
                let single = pre.hit_packed(&b, ray.t_min, ray.t_max + pre.t_margin);
                // The wide single-ray kernels' reference test (`hit`) agrees.
                let (lo, hi) = (lo, lo + size);
                let reference = pre.hit(lo, hi, ray.t_min, ray.t_max + pre.t_margin);
                assert_eq!(
                    single.is_some(),
                    reference.is_some(),
                    "seed {seed}, lane {lane}"
                );
                let entered = hits & (1 << lane) != 0;
                if mask & (1 << lane) == 0 {
                    assert!(!entered, "lane {lane} outside the mask");
                    continue;
                }
                assert_eq!(
                    entered,
                    single.is_some(),
                    "seed {seed}, lane {lane}: {ray:?}"
                );
                match single {
                    Some(t) => {
                        let bits = t_entry[lane].to_bits();
                        assert_eq!(bits, t.to_bits(), "seed {seed}, lane {lane}");
                        entered_both += 1;
                    }
                    None => missed_both += 1,
                }
            }
        }
        assert!(
            entered_both > 1000 && missed_both > 1000,
            "{entered_both} entered, {missed_both} missed"
        );
    }
}
