//! Batches through the top level in runs: each run of [`LANES`] consecutive rays (the passes
//! order a tile's rays so these are neighbours, as the packet kernel's `each_packet` reads
//! them) walks the wide top level once (`run_walk`), a lane mask per child entered, each child
//! box tested across the run's lanes by the packet box kernels grouped by octant
//! (`run_boxes`). At each instance reached, the active lanes' rays are mapped into mesh space
//! and traced together by the mesh query's own batch method, so a mesh tree's packets
//! (re-split there by octant) see the run's coherence.
//!
//! Answers equal the single-ray walk's ([`TwoLevel`]'s `occluded` and `closest_hit`) and the
//! brute-force reference's bit for bit: a lane enters a node only when its own single-ray box
//! test (to its `t_max` plus `t_margin`) passes, a stacked node is culled per lane as the
//! single-ray walk culls it, and closest hits keep the (t, object, triangle) rule of
//! [`closer`], which no visiting order changes.
//!
//! Counters stay per ray, as the wide trees count: a ray counts the root's box, and an interior
//! node (and a box test per used slot) or a leaf slot wherever it is active in its run; the
//! mesh query counts into the ray's counters as its batch method counts. A lone ray enters the
//! children in its single-ray order; a ray in a larger run may enter them in another order,
//! so its counts (not its answers) may differ from the single-ray walk's.

use crate::bvh::MAX_DEPTH;
use crate::geometry::Ray;
use crate::order::{FrontToBack, OrderView};
use crate::trace::wide::{
    lanes, BoxKernel, ChildBoxTest, Kernels, PacketBoxTest, PacketDispatch, PacketTraversal,
    PACKET_LANES as LANES,
};
use crate::trace::{closest_hit_each, occluded_each, Counters, Hit, RayQuery};
use glam::Vec3;

use super::run_boxes::RunBoxes;
use super::run_walk::{walk_run, Run, Stacked};
use super::top_level::{closer, TwoLevel, TOP_WIDTH as WIDTH};
use super::Instance;

/// At most this many rays reaching an instance trace its mesh one at a time: a packet's set-up
/// costs more than it saves there (the packet kernels go on alone below 2 to 5 lanes).
const FEW: usize = 4;

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

/// What a run's walk reuses across runs: the stack, the local batch and the box set-up.
struct Scratch<C> {
    stack: Vec<Stacked>,
    local: Local<C>,
    boxes: RunBoxes,
}

impl<C: Counters> Scratch<C> {
    fn new() -> Self {
        Scratch {
            // A node stacks at most WIDTH - 1 children per level.
            stack: Vec::with_capacity((WIDTH - 1) * MAX_DEPTH + 1),
            local: Local::new(),
            boxes: RunBoxes::new(),
        }
    }
}

/// `TwoLevel::occluded_batch`: any hit per ray, in runs of [`LANES`], with box kernel `P`, the
/// top level's children in `order`.
#[inline(always)]
fn occluded_with<P: PacketBoxTest, Q: RayQuery, C: Counters>(
    q: &TwoLevel<Q>,
    order: &OrderView,
    rays: &[Ray],
    out: &mut [bool],
    counters: &mut [C],
) {
    debug_assert!(out.len() == rays.len() && counters.len() == rays.len());
    out.fill(false);
    let mut scratch = Scratch::<C>::new();
    let runs = rays.chunks(LANES).zip(out.chunks_mut(LANES));
    for ((run_rays, out), counters) in runs.zip(counters.chunks_mut(LANES)) {
        let mut run = Run::new(run_rays, &mut scratch.boxes);
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
        walk_run::<P, _, C>(q.top, order, &mut run, counters, &mut scratch.stack, leaf);
        for lane in lanes(run.done) {
            out[lane] = true;
        }
    }
}

/// `TwoLevel::closest_hit_batch`: the closest hit per ray by (t, object, triangle), in runs of
/// [`LANES`], with box kernel `P`.
#[inline(always)]
fn closest_with<P: PacketBoxTest, Q: RayQuery, C: Counters>(
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
        let mut run = Run::new(run_rays, &mut scratch.boxes);
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
        walk_run::<P, _, C>(
            q.top,
            &FrontToBack,
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

/// `TwoLevel::occluded_batch`: any hit per ray, in runs of [`LANES`], through the packet box
/// kernel the CPU has (the dispatch of the wide packets), the top level's children in `order`.
pub(super) fn occluded_runs<Q: RayQuery, C: Counters>(
    q: &TwoLevel<Q>,
    order: OrderView,
    rays: &[Ray],
    out: &mut [bool],
    counters: &mut [C],
) {
    let call = Occluded {
        q,
        order,
        rays,
        out,
        counters,
    };
    <Kernels as PacketDispatch<WIDTH>>::dispatch_packet(call, BoxKernel::Auto);
}

/// `TwoLevel::closest_hit_batch`, as [`occluded_runs`].
pub(super) fn closest_runs<Q: RayQuery, C: Counters>(
    q: &TwoLevel<Q>,
    rays: &[Ray],
    out: &mut [Option<Hit>],
    counters: &mut [C],
) {
    let call = Closest {
        q,
        rays,
        out,
        counters,
    };
    <Kernels as PacketDispatch<WIDTH>>::dispatch_packet(call, BoxKernel::Auto);
}

/// A batch's runs as one packet traversal of the dispatch (which picks the kernel `P`).
struct Occluded<'a, 'q, Q, C> {
    q: &'a TwoLevel<'q, Q>,
    order: OrderView<'a>,
    rays: &'a [Ray],
    out: &'a mut [bool],
    counters: &'a mut [C],
}

impl<Q: RayQuery, C: Counters> PacketTraversal<WIDTH> for Occluded<'_, '_, Q, C> {
    const COUNTING: bool = C::COUNTING;
    // Runs mix octants (`run_boxes` groups them): one instance per kernel.
    const PER_OCTANT: bool = false;
    #[inline(always)]
    fn fixed_octant(&self) -> Option<usize> {
        None
    }
    #[inline(always)]
    fn run<K: ChildBoxTest<WIDTH>, P: PacketBoxTest, const OCT: usize>(self) {
        occluded_with::<P, Q, C>(self.q, &self.order, self.rays, self.out, self.counters)
    }
}

/// [`Occluded`] for closest hits.
struct Closest<'a, 'q, Q, C> {
    q: &'a TwoLevel<'q, Q>,
    rays: &'a [Ray],
    out: &'a mut [Option<Hit>],
    counters: &'a mut [C],
}

impl<Q: RayQuery, C: Counters> PacketTraversal<WIDTH> for Closest<'_, '_, Q, C> {
    const COUNTING: bool = C::COUNTING;
    const PER_OCTANT: bool = false;
    #[inline(always)]
    fn fixed_octant(&self) -> Option<usize> {
        None
    }
    #[inline(always)]
    fn run<K: ChildBoxTest<WIDTH>, P: PacketBoxTest, const OCT: usize>(self) {
        closest_with::<P, Q, C>(self.q, self.rays, self.out, self.counters)
    }
}
