//! The greedy top-down SRDH build (section 3.4): per node, every binned centroid plane on every
//! axis and every allowed kernel is scored by the SRDH cost over the rays that reach the node;
//! the cheapest wins, and each child receives only the rays that reach it (pierce its box and
//! are not stopped first by a hit in the sibling visited before it). Where no ray remains, the
//! binned SAH builder takes over and its subtree is grafted in.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use super::cost::{pierces, ray_term};
use super::ray_set::RaySet;
use crate::build::{build_sah_nodes, Box4, BuildSettings, PrimRef, MEDIAN_DEPTH};
use crate::bvh::{Bvh, BvhNode, NodeArray};
use crate::geometry::{Aabb, Ray, RayBoxPrecomp};
use crate::order::SrdhSettings;
use crate::order::{Kernel, PackedKernels};
use crate::trace::{
    alpha_query_for, closest_hit_filtered, occluding_leaf, occluding_leaf_filtered, Counters, Hit,
    RayQuery,
};

/// A binary BVH for one light's shadow rays with a traversal kernel per node.
#[derive(Clone, Debug, Default)]
pub struct SrdhBvh {
    pub bvh: Bvh,
    pub kernels: PackedKernels,
    /// Build time (without tracing the ray set), milliseconds.
    pub build_ms: f64,
    /// Representative rays the build read, and how many of them were occluded.
    pub rays: usize,
    pub occluded_rays: usize,
}

/// The light's tree with its kernels: any hit follows them; a closest hit (no kernel is made for
/// it) goes near first on the same binary tree.
impl RayQuery for SrdhBvh {
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        occluding_leaf(&self.bvh, &self.kernels, ray, stats).is_some()
    }
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        self.bvh.closest_hit(ray, stats)
    }
}

alpha_query_for!(
    /// The light's tree through alpha: transmission follows its kernels, as its any hit does.
    /// Its triangle ids are those of the set it was built over (the frame's shadow set), so the
    /// frame's alpha applies as is.
    impl[] SrdhBvh,
    |tree, ray, filter, stats|
    stopped: occluding_leaf_filtered(&tree.bvh, &tree.kernels, ray, filter, stats),
    closest: closest_hit_filtered(&tree.bvh, ray, filter, stats),
);

impl SrdhBvh {
    /// Nodes, triangles, ids and the kernel bits.
    pub fn bytes(&self) -> usize {
        self.bvh.bytes() + self.kernels.bytes()
    }
}

/// Kernel of nodes the SAH builder made: no ray told us better.
pub const DEFAULT_KERNEL: Kernel = Kernel::FrontToBack;
/// Subtrees over more triangles than this are built on another rayon task.
const PARALLEL_SUBTREE: usize = 1024;
/// Nodes whose rays x candidates exceed this score candidates in parallel.
const PARALLEL_SCORING: usize = 1 << 14;

/// A scored candidate: triangles whose centroid bin on `axis` is below `plane` go left.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Candidate {
    pub axis: usize,
    pub plane: usize,
    pub kernel: Kernel,
    pub cost: u64,
}

/// Centroid bins of one node.
struct Binning {
    lo: Vec3,
    scale: Vec3,
    bins: usize,
}

impl Binning {
    fn new(centroids: &Aabb, bins: usize) -> Self {
        let e = centroids.extent();
        let s = |x: f32| {
            if x > 0.0 {
                bins as f32 * (1.0 - 1e-6) / x
            } else {
                0.0
            }
        };
        Binning {
            lo: centroids.min,
            scale: Vec3::new(s(e.x), s(e.y), s(e.z)),
            bins,
        }
    }
    #[inline(always)]
    fn bin(&self, c: Vec3, axis: usize) -> usize {
        // Negative offsets saturate to bin 0.
        (((c[axis] - self.lo[axis]) * self.scale[axis]) as usize).min(self.bins - 1)
    }
}

/// The rays reaching a node, each with its hits among the node's triangles.
struct NodeRays {
    ids: Vec<u32>,
    offsets: Vec<u32>,
    hits: Vec<u32>,
}

