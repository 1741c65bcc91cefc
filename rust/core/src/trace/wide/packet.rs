//! Packet traversal of the wide BVH (Embree's hybrid scheme): up to [`LANES`] rays of one
//! octant walk the tree together, each child box tested against every active ray at once
//! (SIMD across rays); a child is entered by the lanes that hit it, and once few lanes remain
//! active (`PacketBoxTest::SWITCH_TO_SINGLE`) each goes on alone with the single-ray traversal from that
//! node. Leaves are tested per active lane with the single-ray leaf test.
//!
//! Answers equal the single-ray traversal's bit for bit: every lane's box test is the single-ray
//! test's arithmetic, so a ray enters exactly the boxes it would enter alone, and its leaf tests
//! are the same function. Work is counted per ray: a ray counts a node, its boxes and a leaf
//! where it is active in its packet.

use super::any_hit::{any_hit_from, leaf_occludes, near_to_far, ChildRef, WideChildren};
use super::boxes::ChildBoxTest;
use super::closest::{closest_from, closest_in_leaf};
use super::packet_boxes::{PacketBoxTest, PacketRays, LANES};
use std::mem::MaybeUninit;

use super::stack::Stack;
use crate::bvh::{WideBvh, EMPTY_CHILD};
use crate::geometry::{Ray, RayBoxPrecomp, WatertightRay};
use crate::order::{ChildOrder, OrderRay};
use crate::trace::{Counters, Hit};

/// Iterates the set bits of a lane mask, lowest first.
#[inline(always)]
pub(crate) fn lanes(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let lane = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            lane
        })
    })
}

/// One packet: its rays (lane i is `rays[index[i]]`) and where their answers go.
pub(crate) struct Packet<'a> {
    pub rays: &'a [Ray],
    pub index: &'a [u32],
    pub octant: usize,
    /// Every ray's octant is fixed (see `WideRay::fixed_octant`): the `OCT` instance may run.
    pub no_nan: bool,
}

impl Packet<'_> {
    #[inline(always)]
    fn ray(&self, lane: usize) -> &Ray {
        &self.rays[self.index[lane] as usize]
    }
    #[inline(always)]
    fn lanes(&self) -> PacketRays {
        PacketRays::new(
            self.index.iter().map(|&i| self.rays[i as usize]),
            self.octant,
            self.no_nan,
        )
    }
    /// The lanes whose ray enters the root box, each counting that box (as the single-ray
    /// traversal counts it); every lane when not counting, where the root node's test rejects
    /// the same rays.
    #[inline(always)]
    fn entering_root<const N: usize, C: Counters>(
        &self,
        bvh: &WideBvh<N>,
        counters: &mut [C],
    ) -> u32 {
        let all = (1u32 << self.index.len()) - 1;
        if !C::COUNTING {
            return all;
        }
        let r = &bvh.root_bounds;
        lanes(all)
            .filter(|&lane| {
                let ray = self.ray(lane);
                counters[self.index[lane] as usize].boxes(1);
                let pre = RayBoxPrecomp::new(ray);
                pre.hit(r.min, r.max, ray.t_min, ray.t_max + pre.t_margin)
                    .is_some()
            })
            .fold(0, |m, lane| m | 1 << lane)
    }
}

/// Each lane's triangle-test set-up, made at its first leaf (many shadow rays reach none).
struct LaneTriangleRays {
    made: u32,
    rays: [MaybeUninit<WatertightRay>; LANES],
}

impl LaneTriangleRays {
    #[inline(always)]
    fn new() -> Self {
        LaneTriangleRays {
            made: 0,
            rays: [MaybeUninit::uninit(); LANES],
        }
    }
    #[inline(always)]
    fn get(&mut self, lane: usize, ray: &Ray) -> &WatertightRay {
        if self.made & (1 << lane) == 0 {
            self.rays[lane].write(WatertightRay::new(ray));
            self.made |= 1 << lane;
        }
        // SAFETY: lane `lane` was written above or at an earlier call (its bit is set).
        unsafe { self.rays[lane].assume_init_ref() }
    }
}

/// The lanes of `active` counting an interior node.
#[inline(always)]
fn count_node<C: Counters>(packet: &Packet, active: u32, arity: u32, counters: &mut [C]) {
    if C::COUNTING {
        for lane in lanes(active) {
            let c = &mut counters[packet.index[lane] as usize];
            c.inner();
            c.boxes(arity);
        }
    }
}

/// The children of `node` the lanes of `active` enter: per slot its lanes and each lane's
/// entry distance (`t_lanes[slot]`). Returns the mask of slots entered.
#[inline(always)]
fn enter_children<const N: usize, P: PacketBoxTest>(
    p: &PacketRays,
    node: &crate::bvh::WideNode<N>,
    active: u32,
    masks: &mut [u32; N],
    t_lanes: &mut [[f32; LANES]; N],
) -> u32 {
    let mut slots = 0;
    for s in 0..N {
        if node.child[s] == EMPTY_CHILD {
            continue;
        }
        let m = P::test(p, node, s, active, &mut t_lanes[s]);
        masks[s] = m;
        slots |= ((m != 0) as u32) << s;
    }
    slots
}

