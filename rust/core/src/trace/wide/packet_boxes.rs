//! One child box of a wide node against up to [`LANES`] rays at once (SIMD across rays, as
//! Embree's hybrid traversal does): the scalar reference, and AVX-512 (one 16-lane vector) and
//! AVX2 (two 8-lane halves) kernels with its answers bit for bit.
//!
//! Each lane does the arithmetic of [`crate::geometry::RayBoxPrecomp::hit`] in its order:
//! `(plane - origin) * inv_dir` per axis (`inv_dir_far` for far planes), NaN distances replaced
//! by `t_min` / `t_max` through the operand order of `max`/`min` (as the single-ray kernels in
//! `boxes.rs` do), so a ray enters exactly the boxes its single-ray traversal enters.

use crate::bvh::WideNode;
use crate::geometry::{Ray, RayBoxPrecomp};

/// Rays in a packet: 16, one AVX-512 vector (Embree's widest packet).
pub const LANES: usize = 16;

/// A packet's rays as rows of lanes (structure of arrays), all of one octant, so that every
/// lane reads the same near and far plane rows of a node. Lanes past the packet's rays never
/// enter a box (`t_min` = +inf, `t_reach` = -inf).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct PacketRays {
    pub origin: [[f32; LANES]; 3],
    pub inv_dir: [[f32; LANES]; 3],
    pub inv_dir_far: [[f32; LANES]; 3],
    pub t_min: [f32; LANES],
    /// Per lane: how far box tests reach, `t_max + t_margin` (see `RayBoxPrecomp::t_margin`);
    /// a closest-hit traversal lowers it as hits are found.
    pub t_reach: [f32; LANES],
    /// Per lane: `t_margin`, to move `t_reach` with a new `t_max`.
    pub t_margin: [f32; LANES],
    /// Per axis: the row of a node's `bounds` holding the near (far) plane (0..6; read
    /// unchecked by [`PacketRays::plane`], so only `new` sets them).
    near: [usize; 3],
    far: [usize; 3],
    /// No slab distance can be NaN (every lane has a fixed octant, see
    /// `WideRay::fixed_octant`): the kernels may combine the axes in a shallower min/max tree.
    pub no_nan: bool,
}

impl PacketRays {
    /// Child `slot`'s plane in row `row` of a node's `bounds`, `row` one of this packet's
    /// `near` / `far` rows: without the row's bounds check, which the compiler cannot drop
    /// (the rows are data) and which cost a compare and a branch per plane of every child.
    #[inline(always)]
    pub fn plane<const N: usize>(&self, bounds: &[[f32; N]; 6], row: usize, slot: usize) -> f32 {
        debug_assert!(self.near.contains(&row) || self.far.contains(&row));
        // SAFETY: `new` makes every `near` and `far` row in 0..6 and nothing changes them after.
        let plane_row = unsafe { bounds.get_unchecked(row) };
        plane_row[slot]
    }

    /// The packet of `rays` (at most [`LANES`], all of octant `octant`).
    #[inline(always)]
    pub fn new(rays: impl ExactSizeIterator<Item = Ray>, octant: usize, no_nan: bool) -> Self {
        debug_assert!(rays.len() <= LANES && octant < 8);
        let mut p = PacketRays {
            origin: [[0.0; LANES]; 3],
            inv_dir: [[1.0; LANES]; 3],
            inv_dir_far: [[1.0; LANES]; 3],
            t_min: [f32::INFINITY; LANES],
            t_reach: [f32::NEG_INFINITY; LANES],
            t_margin: [0.0; LANES],
            near: [0, 1, 2].map(|a| a + 3 * ((octant >> a) & 1)),
            far: [0, 1, 2].map(|a| a + 3 - 3 * ((octant >> a) & 1)),
            no_nan,
        };
        for (lane, ray) in rays.enumerate() {
            let (inv, far, t_margin) = RayBoxPrecomp::reciprocals(&ray);
            let o = ray.origin;
            for a in 0..3 {
                p.origin[a][lane] = o[a];
                p.inv_dir[a][lane] = inv[a];
                p.inv_dir_far[a][lane] = far[a];
            }
            p.t_min[lane] = ray.t_min;
            p.t_margin[lane] = t_margin;
            p.t_reach[lane] = ray.t_max + t_margin;
        }
        p
    }
}