impl NodeRays {
    fn new() -> Self {
        NodeRays {
            ids: Vec::new(),
            offsets: vec![0],
            hits: Vec::new(),
        }
    }
    fn push(&mut self, id: u32, hits: impl Iterator<Item = u32>) {
        self.ids.push(id);
        self.hits.extend(hits);
        self.offsets.push(self.hits.len() as u32);
    }
    fn hits(&self, j: usize) -> &[u32] {
        &self.hits[self.offsets[j] as usize..self.offsets[j + 1] as usize]
    }
}

enum Built {
    Leaf(Aabb, Vec<u32>),
    Inner(Aabb, Kernel, Box<[Built; 2]>),
    /// A binned SAH subtree (compacted nodes, leaf ranges indexing its ids).
    Sah(Vec<BvhNode>, Vec<u32>),
}

struct Builder<'a> {
    boxes: Vec<Aabb>,
    centroids: Vec<Vec3>,
    set: &'a RaySet,
    pre: Vec<RayBoxPrecomp>,
    settings: &'a SrdhSettings,
    sah: &'a BuildSettings,
}

/// Builds the SRDH tree over `triangles` for the rays of `set` (their hit ids index
/// `triangles`). With an empty set this is the binned SAH tree of `sah`.
pub fn build_srdh(
    triangles: &[[Vec3; 3]],
    set: &RaySet,
    settings: &SrdhSettings,
    sah: &BuildSettings,
) -> SrdhBvh {
    let start = Instant::now();
    let boxes: Vec<Aabb> = triangles.par_iter().map(Aabb::of_triangle).collect();
    let mut tree = build_srdh_over_boxes(boxes, set, settings, sah);
    tree.bvh.triangles = (tree.bvh.triangle_ids.iter())
        .map(|&i| triangles[i as usize])
        .collect();
    let build_ms = start.elapsed().as_secs_f64() * 1e3;
    tree.bvh.build_ms = build_ms;
    tree.build_ms = build_ms;
    tree
}

/// The SRDH tree over primitives given by their boxes, for the rays of `set` (their hit ids
/// index `boxes`): the nodes and kernels, its leaves' ranges indexing `triangle_ids` (the
/// primitives' indices in leaf order), and no triangles. A child's cost is its count of
/// primitives, whatever they are (triangles, or the instances of a top level).
pub fn build_srdh_over_boxes(
    boxes: Vec<Aabb>,
    set: &RaySet,
    settings: &SrdhSettings,
    sah: &BuildSettings,
) -> SrdhBvh {
    let start = Instant::now();
    if boxes.is_empty() {
        return SrdhBvh::default();
    }
    let n = boxes.len() as u32;
    let b = Builder::new(boxes, set, settings, sah);
    let prims: Vec<u32> = (0..n).collect();
    let rays = b.root_rays(&b.bounds(&prims));
    let tree = b.node(prims, rays, 0);
    let (nodes, kernels, ids) = flatten(tree);
    let build_ms = start.elapsed().as_secs_f64() * 1e3;
    SrdhBvh {
        bvh: Bvh {
            nodes: NodeArray::from_nodes(&nodes),
            triangles: Vec::new(),
            triangle_ids: ids,
            build_ms,
        },
        kernels: PackedKernels::from_kernels(&kernels),
        build_ms,
        rays: set.len(),
        occluded_rays: set.occluded_count(),
    }
}

/// What the builder scores at the root (for the exhaustive test).
pub struct RootCandidates {
    /// Every candidate with its left and right triangle sets.
    pub scored: Vec<(Candidate, Vec<u32>, Vec<u32>)>,
    pub chosen: Candidate,
    /// Indices of the set's rays that reach the root (pierce its box).
    pub reaching: Vec<usize>,
}

