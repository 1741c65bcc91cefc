//! A wide top-level node's child box against a run's lanes at once, with the packet box
//! kernels ([`PacketBoxTest`]: one AVX-512 vector of 16 lanes, two AVX2 halves, or the scalar
//! reference). A packet reads one octant's near and far plane rows, and a run may mix octants
//! (rays along a tile's edge, shadow rays to an area light), so the run's lanes are grouped by
//! octant: a box is tested once per octant present among the active lanes (mostly one).
//!
//! Each lane's arithmetic is the single-ray test's (`RayBoxPrecomp::hit`, to `t_max` plus
//! `t_margin`), so a lane enters exactly the boxes its single-ray walk enters, at the same
//! entry distance.

use crate::bvh::WideNode;
use crate::geometry::Ray;
use crate::trace::wide::{lanes, PacketBoxTest, PacketRays, WideRay, PACKET_LANES as LANES};

/// The lanes of one octant, as a packet.
struct Group {
    lanes: u32,
    rays: PacketRays,
}

/// Per run: its lanes grouped by octant, and how far each lane's box tests reach. Reused
/// across runs (the groups' storage stays).
pub(super) struct RunBoxes {
    groups: Vec<Group>,
    /// Per lane: its group's index.
    group_of: [u8; LANES],
    /// Per lane: `t_max + t_margin`, lowered with `t_max` by closer hits.
    reach: [f32; LANES],
}

impl RunBoxes {
    pub(super) fn new() -> Self {
        RunBoxes {
            groups: Vec::with_capacity(8),
            group_of: [0; LANES],
            reach: [f32::NEG_INFINITY; LANES],
        }
    }

    /// Sets up the run of `rays` (1 to [`LANES`]).
    #[inline(always)]
    pub(super) fn reset(&mut self, rays: &[Ray]) {
        debug_assert!(!rays.is_empty() && rays.len() <= LANES);
        // Per octant: its lanes, and whether all of them have a fixed octant (no NaN slab).
        let (mut by_octant, mut fixed) = ([0u32; 8], [true; 8]);
        for (lane, ray) in rays.iter().enumerate() {
            let octant = WideRay::<8>::octant(ray);
            by_octant[octant] |= 1 << lane;
            fixed[octant] &= WideRay::<8>::fixed_octant(ray).is_some();
        }
        self.groups.clear();
        for octant in (0..8).filter(|&o| by_octant[o] != 0) {
            for lane in lanes(by_octant[octant]) {
                self.group_of[lane] = self.groups.len() as u8;
            }
            // Lanes of other octants get this octant's plane rows: never tested here.
            let rays = PacketRays::new(rays.iter().copied(), octant, fixed[octant]);
            self.groups.push(Group {
                lanes: by_octant[octant],
                rays,
            });
        }
        for lane in 0..rays.len() {
            self.reach[lane] = self.groups[self.group_of[lane] as usize].rays.t_reach[lane];
        }
    }

    /// The lane's segment now ends at `t_max` (a closer hit).
    #[inline(always)]
    pub(super) fn set_t_max(&mut self, lane: usize, t_max: f32) {
        let rays = &mut self.groups[self.group_of[lane] as usize].rays;
        rays.t_reach[lane] = t_max + rays.t_margin[lane];
        self.reach[lane] = rays.t_reach[lane];
    }

    /// How far the lane's box tests reach.
    #[inline(always)]
    pub(super) fn reach(&self, lane: usize) -> f32 {
        self.reach[lane]
    }

    /// The lanes of `mask` whose box test passes on child `slot` of `node`, each one's entry
    /// in `t_entry` (other lanes' entries are left as any value).
    #[inline(always)]
    pub(super) fn test<P: PacketBoxTest, const N: usize>(
        &self,
        node: &WideNode<N>,
        slot: usize,
        mask: u32,
        t_entry: &mut [f32; LANES],
    ) -> u32 {
        if let [one] = &self.groups[..] {
            return P::test(&one.rays, node, slot, mask, t_entry);
        }
        // Several octants: each group's kernel writes all lanes, so its entries are copied
        // out lane by lane.
        let (mut hits, mut t) = (0, [0f32; LANES]);
        for group in &self.groups {
            let active = mask & group.lanes;
            if active != 0 {
                let entered = P::test(&group.rays, node, slot, active, &mut t);
                for lane in lanes(entered) {
                    t_entry[lane] = t[lane];
                }
                hits |= entered;
            }
        }
        hits
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Aabb, RayBoxPrecomp};
    use crate::trace::wide::ScalarPacket;
    use glam::Vec3;