/// Tests one child box against the lanes of a packet.
pub trait PacketBoxTest {
    /// A packet goes on as single rays once this many of its lanes or fewer are active: below
    /// it, testing a box for the whole packet costs more than the active rays' own tests.
    const SWITCH_TO_SINGLE: u32;

    /// The lanes of `active` whose ray enters child `slot` of `node` within (t_min, t_reach];
    /// each entering lane's entry distance is written to `t_near` (other lanes unspecified).
    fn test<const N: usize>(
        p: &PacketRays,
        node: &WideNode<N>,
        slot: usize,
        active: u32,
        t_near: &mut [f32; LANES],
    ) -> u32;

    /// The lanes of `mask` whose `t_near` is within their reach: those a stacked child may
    /// still matter to.
    #[inline(always)]
    fn within_reach(p: &PacketRays, t_near: &[f32; LANES], mask: u32) -> u32 {
        let mut keep = 0;
        let mut bits = mask;
        while bits != 0 {
            let lane = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            keep |= ((t_near[lane] <= p.t_reach[lane]) as u32) << lane;
        }
        keep
    }
}

/// The reference: [`crate::geometry::RayBoxPrecomp::hit`]'s arithmetic, one lane at a time.
pub struct ScalarPacket;

impl PacketBoxTest for ScalarPacket {
    // One lane at a time: the packet saves only the per-node bookkeeping.
    const SWITCH_TO_SINGLE: u32 = 1;
    #[inline(always)]
    fn test<const N: usize>(
        p: &PacketRays,
        node: &WideNode<N>,
        slot: usize,
        active: u32,
        t_near: &mut [f32; LANES],
    ) -> u32 {
        let b = &node.bounds;
        let mut mask = 0;
        let mut bits = active;
        while bits != 0 {
            let lane = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let near = |a: usize| (b[p.near[a]][slot] - p.origin[a][lane]) * p.inv_dir[a][lane];
            let far = |a: usize| (b[p.far[a]][slot] - p.origin[a][lane]) * p.inv_dir_far[a][lane];
            let tn = near(0).max(near(1)).max(near(2)).max(p.t_min[lane]);
            let tf = far(0).min(far(1)).min(far(2)).min(p.t_reach[lane]);
            if tn <= tf {
                mask |= 1 << lane;
                t_near[lane] = tn;
            }
        }
        mask
    }
}