/// Every candidate the builder scores at the root, with its two triangle sets, and the one it
/// chooses. `None` when all centroids coincide.
pub fn root_candidates(
    triangles: &[[Vec3; 3]],
    set: &RaySet,
    settings: &SrdhSettings,
    sah: &BuildSettings,
) -> Option<RootCandidates> {
    let boxes = triangles.iter().map(Aabb::of_triangle).collect();
    let b = Builder::new(boxes, set, settings, sah);
    let prims: Vec<u32> = (0..triangles.len() as u32).collect();
    let rays = b.root_rays(&b.bounds(&prims));
    let (all, binning) = b.score(&prims, &rays)?;
    let chosen = best(&all)?;
    let scored = all
        .iter()
        .map(|c| {
            let (l, r) = b.partition(&prims, c, &binning);
            (*c, l, r)
        })
        .collect();
    Some(RootCandidates {
        scored,
        chosen,
        reaching: rays.ids.iter().map(|&i| i as usize).collect(),
    })
}

/// The cheapest candidate; ties go to the first scored.
fn best(all: &[Candidate]) -> Option<Candidate> {
    all.iter()
        .copied()
        .reduce(|a, c| if c.cost < a.cost { c } else { a })
}

impl<'a> Builder<'a> {
    fn new(
        boxes: Vec<Aabb>,
        set: &'a RaySet,
        settings: &'a SrdhSettings,
        sah: &'a BuildSettings,
    ) -> Self {
        Builder {
            centroids: boxes.iter().map(Aabb::center).collect(),
            boxes,
            set,
            pre: set.rays.iter().map(RayBoxPrecomp::new).collect(),
            settings,
            sah,
        }
    }

    fn bounds(&self, prims: &[u32]) -> Aabb {
        prims
            .iter()
            .fold(Aabb::EMPTY, |b, &p| b.union(&self.boxes[p as usize]))
    }

    /// The rays that pierce the root's box, with all their hits.
    fn root_rays(&self, root: &Aabb) -> NodeRays {
        let mut rays = NodeRays::new();
        for (i, ray) in self.set.rays.iter().enumerate() {
            if pierces(&self.pre[i], ray, root) {
                rays.push(i as u32, self.set.hits(i).iter().copied());
            }
        }
        rays
    }

    fn node(&self, prims: Vec<u32>, rays: NodeRays, depth: usize) -> Built {
        let bounds = self.bounds(&prims);
        if prims.len() <= self.settings.leaf as usize {
            return Built::Leaf(bounds, prims);
        }
        // Past MEDIAN_DEPTH the SAH builder's object medians keep the depth bounded.
        if rays.ids.is_empty() || depth >= MEDIAN_DEPTH {
            return self.sah_subtree(prims, depth);
        }
        let Some((all, binning)) = self.score(&prims, &rays) else {
            return self.sah_subtree(prims, depth);
        };
        let mut chosen = best(&all).expect("score returns candidates");
        // No ray here is occluded: every kernel costs the same; front to back suits new rays.
        if rays.hits.is_empty() && self.settings.kernels.kernels().contains(&DEFAULT_KERNEL) {
            chosen.kernel = DEFAULT_KERNEL;
        }
        let (left, right) = self.partition(&prims, &chosen, &binning);
        let (lb, rb) = (self.bounds(&left), self.bounds(&right));
        let (lr, rr) = self.filter(&rays, &chosen, &binning, [&lb, &rb]);
        drop(rays);
        let (l, r) = if prims.len() > PARALLEL_SUBTREE {
            rayon::join(
                || self.node(left, lr, depth + 1),
                || self.node(right, rr, depth + 1),
            )
        } else {
            (
                self.node(left, lr, depth + 1),
                self.node(right, rr, depth + 1),
            )
        };
        Built::Inner(bounds, chosen.kernel, Box::new([l, r]))
    }

    fn sah_subtree(&self, prims: Vec<u32>, depth: usize) -> Built {
        let mut refs: Vec<PrimRef> = prims
            .iter()
            .map(|&p| {
                let b = &self.boxes[p as usize];
                PrimRef::new(
                    p,
                    Box4 {
                        lo: b.min.extend(0.0),
                        hi: b.max.extend(0.0),
                    },
                )
            })
            .collect();
        let nodes = build_sah_nodes(&mut refs, self.sah, depth);
        Built::Sah(nodes, refs.iter().map(|r| r.id()).collect())
    }

