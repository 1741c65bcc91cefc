//! Batches through the top level in runs: each run of [`LANES`] consecutive rays (the passes
//! order a tile's rays so these are neighbours, as the packet kernel's `each_packet` reads
//! them) walks the wide top level once, a lane mask per child entered: each used slot of a
//! node is tested across the run's lanes ([`LaneBoxes`]; the run mixes octants, so each lane
//! reads its own near and far planes). At each instance reached, the
//! active lanes' rays are mapped into mesh space and traced together by the mesh query's own
//! batch method, so a mesh tree's packets (re-split there by octant) see the run's coherence.
//!
//! Answers equal the single-ray walk's ([`TwoLevel`]'s `occluded` and `closest_hit`) and the
//! brute-force reference's bit for bit: a lane enters a node only when its own single-ray box
//! test (`RayBoxPrecomp::hit_packed`'s arithmetic, to its `t_max` plus `t_margin`; run across
//! lanes by [`LaneBoxes`]) passes, a stacked node is
//! culled per lane as the single-ray walk culls it, and closest hits keep the (t, object,
//! triangle) rule of [`closer`], which no visiting order changes.
//!
//! Counters stay per ray, as the wide trees count: a ray counts the root's box, and an interior
//! node (and a box test per used slot) or a leaf slot wherever it is active in its run; the
//! mesh query counts into the ray's counters as its batch method counts. The children are
//! entered near to far by the lowest lane entering any, which is a lone ray's own order; a
//! ray in a larger run may enter them in another order, so its counts (not its answers) may
//! differ from the single-ray walk's.

use crate::bvh::{WideNode, EMPTY_CHILD, MAX_DEPTH};
use crate::geometry::Ray;
use crate::trace::wide::{lanes, near_to_far, PACKET_LANES as LANES};
use crate::trace::{closest_hit_each, occluded_each, Counters, Hit, RayQuery};
use glam::Vec3;

use super::lane_boxes::{packed, slot_box, LaneBoxes};
use super::top_level::{closer, TwoLevel, TOP_WIDTH as WIDTH};
use super::Instance;

/// At most this many rays reaching an instance trace its mesh one at a time: a packet's set-up
/// costs more than it saves there (the packet kernels go on alone below 2 to 5 lanes).
const FEW: usize = 4;

/// One run's rays and what their walk keeps per lane.
struct Run<'r> {
    rays: &'r [Ray],
    boxes: LaneBoxes,
    /// Per lane: the segment's end, lowered by closest hits.
    t_max: [f32; LANES],
    /// Lanes answered (occluded): they enter nothing more.
    done: u32,
}

impl<'r> Run<'r> {
    /// `rays` holds 1 to [`LANES`] rays.
    #[inline(always)]
    fn new(rays: &'r [Ray]) -> Self {
        let last = rays.len() - 1;
        Run {
            rays,
            boxes: LaneBoxes::new(rays),
            t_max: std::array::from_fn(|i| rays[i.min(last)].t_max),
            done: 0,
        }
    }

    #[inline(always)]
    fn all(&self) -> u32 {
        ((1u64 << self.rays.len()) - 1) as u32
    }

    /// The lanes of `mask` entering box `b` ([`packed`]) as their single-ray tests do (to
    /// `t_max` plus margin), each lane's entry in `t_entry`.
    #[inline(always)]
    fn entering(&self, mask: u32, b: &[f32; 8], t_entry: &mut [f32; LANES]) -> u32 {
        self.boxes.test(b, mask, t_entry)
    }