/// Each entered slot's distance for ordering children: its lowest lane's entry (as Embree's
/// packets, no reduction over the lanes; any key gives the same answers).
#[inline(always)]
fn slot_keys<const N: usize>(
    slots: u32,
    masks: &[u32; N],
    t_lanes: &[[f32; LANES]; N],
    keys: &mut [f32; N],
) {
    for s in lanes(slots) {
        keys[s] = t_lanes[s][masks[s].trailing_zeros() as usize];
    }
}

/// Any hit for the rays of `packet`: `out[index[i]]` is set when lane i is occluded.
/// `K` is the single-ray kernel the lanes go on with, `P` the packet's box test, `OCT` the
/// packet's octant or `ANY_OCTANT`.
#[inline(always)]
pub(crate) fn occluded_packet<
    const N: usize,
    K: ChildBoxTest<N>,
    P: PacketBoxTest,
    O: ChildOrder,
    C: Counters,
    const OCT: usize,
>(
    bvh: &WideBvh<N>,
    packet: &Packet,
    order: &O,
    out: &mut [bool],
    counters: &mut [C],
) {
    if bvh.nodes.is_empty() || packet.index.is_empty() {
        return;
    }
    let p = packet.lanes();
    let valid = packet.entering_root(bvh, counters);
    let mut occluded = 0u32;
    let mut wts = LaneTriangleRays::new();
    // The order reads one ray: the packet's first (all share an octant, and per-light orders
    // key on the light, not the ray).
    let oray = OrderRay::new::<O>(packet.ray(0));
    let mut stack = Stack::<(ChildRef, u32)>::new();
    stack.push((ChildRef::ROOT, valid));
    let (mut masks, mut keys, mut t_lanes) = ([0u32; N], [0f32; N], [[0f32; LANES]; N]);
    let (mut steps, mut to_single) = (0u32, 0u32);
    'pop: while let Some((mut current, mask)) = stack.pop() {
        let mut active = mask & !occluded;
        loop {
            if active == 0 {
                continue 'pop;
            }
            if active.count_ones() <= P::SWITCH_TO_SINGLE {
                to_single += active.count_ones();
                for lane in lanes(active) {
                    let i = packet.index[lane] as usize;
                    let ray = packet.ray(lane);
                    if any_hit_from::<N, K, O, C, OCT>(bvh, ray, current, order, &mut counters[i])
                        .is_some()
                    {
                        occluded |= 1 << lane;
                    }
                }
                break;
            }
            if current.count > 0 {
                let (first, count) = (current.child as usize, current.count as usize);
                for lane in lanes(active) {
                    let i = packet.index[lane] as usize;
                    let c = &mut counters[i];
                    c.leaf();
                    let ray = packet.ray(lane);
                    let wt = wts.get(lane, ray);
                    if leaf_occludes::<N, K, C>(bvh, wt, ray, first, count, c) {
                        occluded |= 1 << lane;
                    }
                }
                break;
            }
            let index = current.child as usize;
            let node = &bvh.nodes[index];
            steps += 1;
            count_node(packet, active, node.arity() as u32, counters);
            let slots = enter_children::<N, P>(&p, node, active, &mut masks, &mut t_lanes);
            if slots == 0 {
                break;
            }
            let r = |s: u8| ChildRef {
                child: node.child[s as usize],
                count: node.count[s as usize] as u32,
            };
            if slots & (slots - 1) == 0 {
                // One child entered (most steps): no order to read.
                let s = slots.trailing_zeros() as u8;
                current = r(s);
                active = masks[s as usize] & !occluded;
                continue;
            }
            slot_keys(slots, &masks, &t_lanes, &mut keys);
            let mut visit = [0u8; N];
            let children = WideChildren {
                t_near: &keys,
                node,
            };
            let hits = order.ordered_hits(index, slots, &oray, &children, &mut visit);
            for &s in visit[1..hits].iter().rev() {
                stack.push((r(s), masks[s as usize]));
            }
            current = r(visit[0]);
            active = masks[visit[0] as usize] & !occluded;
        }
        if occluded == valid {
            break;
        }
    }
    counters[packet.index[0] as usize].packet(steps, to_single);
    for lane in lanes(occluded) {
        out[packet.index[lane] as usize] = true;
    }
}

/// A stacked child of the closest-hit traversal: its lanes and their entry distances.
#[derive(Clone, Copy)]
struct ClosestEntry {
    child: ChildRef,
    mask: u32,
    t_near: [f32; LANES],
}

/// Closest hits for the rays of `packet`: `out[index[i]]` is lane i's closest hit (ties by the
/// smaller triangle id). Children are visited near to far by their nearest lane's entry.
#[inline(always)]
pub(crate) fn closest_packet<
    const N: usize,
    K: ChildBoxTest<N>,
    P: PacketBoxTest,
    C: Counters,
    const OCT: usize,