#[cfg(target_arch = "x86_64")]
pub use x86::{Avx2Packet, Avx512Packet};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;

    use super::super::boxes::slab_interval;
    use super::{PacketBoxTest, PacketRays, LANES};
    use crate::bvh::WideNode;

    /// Entry and exit distances of `lanes` lanes from `from`, for one vector width: a macro so
    /// that every intrinsic inlines into a caller compiled with the features it needs.
    macro_rules! slab {
        ($p:expr, $node:expr, $slot:expr, $from:expr;
         $load:ident, $set1:ident, $sub:ident, $mul:ident, $max:ident, $min:ident) => {{
            let (p, b, slot, from) = ($p, &$node.bounds, $slot, $from);
            // Macros, not closures: a closure is a function of its own, compiled without the
            // caller's target features unless inlined.
            macro_rules! row {
                ($r:expr) => {
                    $load($r.as_ptr().add(from))
                };
            }
            macro_rules! dist {
                ($plane:expr, $a:expr, $inv:expr) => {
                    $mul($sub($set1($plane), row!(p.origin[$a])), row!($inv[$a]))
                };
            }
            macro_rules! near {
                ($a:expr) => {
                    dist!(p.plane(b, p.near[$a], slot), $a, p.inv_dir)
                };
            }
            macro_rules! far {
                ($a:expr) => {
                    dist!(p.plane(b, p.far[$a], slot), $a, p.inv_dir_far)
                };
            }
            let (tmin, tmax) = (row!(p.t_min), row!(p.t_reach));
            slab_interval!(p.no_nan, near, far, tmin, tmax; $max, $min)
        }};
    }

    /// Sixteen lanes in one AVX-512 vector. Only call inside functions compiled with
    /// `avx512f`, after runtime detection.
    pub struct Avx512Packet;

    impl PacketBoxTest for Avx512Packet {
        // One instruction tests 16 lanes, about what a single ray's node test costs.
        const SWITCH_TO_SINGLE: u32 = 3;
        #[inline(always)]
        fn test<const N: usize>(
            p: &PacketRays,
            node: &WideNode<N>,
            slot: usize,
            active: u32,
            t_near: &mut [f32; LANES],
        ) -> u32 {
            // SAFETY: only instantiated inside functions compiled with `avx512f` and called
            // after runtime detection; every load reads one whole 16-lane row of `p`.
            unsafe {
                let (tn, tf) = slab!(
                    p, node, slot, 0;
                    _mm512_loadu_ps, _mm512_set1_ps, _mm512_sub_ps, _mm512_mul_ps,
                    _mm512_max_ps, _mm512_min_ps
                );
                let mask = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(active as __mmask16, tn, tf);
                _mm512_storeu_ps(t_near.as_mut_ptr(), tn);
                mask as u32
            }
        }

        #[inline(always)]
        fn within_reach(p: &PacketRays, t_near: &[f32; LANES], mask: u32) -> u32 {
            // SAFETY: as in `test`.
            unsafe {
                let tn = _mm512_loadu_ps(t_near.as_ptr());
                let reach = _mm512_loadu_ps(p.t_reach.as_ptr());
                _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(mask as __mmask16, tn, reach) as u32
            }
        }
    }

    /// Sixteen lanes as two AVX2 halves. Only call inside functions compiled with `avx2`,
    /// after runtime detection.
    pub struct Avx2Packet;

    impl PacketBoxTest for Avx2Packet {
        // Two halves, each skipped when none of its lanes is active.
        const SWITCH_TO_SINGLE: u32 = 4;
        #[inline(always)]
        fn test<const N: usize>(
            p: &PacketRays,
            node: &WideNode<N>,
            slot: usize,
            active: u32,
            t_near: &mut [f32; LANES],
        ) -> u32 {
            let mut mask = 0;
            for half in [0, 8] {
                if (active >> half) & 0xff == 0 {
                    continue;
                }
                // SAFETY: only instantiated inside functions compiled with `avx2` and called
                // after runtime detection; loads read lanes half..half + 8 of a row.
                unsafe {
                    let (tn, tf) = slab!(
                        p, node, slot, half;
                        _mm256_loadu_ps, _mm256_set1_ps, _mm256_sub_ps, _mm256_mul_ps,
                        _mm256_max_ps, _mm256_min_ps
                    );
                    let hit = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32;
                    _mm256_storeu_ps(t_near.as_mut_ptr().add(half), tn);
                    mask |= (hit << half) & active;
                }
            }
            mask
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::sampling::hash_combine;
    use glam::Vec3;

    fn unit(h: u32) -> f32 {
        (h >> 8) as f32 / (1u32 << 24) as f32
    }

    #[target_feature(enable = "avx512f")]
    unsafe fn avx512(
        p: &PacketRays,
        node: &WideNode<8>,
        s: usize,
        active: u32,
        t: &mut [f32; LANES],
    ) -> u32 {
        Avx512Packet::test(p, node, s, active, t)
    }

    #[target_feature(enable = "avx2")]
    unsafe fn avx2(
        p: &PacketRays,
        node: &WideNode<8>,
        s: usize,
        active: u32,
        t: &mut [f32; LANES],
    ) -> u32 {
        Avx2Packet::test(p, node, s, active, t)
    }

    /// Every lane of every packet kernel enters exactly the boxes the single-ray reference
    /// test enters, with its entry distance bit for bit: random boxes (flat ones among them)
    /// against packets of one octant with zero direction components and origins on planes.
    #[test]
    fn packet_kernels_equal_the_single_ray_reference() {
        let has_avx2 = std::arch::is_x86_feature_detected!("avx2");
        let has_avx512 = std::arch::is_x86_feature_detected!("avx512f");
        let (mut hits, mut cases) = (0, 0);
        for k in 0..3000u32 {
            let r = |i: u32| unit(hash_combine(k, i));
            let mut node = WideNode::<8>::default();
            for s in 0..8u32 {
                let lo = [0, 1, 2].map(|a| 2.0 * r(10 * s + a) - 1.0);
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
            let octant = (k % 8) as usize;
            let sign = |a: usize| if (octant >> a) & 1 == 1 { -1.0 } else { 1.0 };
            let rays: Vec<Ray> = (0..LANES as u32)
                .map(|l| {
                    let q = |i: u32| r(1000 + 20 * l + i);
                    let mut origin =
                        Vec3::new(4.0 * q(0) - 2.0, 4.0 * q(1) - 2.0, 4.0 * q(2) - 2.0);
                    if q(3) < 0.2 {
                        origin.y = node.bounds[1][l as usize % 8];
                    }
                    let mut d = Vec3::new(sign(0) * q(4), sign(1) * q(5), sign(2) * q(6));
                    for a in 0..3 {
                        if q(7 + a as u32) < 0.1 {
                            d[a] = 0.0f32.copysign(sign(a));
                        }
                    }
                    if d.abs().max_element() == 0.0 {
                        d.x = sign(0);
                    }
                    Ray::new(origin, d, 0.0, 10.0)
                })
                .collect();
            let no_nan = rays
                .iter()
                .all(|r| super::super::WideRay::<8>::fixed_octant(r).is_some());
            let p = PacketRays::new(rays.iter().copied(), octant, no_nan);
            let active = hash_combine(k, 77) & 0xffff;
            for s in 0..8 {
                let mut want = [0f32; LANES];
                let expected = ScalarPacket::test(&p, &node, s, active, &mut want);
                // The reference itself against RayBoxPrecomp::hit.
                for (lane, ray) in rays.iter().enumerate() {
                    let pre = RayBoxPrecomp::new(ray);
                    let b = node.child_bounds(s);
                    let single = pre.hit(b.min, b.max, ray.t_min, ray.t_max + pre.t_margin);
                    let on = active & (1 << lane) != 0;
                    assert_eq!(
                        on && single.is_some(),
                        expected & (1 << lane) != 0,
                        "case {k} slot {s} lane {lane}"
                    );
                    if let (true, Some(t)) = (on, single) {
                        assert_eq!(t.to_bits(), want[lane].to_bits());
                    }
                }
                let mut check = |mask: u32, got: [f32; LANES]| {
                    assert_eq!(mask, expected, "case {k} slot {s}");
                    // Equal values; a zero distance's sign may differ when NaN-free lanes take
                    // the shallower min/max tree, and no comparison sees it.
                    for lane in (0..LANES).filter(|l| expected & (1 << l) != 0) {
                        assert_eq!(got[lane], want[lane], "case {k} slot {s} lane {lane}");
                    }
                    cases += 1;
                };
                let mut t = [0f32; LANES];
                if has_avx2 {
                    // SAFETY: AVX2 was detected.
                    check(unsafe { avx2(&p, &node, s, active, &mut t) }, t);
                }
                if has_avx512 {
                    // SAFETY: AVX-512F was detected.
                    check(unsafe { avx512(&p, &node, s, active, &mut t) }, t);
                }
                hits += expected.count_ones();
            }
        }
        assert!(hits > 2000, "{hits} lane hits");
        assert!(cases > 0 || !has_avx2);
    }
}