    /// The lane's segment now ends at a closer hit's `t`.
    #[inline(always)]
    fn lower(&mut self, lane: usize, t: f32) {
        self.t_max[lane] = t;
        self.boxes.set_t_max(lane, t);
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
struct Stacked {
    child: Child,
    mask: u32,
    t_entry: [f32; LANES],
}

/// The active lanes' rays in an instance's mesh space: the small batch a mesh query traces.
struct Local<C> {
    rays: [Ray; LANES],
    /// The run lane of each local ray.
    lane: [u8; LANES],
    counters: [C; LANES],
    occluded: [bool; LANES],
    hits: [Option<Hit>; LANES],
    len: usize,
}

impl<C: Counters> Local<C> {
    fn new() -> Self {
        Local {
            rays: [Ray::new(Vec3::ZERO, Vec3::ZERO, 0.0, 0.0); LANES],
            lane: [0; LANES],
            counters: [C::default(); LANES],
            occluded: [false; LANES],
            hits: [None; LANES],
            len: 0,
        }
    }

    /// The rays of the lanes of `mask` through `instance`, each to the lane's current `t_max`
    /// (its best hit so far for closest hits), with fresh counters.
    #[inline(always)]
    fn gather(&mut self, run: &Run, instance: &Instance, mask: u32) {
        self.len = 0;
        for lane in lanes(mask) {
            let k = self.len;
            self.rays[k] = Ray {
                t_max: run.t_max[lane],
                ..instance.ray_to_mesh(&run.rays[lane])
            };
            self.lane[k] = lane as u8;
            self.counters[k] = C::default();
            self.len += 1;
        }
    }

    /// Any hit for the gathered rays through `mesh`: as one batch, or one ray at a time when
    /// they are [`FEW`].
    #[inline(always)]
    fn occluded_in<Q: RayQuery>(&mut self, mesh: &Q) {
        let k = self.len;
        let (rays, out, counters) = (
            &self.rays[..k],
            &mut self.occluded[..k],
            &mut self.counters[..k],
        );
        if k <= FEW {
            occluded_each(mesh, rays, out, counters);
        } else {
            mesh.occluded_batch(rays, out, counters);
        }
    }

    /// Closest hits for the gathered rays through `mesh`, as [`Self::occluded_in`].
    #[inline(always)]
    fn closest_in<Q: RayQuery>(&mut self, mesh: &Q) {
        let k = self.len;
        let (rays, out, counters) = (
            &self.rays[..k],
            &mut self.hits[..k],
            &mut self.counters[..k],
        );
        if k <= FEW {
            closest_hit_each(mesh, rays, out, counters);
        } else {
            mesh.closest_hit_batch(rays, out, counters);
        }
    }

    /// Adds the mesh query's counts back into the run's counters.
    #[inline(always)]
    fn count_back(&self, counters: &mut [C]) {
        if C::COUNTING {
            for k in 0..self.len {
                counters[self.lane[k] as usize] += self.counters[k];
            }
        }
    }
}

/// What a run's walk reuses across runs: the stack and the local batch.
struct Scratch<C> {
    stack: Vec<Stacked>,
    local: Local<C>,
}

impl<C: Counters> Scratch<C> {
    fn new() -> Self {
        Scratch {
            // A node stacks at most WIDTH - 1 children per level.
            stack: Vec::with_capacity((WIDTH - 1) * MAX_DEPTH + 1),
            local: Local::new(),
        }
    }
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

/// Walks the top level once for `run`, near child first by the lowest lane entering any,
/// handing each entered leaf's range (`first`, `count`) to `leaf` with the lanes in it.
/// `counters[lane]` is the lane's ray's. Stops when every lane that entered the root is done.
#[inline(always)]
fn walk_run<C: Counters>(
    top: &super::TopLevel,
    run: &mut Run,
    counters: &mut [C],
    stack: &mut Vec<Stacked>,
    mut leaf: impl FnMut(usize, usize, u32, &mut Run, &mut [C]),
) {
    let nodes = &top.bvh.nodes;
    if nodes.is_empty() {
        return;
    }
    count(run.all(), counters, |c| c.boxes(1));
    let root_box = packed(&top.bvh.root_bounds);
    let valid = run.entering(run.all(), &root_box, &mut [0f32; LANES]);
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
            at = enter_children(node, active, run, stack);
        }
    }
}

/// The children of `node` the lanes of `active` enter: the one to go on with and its lanes
/// (`None`: none), the others stacked with their lanes' entries. The order is the single-ray
/// walk's (near to far, equal entries by slot) for the lowest lane entering any child; the
/// children that lane misses are stacked below, to come last.
#[inline(always)]
fn enter_children(
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
        masks[slot] = run.entering(active, &slot_box(node, slot), &mut t_entry[slot]);
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
    let mut order = [0u8; WIDTH];
    let n = near_to_far(node, keyed, &key_t, &mut order);
    for &slot in order[1..n].iter().rev() {
        push(stack, slot as usize);
    }
    let near = order[0] as usize;
    Some((Child::of(node, near), masks[near]))
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

/// `TwoLevel::occluded_batch`: any hit per ray, in runs of [`LANES`].
pub(super) fn occluded_runs<Q: RayQuery, C: Counters>(
    q: &TwoLevel<Q>,
    rays: &[Ray],
    out: &mut [bool],
    counters: &mut [C],
) {
    debug_assert!(out.len() == rays.len() && counters.len() == rays.len());
    out.fill(false);
    let mut scratch = Scratch::<C>::new();
    let runs = rays.chunks(LANES).zip(out.chunks_mut(LANES));
    for ((run_rays, out), counters) in runs.zip(counters.chunks_mut(LANES)) {
        let mut run = Run::new(run_rays);
        let local = &mut scratch.local;
        let leaf = |first: usize, n: usize, active: u32, run: &mut Run, counters: &mut [C]| {
            for instance in &q.top.instances[first..first + n] {
                let live = active & !run.done;
                if live == 0 {
                    return;
                }
                local.gather(run, instance, live);
                local.occluded_in(&q.meshes[instance.mesh as usize]);
                local.count_back(counters);
                let k = local.len;
                for (&lane, &occluded) in local.lane[..k].iter().zip(&local.occluded[..k]) {
                    run.done |= (occluded as u32) << lane;
                }
            }
        };
        walk_run(q.top, &mut run, counters, &mut scratch.stack, leaf);
        for lane in lanes(run.done) {
            out[lane] = true;
        }
    }
}

/// `TwoLevel::closest_hit_batch`: the closest hit per ray by (t, object, triangle), in runs of
/// [`LANES`].
pub(super) fn closest_runs<Q: RayQuery, C: Counters>(
    q: &TwoLevel<Q>,
    rays: &[Ray],
    out: &mut [Option<Hit>],
    counters: &mut [C],
) {
    debug_assert!(out.len() == rays.len() && counters.len() == rays.len());
    out.fill(None);
    let mut scratch = Scratch::<C>::new();
    let runs = rays.chunks(LANES).zip(out.chunks_mut(LANES));
    for ((run_rays, out), counters) in runs.zip(counters.chunks_mut(LANES)) {
        let mut run = Run::new(run_rays);
        let local = &mut scratch.local;
        let leaf = |first: usize, n: usize, active: u32, run: &mut Run, counters: &mut [C]| {
            for instance in &q.top.instances[first..first + n] {
                local.gather(run, instance, active);
                local.closest_in(&q.meshes[instance.mesh as usize]);
                local.count_back(counters);
                let k = local.len;
                for (&lane, hit) in local.lane[..k].iter().zip(&local.hits[..k]) {
                    keep_closer(hit, instance, lane as usize, run, out);
                }
            }
        };
        walk_run(q.top, &mut run, counters, &mut scratch.stack, leaf);
    }
}

/// Keeps a mesh's hit for `lane` where it is closer by (t, object, triangle) than the lane's
/// best, and lowers the lane's `t_max` to it.
#[inline(always)]
fn keep_closer(
    hit: &Option<Hit>,
    instance: &Instance,
    lane: usize,
    run: &mut Run,
    best: &mut [Option<Hit>],
) {
    let Some(mut h) = *hit else {
        return;
    };
    h.instance = instance.object;
    if closer(&h, &best[lane]) {
        best[lane] = Some(h);
        run.lower(lane, h.t);
    }
}
