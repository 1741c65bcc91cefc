//! One run of up to [`LANES`] rays walking the wide top level together: a lane mask per child
//! entered, each used slot of a node tested across the run's active lanes ([`RunBoxes`]), the
//! children entered in the walk's order (near to far for closest hits; for any hits the top
//! level's order, a permutation or near to far) for the lowest lane entering any (a lone ray's
//! own order), the others stacked with their lanes' entries and culled per lane as the
//! single-ray walk culls.

use crate::bvh::{WideNode, EMPTY_CHILD};
use crate::geometry::{Ray, RayBoxPrecomp};
use crate::order::ChildOrder;
use crate::trace::wide::{in_order, lanes, PacketBoxTest, PACKET_LANES as LANES};
use crate::trace::Counters;

use super::run_boxes::RunBoxes;
use super::top_level::TOP_WIDTH as WIDTH;
use super::TopLevel;

/// One run's rays and what their walk keeps per lane.
pub(super) struct Run<'r> {
    pub(super) rays: &'r [Ray],
    boxes: &'r mut RunBoxes,
    /// Per lane: the segment's end, lowered by closest hits.
    pub(super) t_max: [f32; LANES],
    /// Lanes answered (occluded): they enter nothing more.
    pub(super) done: u32,
}

impl<'r> Run<'r> {
    /// `rays` holds 1 to [`LANES`] rays; `boxes` is set up for them.
    #[inline(always)]
    pub(super) fn new(rays: &'r [Ray], boxes: &'r mut RunBoxes) -> Self {
        boxes.reset(rays);
        let last = rays.len() - 1;
        Run {
            rays,
            boxes,
            t_max: std::array::from_fn(|i| rays[i.min(last)].t_max),
            done: 0,
        }
    }

    #[inline(always)]
    fn all(&self) -> u32 {
        ((1u64 << self.rays.len()) - 1) as u32
    }

    /// The lane's segment now ends at a closer hit's `t`.
    #[inline(always)]
    pub(super) fn lower(&mut self, lane: usize, t: f32) {
        self.t_max[lane] = t;
        self.boxes.set_t_max(lane, t);
    }

    /// The lanes entering the root box, each counting it (as the single-ray walk counts it);
    /// every lane when not counting, where the root node's test rejects the same rays.
    #[inline(always)]
    fn entering_root<C: Counters>(&self, top: &TopLevel, counters: &mut [C]) -> u32 {
        if !C::COUNTING {
            return self.all();
        }
        let r = &top.bvh.root_bounds;
        let mut valid = 0;
        for (lane, ray) in self.rays.iter().enumerate() {
            counters[lane].boxes(1);
            let pre = RayBoxPrecomp::new(ray);
            let entered = pre.hit(r.min, r.max, ray.t_min, ray.t_max + pre.t_margin);
            valid |= (entered.is_some() as u32) << lane;
        }
        valid
    }

    /// The lanes of `entry` still to enter it when it comes off the stack: not answered, and
    /// entering it before their (perhaps lowered) `t_max` plus margin, the single-ray cull.
    #[inline(always)]
    fn still_entering(&self, entry: &Stacked) -> u32 {
        let mut live = 0;
        for lane in lanes(entry.mask & !self.done) {
            live |= ((entry.t_entry[lane] <= self.boxes.reach(lane)) as u32) << lane;
        }
        live
    }
}

/// A top-level child: a node's index (`count` 0) or a leaf's first instance and size.
#[derive(Clone, Copy)]
struct Child {
    index: u32,
    count: u32,
}

impl Child {
    const ROOT: Child = Child { index: 0, count: 0 };

    #[inline(always)]
    fn of(node: &WideNode<WIDTH>, slot: usize) -> Self {
        Child {
            index: node.child[slot],
            count: node.count[slot] as u32,
        }
    }
}

/// A top-level child waiting on the stack: the lanes that entered it and where.
#[derive(Clone, Copy)]
pub(super) struct Stacked {
    child: Child,
    mask: u32,
    t_entry: [f32; LANES],
}

