//! Batches through the top level in runs: each run of [`LANES`] consecutive rays (the passes
//! order a tile's rays so these are neighbours, as the packet kernel's `each_packet` reads
//! them) walks the binary top level once, a lane mask per node. At each instance reached, the
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
//! Counters stay per ray: a ray counts the root's box, and an interior node (and its two boxes)
//! or a leaf wherever it is active in its run; the mesh query counts into the ray's counters
//! as its batch method counts. The run's shared child order may differ from a lone ray's, so
//! the counts (not the answers) may differ from the single-ray walk's.

use crate::bvh::{BvhNode, MAX_DEPTH};
use crate::geometry::Ray;
use crate::trace::wide::{lanes, PACKET_LANES as LANES};
use crate::trace::{closest_hit_each, occluded_each, Counters, Hit, RayQuery};
use glam::Vec3;

use super::lane_boxes::LaneBoxes;
use super::top_level::{closer, TwoLevel};
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

    /// The lanes of `mask` entering `node` as their single-ray tests do (to `t_max` plus
    /// margin), each lane's entry in `t_entry`.
    #[inline(always)]
    fn entering(&self, mask: u32, node: &BvhNode, t_entry: &mut [f32; LANES]) -> u32 {
        self.boxes.test(node, mask, t_entry)
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

/// A top-level node waiting on the stack: the lanes that entered it and where.
#[derive(Clone, Copy)]
struct Stacked {
    node: u32,
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
            stack: Vec::with_capacity(MAX_DEPTH),
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

/// Walks the top level once for `run`, near child first by the lowest lane entering both,
/// handing each entered leaf's range (`first`, `count`) to `leaf` with the lanes in it.
/// `counters[lane]` is the lane's ray's. Stops when every lane that entered the root is done.
#[inline(always)]
fn walk_run<C: Counters>(
    nodes: &[BvhNode],
    run: &mut Run,
    counters: &mut [C],
    stack: &mut Vec<Stacked>,
    mut leaf: impl FnMut(usize, usize, u32, &mut Run, &mut [C]),
) {
    let Some(root) = nodes.first() else {
        return;
    };
    count(run.all(), counters, |c| c.boxes(1));
    let valid = run.entering(run.all(), root, &mut [0f32; LANES]);
    stack.clear();
    let mut at = (valid != 0).then_some((0, valid));
    while let Some((index, active)) = at.or_else(|| next_stacked(stack, run)) {
        let node = &nodes[index];
        if node.is_leaf() {
            count(active, counters, |c| c.leaf());
            let (first, n) = (node.first as usize, node.count as usize);
            leaf(first, n, active, run, counters);
            if valid & !run.done == 0 {
                return;
            }
            at = None;
        } else {
            count(active, counters, |c| {
                c.inner();
                c.boxes(2);
            });
            at = enter_children(nodes, node, active, run, stack);
        }
    }
}

/// The children of interior `node` the lanes of `active` enter: the one to go on with and its
/// lanes (`None`: neither), the other stacked with its lanes' entries when both are entered.
/// The near child is the single-ray rule's (b first when nearer) for the lowest lane entering
/// both; where no lane enters both, a goes first.
#[inline(always)]
fn enter_children(
    nodes: &[BvhNode],
    node: &BvhNode,
    active: u32,
    run: &Run,
    stack: &mut Vec<Stacked>,
) -> Option<(usize, u32)> {
    let l = node.first as usize;
    let (mut ta, mut tb) = ([0f32; LANES], [0f32; LANES]);
    let ma = run.entering(active, &nodes[l], &mut ta);
    let mb = run.entering(active, &nodes[l + 1], &mut tb);
    match (ma, mb) {
        (0, 0) => None,
        (m, 0) => Some((l, m)),
        (0, m) => Some((l + 1, m)),
        _ => {
            let both = ma & mb;
            let key = both.trailing_zeros() as usize;
            let (near, far) = if both != 0 && tb[key] < ta[key] {
                ((l + 1, mb), (l, ma, ta))
            } else {
                ((l, ma), (l + 1, mb, tb))
            };
            stack.push(Stacked {
                node: far.0 as u32,
                mask: far.1,
                t_entry: far.2,
            });
            Some(near)
        }
    }
}

/// The next stacked node some lane may still hold a closer (or equal) hit in, and those lanes.
#[inline(always)]
fn next_stacked(stack: &mut Vec<Stacked>, run: &Run) -> Option<(usize, u32)> {
    while let Some(entry) = stack.pop() {
        let live = run.still_entering(&entry);
        if live != 0 {
            return Some((entry.node as usize, live));
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
        walk_run(
            &q.top.bvh.nodes,
            &mut run,
            counters,
            &mut scratch.stack,
            leaf,
        );
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
        walk_run(
            &q.top.bvh.nodes,
            &mut run,
            counters,
            &mut scratch.stack,
            leaf,
        );
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