    /// Scores every usable plane of every axis with every allowed kernel, in the order axis,
    /// plane, kernel. `None` if all centroids coincide.
    fn score(&self, prims: &[u32], rays: &NodeRays) -> Option<(Vec<Candidate>, Binning)> {
        let centroid_bounds = prims.iter().fold(Aabb::EMPTY, |mut b, &p| {
            b.grow_point(self.centroids[p as usize]);
            b
        });
        let bins = self.settings.bins as usize;
        let binning = Binning::new(&centroid_bounds, bins);
        let axes: Vec<usize> = (0..3).filter(|&a| binning.scale[a] > 0.0).collect();
        if axes.is_empty() {
            return None;
        }
        // Per axis: left boxes/counts for planes 1..bins (bins below), right boxes likewise.
        let mut sides = Vec::new();
        for &a in &axes {
            let mut bin_box = vec![Aabb::EMPTY; bins];
            let mut bin_count = vec![0u64; bins];
            for &p in prims {
                let k = binning.bin(self.centroids[p as usize], a);
                bin_box[k].grow(&self.boxes[p as usize]);
                bin_count[k] += 1;
            }
            let mut left = vec![(Aabb::EMPTY, 0u64); bins + 1];
            for k in 1..=bins {
                left[k] = (
                    left[k - 1].0.union(&bin_box[k - 1]),
                    left[k - 1].1 + bin_count[k - 1],
                );
            }
            let mut right = vec![(Aabb::EMPTY, 0u64); bins + 1];
            for k in (0..bins).rev() {
                right[k] = (
                    right[k + 1].0.union(&bin_box[k]),
                    right[k + 1].1 + bin_count[k],
                );
            }
            for plane in 1..bins {
                if left[plane].1 > 0 && right[plane].1 > 0 {
                    sides.push((a, plane, left[plane], right[plane]));
                }
            }
        }
        // Per ray and axis: lowest and highest bin among its hits (bins, 0 if none).
        let hit_bins: Vec<[(usize, usize); 3]> = (0..rays.ids.len())
            .map(|j| {
                let mut r = [(bins, 0); 3];
                for &h in rays.hits(j) {
                    for &a in &axes {
                        let k = binning.bin(self.centroids[h as usize], a);
                        r[a] = (r[a].0.min(k), r[a].1.max(k));
                    }
                }
                r
            })
            .collect();
        let kernels = self.settings.kernels.kernels();
        let score_one =
            |&(a, plane, (lb, nl), (rb, nr)): &(usize, usize, (Aabb, u64), (Aabb, u64))| {
                let (cl, cr) = (lb.center(), rb.center());
                let mut cost = [0u64; 4];
                for (j, &id) in rays.ids.iter().enumerate() {
                    let ray = &self.set.rays[id as usize];
                    let pre = &self.pre[id as usize];
                    let pierce = [pierces(pre, ray, &lb), pierces(pre, ray, &rb)];
                    if !pierce[0] && !pierce[1] {
                        continue;
                    }
                    let (lo, hi) = hit_bins[j][a];
                    let hit = [lo < plane, lo <= hi && hi >= plane];
                    for (c, k) in cost.iter_mut().zip(kernels) {
                        *c += ray_term(k.left_first(ray.origin, cl, cr), pierce, hit, [nl, nr]);
                    }
                }
                kernels
                    .iter()
                    .zip(cost)
                    .map(|(&kernel, cost)| Candidate {
                        axis: a,
                        plane,
                        kernel,
                        cost,
                    })
                    .collect::<Vec<_>>()
            };
        let all: Vec<Candidate> = if rays.ids.len() * sides.len() > PARALLEL_SCORING {
            sides.par_iter().flat_map_iter(score_one).collect()
        } else {
            sides.iter().flat_map(score_one).collect()
        };
        (!all.is_empty()).then_some((all, binning))
    }