    /// Values that reach every branch of the slab test: zero and negative-zero directions,
    /// origins on box planes (NaN slabs), boxes behind, around and past the segment.
    const VALUES: [f32; 7] = [-1.0, -0.0, 0.0, 0.25, 0.5, 1.0, 2.0];

    fn pick(seed: usize, k: usize) -> f32 {
        VALUES[(seed / 7usize.pow(k as u32)) % VALUES.len()]
    }

    /// Every kernel the CPU has, compiled with the features it needs.
    fn kernels() -> Vec<(&'static str, Kernel)> {
        let mut out: Vec<(&str, Kernel)> = vec![("scalar", |b, n, s, m, t| {
            b.test::<ScalarPacket, 8>(n, s, m, t)
        })];
        #[cfg(target_arch = "x86_64")]
        {
            use crate::trace::wide::{Avx2Packet, Avx512Packet};
            #[target_feature(enable = "avx2")]
            unsafe fn avx2(b: &RunBoxes, n: &WideNode<8>, s: usize, m: u32, t: &mut T) -> u32 {
                b.test::<Avx2Packet, 8>(n, s, m, t)
            }
            #[target_feature(enable = "avx512f")]
            unsafe fn avx512(b: &RunBoxes, n: &WideNode<8>, s: usize, m: u32, t: &mut T) -> u32 {
                b.test::<Avx512Packet, 8>(n, s, m, t)
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: AVX2 was detected.
                out.push(("avx2", |b, n, s, m, t| unsafe { avx2(b, n, s, m, t) }));
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: AVX-512F was detected.
                out.push(("avx512", |b, n, s, m, t| unsafe { avx512(b, n, s, m, t) }));
            }
        }
        out
    }

    type T = [f32; LANES];
    type Kernel = fn(&RunBoxes, &WideNode<8>, usize, u32, &mut T) -> u32;

    #[test]
    fn lanes_enter_what_their_single_ray_tests_enter_at_the_same_distance() {
        let (mut entered_both, mut missed_both, mut mixed) = (0, 0, 0);
        let kernels = kernels();
        let mut boxes = RunBoxes::new();
        for seed in 0..4000usize {
            // Lanes of mixed octants, rays along axes (zero components of either sign).
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
            boxes.reset(&rays[..n]);
            mixed += (boxes.groups.len() > 1) as u32;
            // Some lanes end earlier, as after a closer hit.
            let mut ends: Vec<Ray> = rays[..n].to_vec();
            for (lane, ray) in ends
                .iter_mut()
                .enumerate()
                .filter(|(l, _)| (l + seed) % 5 == 0)
            {
                ray.t_max = 0.5;
                boxes.set_t_max(lane, 0.5);
            }
            let lo = Vec3::new(pick(seed, 1), pick(seed, 3), pick(seed, 5));
            // Every third box is flat on one axis (a zero-width slab).
            let mut size = Vec3::new(1.5, 2.0, 1.25);
            if seed % 3 == 0 {
                size[seed / 3 % 3] = 0.0;
            }
            let mut node = WideNode::<8>::default();
            let slot = seed % 8;
            node.set_child_bounds(slot, &Aabb::new(lo, lo + size));
            // Some lanes left out of the mask (they must not enter).
            let mask = ((1u32 << n) - 1) & !((seed as u32).wrapping_mul(0x9e37_79b9) >> 20);
            for (name, kernel) in &kernels {
                let mut t_entry = [0f32; LANES];
                let hits = kernel(&boxes, &node, slot, mask, &mut t_entry);
                for (lane, ray) in ends.iter().enumerate() {
                    let pre = RayBoxPrecomp::new(ray);
                    let reach = ray.t_max + pre.t_margin;
                    assert_eq!(boxes.reach(lane).to_bits(), reach.to_bits());
                    let single = pre.hit(lo, lo + size, ray.t_min, reach);
                    let entered = hits & (1 << lane) != 0;
                    if mask & (1 << lane) == 0 {
                        assert!(!entered, "{name}: lane {lane} outside the mask");
                        continue;
                    }
                    let at = format!("{name}: seed {seed}, lane {lane}: {ray:?}");
                    assert_eq!(entered, single.is_some(), "{at}");
                    match single {
                        // Equal values (a zero's sign may differ, which no comparison sees).
                        Some(t) => {
                            assert_eq!(t_entry[lane], t, "{at}");
                            entered_both += 1;
                        }
                        None => missed_both += 1,
                    }
                }
            }
        }
        assert!(
            entered_both > 1000 && missed_both > 1000 && mixed > 1000,
            "{entered_both} entered, {missed_both} missed, {mixed} mixed runs"
        );
    }
}