>(
    bvh: &WideBvh<N>,
    packet: &Packet,
    out: &mut [Option<Hit>],
    counters: &mut [C],
) {
    if bvh.nodes.is_empty() || packet.index.is_empty() {
        return;
    }
    let mut p = packet.lanes();
    let valid = packet.entering_root(bvh, counters);
    let mut best: [Option<Hit>; LANES] = [None; LANES];
    let mut wts = LaneTriangleRays::new();
    let mut stack = Stack::<ClosestEntry>::new();
    stack.push(ClosestEntry {
        child: ChildRef::ROOT,
        mask: valid,
        t_near: p.t_min,
    });
    let (mut masks, mut keys, mut t_lanes) = ([0u32; N], [0f32; N], [[0f32; LANES]; N]);
    let (mut steps, mut to_single) = (0u32, 0u32);
    while let Some(entry) = stack.pop() {
        // Lanes whose closest hit so far lies before the child's entry need not go in.
        let mut active = P::within_reach(&p, &entry.t_near, entry.mask);
        let mut current = entry.child;
        loop {
            if active == 0 {
                break;
            }
            if active.count_ones() <= P::SWITCH_TO_SINGLE {
                to_single += active.count_ones();
                for lane in lanes(active) {
                    let i = packet.index[lane] as usize;
                    let ray = packet.ray(lane);
                    best[lane] = closest_from::<N, K, C, OCT>(
                        bvh,
                        ray,
                        current,
                        best[lane],
                        &mut counters[i],
                    );
                    if let Some(h) = best[lane] {
                        p.t_reach[lane] = h.t + p.t_margin[lane];
                    }
                }
                break;
            }
            if current.count > 0 {
                for lane in lanes(active) {
                    let i = packet.index[lane] as usize;
                    let ray = packet.ray(lane);
                    let wt = wts.get(lane, ray);
                    leaf_closest::<N, K, C>(
                        bvh,
                        wt,
                        ray,
                        current,
                        &mut best[lane],
                        &mut counters[i],
                    );
                    if let Some(h) = best[lane] {
                        p.t_reach[lane] = h.t + p.t_margin[lane];
                    }
                }
                break;
            }
            let node = &bvh.nodes[current.child as usize];
            steps += 1;
            count_node(packet, active, node.arity() as u32, counters);
            let slots = enter_children::<N, P>(&p, node, active, &mut masks, &mut t_lanes);
            if slots == 0 {
                break;
            }
            if slots & (slots - 1) == 0 {
                let s = slots.trailing_zeros() as usize;
                current = ChildRef {
                    child: node.child[s],
                    count: node.count[s] as u32,
                };
                active = masks[s];
                continue;
            }
            slot_keys(slots, &masks, &t_lanes, &mut keys);
            let mut visit = [0u8; N];
            let hits = near_to_far(node, slots, &keys, &mut visit);
            let r = |s: u8| ChildRef {
                child: node.child[s as usize],
                count: node.count[s as usize] as u32,
            };
            for &s in visit[1..hits].iter().rev() {
                stack.push(ClosestEntry {
                    child: r(s),
                    mask: masks[s as usize],
                    t_near: t_lanes[s as usize],
                });
            }
            current = r(visit[0]);
            active = masks[visit[0] as usize];
        }
    }
    counters[packet.index[0] as usize].packet(steps, to_single);
    for lane in lanes(valid) {
        out[packet.index[lane] as usize] = best[lane];
    }
}

/// One lane's leaf step, counted as the single-ray traversal counts it.
#[inline(always)]
fn leaf_closest<const N: usize, K: ChildBoxTest<N>, C: Counters>(
    bvh: &WideBvh<N>,
    wt: &WatertightRay,
    ray: &Ray,
    leaf: ChildRef,
    best: &mut Option<Hit>,
    stats: &mut C,
) {
    stats.leaf();
    stats.triangles(leaf.count);
    let mut t_max = best.map_or(ray.t_max, |b| b.t);
    let (first, count) = (leaf.child as usize, leaf.count as usize);
    closest_in_leaf::<N, K>(bvh, wt, ray.t_min, first, count, &mut t_max, best);
}

/// Splits `rays` into packets: each run of [`LANES`] consecutive rays (the passes order a
/// tile's rays so that these are neighbours) becomes one packet per octant present in it.
#[inline]
pub(crate) fn each_packet(rays: &[Ray], mut f: impl FnMut(&Packet)) {
    for (chunk, group) in rays.chunks(LANES).enumerate() {
        let base = (chunk * LANES) as u32;
        let mut octants = [0usize; LANES];
        for (o, r) in octants.iter_mut().zip(group) {
            *o = super::WideRay::<8>::octant(r);
        }
        let mut left = (1u32 << group.len()) - 1;
        while left != 0 {
            let octant = octants[left.trailing_zeros() as usize];
            let mut index = [0u32; LANES];
            let (mut n, mut no_nan) = (0, true);
            for lane in lanes(left) {
                if octants[lane] == octant {
                    index[n] = base + lane as u32;
                    n += 1;
                    no_nan &= super::WideRay::<8>::fixed_octant(&group[lane]).is_some();
                    left &= !(1 << lane);
                }
            }
            f(&Packet {
                rays,
                index: &index[..n],
                octant,
                no_nan,
            });
        }
    }
}