/// Counts `f` into the counters of the lanes of `mask`.
#[inline(always)]
fn count<C: Counters>(mask: u32, counters: &mut [C], f: impl Fn(&mut C)) {
    if C::COUNTING {
        for lane in lanes(mask) {
            f(&mut counters[lane]);
        }
    }
}

/// Walks the top level once for `run` with the box kernel `P`, each node's children in `order`,
/// handing each entered leaf's range (`first`, `count`) to `leaf` with the lanes in it.
/// `counters[lane]` is the lane's ray's. Stops when every lane that entered the root is done.
#[inline(always)]
pub(super) fn walk_run<P: PacketBoxTest, O: ChildOrder, C: Counters>(
    top: &TopLevel,
    order: &O,
    run: &mut Run,
    counters: &mut [C],
    stack: &mut Vec<Stacked>,
    mut leaf: impl FnMut(usize, usize, u32, &mut Run, &mut [C]),
) {
    let nodes = &top.bvh.nodes;
    if nodes.is_empty() {
        return;
    }
    let valid = run.entering_root(top, counters);
    stack.clear();
    let mut at = (valid != 0).then_some((Child::ROOT, valid));
    while let Some((child, active)) = at.or_else(|| next_stacked(stack, run)) {
        if child.count > 0 {
            count(active, counters, |c| c.leaf());
            leaf(
                child.index as usize,
                child.count as usize,
                active,
                run,
                counters,
            );
            if valid & !run.done == 0 {
                return;
            }
            at = None;
        } else {
            let node = &nodes[child.index as usize];
            if C::COUNTING {
                let arity = node.arity() as u32;
                count(active, counters, |c| {
                    c.inner();
                    c.boxes(arity);
                });
            }
            at = enter_children::<P, O>(order, child.index as usize, node, active, run, stack);
        }
    }
}

/// The children of node `index` the lanes of `active` enter: the one to go on with and its
/// lanes (`None`: none), the others stacked with their lanes' entries. The order is the
/// single-ray walk's (`order`: near to far with equal entries by slot, or a permutation) for
/// the lowest lane entering any child; the children that lane misses are stacked below, to
/// come last.
#[inline(always)]
fn enter_children<P: PacketBoxTest, O: ChildOrder>(
    order: &O,
    index: usize,
    node: &WideNode<WIDTH>,
    active: u32,
    run: &Run,
    stack: &mut Vec<Stacked>,
) -> Option<(Child, u32)> {
    let mut masks = [0u32; WIDTH];
    let mut t_entry = [[0f32; LANES]; WIDTH];
    let mut entered = 0;
    for slot in 0..WIDTH {
        if node.child[slot] == EMPTY_CHILD {
            continue;
        }
        masks[slot] = run
            .boxes
            .test::<P, WIDTH>(node, slot, active, &mut t_entry[slot]);
        entered |= masks[slot];
    }
    if entered == 0 {
        return None;
    }
    let key = entered.trailing_zeros() as usize;
    let (mut keyed, mut key_t) = (0u32, [0f32; WIDTH]);
    for slot in 0..WIDTH {
        keyed |= ((masks[slot] >> key) & 1) << slot;
        key_t[slot] = t_entry[slot][key];
    }
    let push = |stack: &mut Vec<Stacked>, slot: usize| {
        stack.push(Stacked {
            child: Child::of(node, slot),
            mask: masks[slot],
            t_entry: t_entry[slot],
        })
    };
    for slot in (0..WIDTH).rev() {
        if masks[slot] != 0 && keyed & (1 << slot) == 0 {
            push(stack, slot);
        }
    }
    let mut visit = [0u8; WIDTH];
    let n = in_order(order, index, node, keyed, &key_t, &mut visit);
    for &slot in visit[1..n].iter().rev() {
        push(stack, slot as usize);
    }
    let first = visit[0] as usize;
    Some((Child::of(node, first), masks[first]))
}

/// The next stacked child some lane may still hold a closer (or equal) hit in, and those lanes.
#[inline(always)]
fn next_stacked(stack: &mut Vec<Stacked>, run: &Run) -> Option<(Child, u32)> {
    while let Some(entry) = stack.pop() {
        let live = run.still_entering(&entry);
        if live != 0 {
            return Some((entry.child, live));
        }
    }
    None
}