    fn partition(&self, prims: &[u32], c: &Candidate, binning: &Binning) -> (Vec<u32>, Vec<u32>) {
        prims
            .iter()
            .partition(|&&p| binning.bin(self.centroids[p as usize], c.axis) < c.plane)
    }

    /// The rays reaching each child: they pierce its box and are not stopped by a hit in the
    /// sibling the kernel sends them to first.
    fn filter(
        &self,
        rays: &NodeRays,
        c: &Candidate,
        binning: &Binning,
        boxes: [&Aabb; 2],
    ) -> (NodeRays, NodeRays) {
        let (cl, cr) = (boxes[0].center(), boxes[1].center());
        let (mut left, mut right) = (NodeRays::new(), NodeRays::new());
        let is_left = |h: &u32| binning.bin(self.centroids[*h as usize], c.axis) < c.plane;
        for (j, &id) in rays.ids.iter().enumerate() {
            let ray = &self.set.rays[id as usize];
            let pre = &self.pre[id as usize];
            let hits = rays.hits(j);
            let hit = [hits.iter().any(is_left), hits.iter().any(|h| !is_left(h))];
            let lf = c.kernel.left_first(ray.origin, cl, cr);
            if pierces(pre, ray, boxes[0]) && (lf || !hit[1]) {
                left.push(id, hits.iter().copied().filter(is_left));
            }
            if pierces(pre, ray, boxes[1]) && (!lf || !hit[0]) {
                right.push(id, hits.iter().copied().filter(|h| !is_left(h)));
            }
        }
        (left, right)
    }
}

/// Lays the tree out as [`NodeArray`] needs (root, pad, sibling pairs depth-first): nodes, one
/// kernel per node, triangle ids in leaf order.
fn flatten(tree: Built) -> (Vec<BvhNode>, Vec<Kernel>, Vec<u32>) {
    if let Built::Sah(nodes, ids) = tree {
        let kernels = vec![DEFAULT_KERNEL; nodes.len()];
        return (nodes, kernels, ids);
    }
    let mut nodes = vec![BvhNode::default(); 2];
    let mut kernels = vec![DEFAULT_KERNEL; 2];
    let mut ids = Vec::new();
    let mut stack: Vec<(Built, usize)> = vec![(tree, 0)];
    while let Some((built, at)) = stack.pop() {
        match built {
            Built::Leaf(bounds, mut leaf) => {
                nodes[at].set_bounds(&bounds);
                nodes[at].first = ids.len() as u32;
                nodes[at].count = leaf.len() as u32;
                ids.append(&mut leaf);
            }
            Built::Inner(bounds, kernel, children) => {
                nodes[at].set_bounds(&bounds);
                nodes[at].count = 0;
                kernels[at] = kernel;
                let k = nodes.len();
                nodes[at].first = k as u32;
                nodes.extend([BvhNode::default(); 2]);
                kernels.extend([DEFAULT_KERNEL; 2]);
                let [l, r] = *children;
                stack.push((r, k + 1));
                stack.push((l, k));
            }
            Built::Sah(sub, mut sub_ids) => {
                let base = ids.len() as u32;
                ids.append(&mut sub_ids);
                graft(&sub, &mut nodes, &mut kernels, at, base);
            }
        }
    }
    (nodes, kernels, ids)
}

/// Copies a compacted SAH subtree into `out` with its root at `at`, leaf ranges offset by `base`.
fn graft(sub: &[BvhNode], out: &mut Vec<BvhNode>, kernels: &mut Vec<Kernel>, at: usize, base: u32) {
    let mut stack = vec![(0usize, at)];
    while let Some((i, o)) = stack.pop() {
        let mut node = sub[i];
        if node.is_leaf() {
            node.first += base;
            out[o] = node;
            continue;
        }
        let k = out.len();
        out.extend([BvhNode::default(); 2]);
        kernels.extend([DEFAULT_KERNEL; 2]);
        let child = node.first as usize;
        node.first = k as u32;
        out[o] = node;
        stack.push((child + 1, k + 1));
        stack.push((child, k));
    }
}
