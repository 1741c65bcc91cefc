//! Binned SAH build (Wald 2007): primitive centroids are binned along each axis, the best of the
//! bin boundaries by surface-area cost splits the node. Subtrees are built in parallel with
//! rayon; each subtree writes into its own disjoint part of one preallocated node array, which a
//! final pass compacts into depth-first order with sibling pairs adjacent.

use std::time::Instant;

use glam::{Vec3, Vec4};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::node::{zeroed_vec, Bvh, BvhNode, NodeArray, MAX_DEPTH};
use super::spatial_split::SpatialSettings;
use crate::geometry::Aabb;

/// Settings of the binned SAH builder.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BuildSettings {
    /// Bins per axis (2..=256). More bins find better splits at a higher build cost.
    pub bins: usize,
    /// Leaves never hold more triangles than this (1..=64).
    pub max_leaf_size: usize,
    /// Nodes of at most this many references become leaves without a split search
    /// (1..=`max_leaf_size`; Embree's `minLeafSize`). 1, the default, lets the SAH decide
    /// every leaf; larger values skip the bottom levels' binning (a faster build) for leaves
    /// of more triangles (more triangle tests, fewer nodes entered).
    #[serde(default = "default_min_leaf_size")]
    pub min_leaf_size: usize,
    /// SAH cost of one traversal step, relative to `intersection_cost`.
    pub traversal_cost: f32,
    /// SAH cost of one ray/triangle test.
    pub intersection_cost: f32,
    /// Spatial splits of the SBVH, ABVH and OSAH builders.
    #[serde(default)]
    pub spatial: SpatialSettings,
    /// OSAH weight w of the visible-triangle term (the paper's equation 4), in (0, 1).
    #[serde(default = "default_osah_weight")]
    pub osah_weight: f32,
    /// OSAH viability: besides the paper's condition (5), the hidden child must hold no visible
    /// triangle (true, the default: fewer traversal steps than the paper's rule); false is the
    /// paper's condition (5) alone.
    #[serde(default = "default_osah_strict")]
    pub osah_strict_viability: bool,
}

fn default_min_leaf_size() -> usize {
    1
}

fn default_osah_strict() -> bool {
    true
}

fn default_osah_weight() -> f32 {
    0.9
}

impl Default for BuildSettings {
    fn default() -> Self {
        BuildSettings {
            bins: 16,
            max_leaf_size: 8,
            min_leaf_size: default_min_leaf_size(),
            traversal_cost: 1.0,
            intersection_cost: 1.0,
            spatial: SpatialSettings::default(),
            osah_weight: default_osah_weight(),
            osah_strict_viability: default_osah_strict(),
        }
    }
}

impl BuildSettings {
    /// Nodes of at most this many references are leaves without a split search: the
    /// smallest leaf, never below 1 even in settings that were not validated.
    pub(crate) fn unsplit_refs(&self) -> usize {
        self.min_leaf_size.max(1)
    }

    pub fn validate(&self) -> crate::Result<()> {
        if !(2..=MAX_BINS).contains(&self.bins) {
            return Err(crate::Error::invalid(
                "build.bins",
                format!("must be in 2..={MAX_BINS}, got {}", self.bins),
            ));
        }
        if !(1..=64).contains(&self.max_leaf_size) {
            return Err(crate::Error::invalid(
                "build.max_leaf_size",
                format!("must be in 1..=64, got {}", self.max_leaf_size),
            ));
        }
        if !(1..=self.max_leaf_size).contains(&self.min_leaf_size) {
            return Err(crate::Error::invalid(
                "build.min_leaf_size",
                format!(
                    "must be in 1..=max_leaf_size ({}), got {}",
                    self.max_leaf_size, self.min_leaf_size
                ),
            ));
        }
        for (f, v) in [
            ("build.traversal_cost", self.traversal_cost),
            ("build.intersection_cost", self.intersection_cost),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(crate::Error::invalid(
                    f,
                    format!("must be positive, got {v}"),
                ));
            }
        }
        // w = 1 would drop the area term that breaks ties between splits; w = 0 is plain SAH.
        if !(self.osah_weight > 0.0 && self.osah_weight < 1.0) {
            return Err(crate::Error::invalid(
                "build.osah_weight",
                format!("must be in (0, 1), got {}", self.osah_weight),
            ));
        }
        self.spatial.validate()
    }
}

/// A triangle's box, with its id in the fourth lane of `lo` (as bits), so a reference is two
/// 16-byte vectors that min/max in one instruction each.
///
/// The id lane rides along through 4-lane arithmetic (areas, centroids, bin indices). Raw ids
/// below 2^23 are denormal floats, and every multiply that met one took a slow microcode
/// assist; the id is stored XOR [`ID_LANE_BIAS`], a normal float for any id below 2^30.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PrimRef {
    pub(crate) lo: Vec4,
    pub(crate) hi: Vec4,
}

/// Flips the id's bit 30 so the id lane holds a normal (or infinite/NaN) float, never a denormal
/// (for ids below 2^30).
const ID_LANE_BIAS: u32 = 0x4000_0000;

impl PrimRef {
    /// A reference to triangle `id` with the given box (a spatial split's clipped part, or
    /// the whole triangle's box).
    #[inline]
    pub(crate) fn new(id: u32, b: Box4) -> Self {
        PrimRef {
            lo: b.lo.truncate().extend(f32::from_bits(id ^ ID_LANE_BIAS)),
            hi: b.hi.truncate().extend(0.0),
        }
    }
    /// A reference to the whole of triangle `id`.
    #[inline]
    pub(crate) fn of_triangle(id: u32, triangle: &[Vec3; 3]) -> Self {
        let b = Aabb::of_triangle(triangle);
        PrimRef {
            lo: b.min.extend(f32::from_bits(id ^ ID_LANE_BIAS)),
            hi: b.max.extend(0.0),
        }
    }
    #[inline]
    pub(crate) fn id(&self) -> u32 {
        self.lo.w.to_bits() ^ ID_LANE_BIAS
    }
    /// The reference's box (without the id lane).
    #[inline]
    pub(crate) fn bounds(&self) -> Box4 {
        Box4 {
            lo: self.lo.truncate().extend(0.0),
            hi: self.hi,
        }
    }
    /// Whether the reference's triangle is in the visible set the build was given: carried in
    /// the upper corner's fourth lane (1.0 visible, 0.0 not), so the visibility-driven builders
    /// count visible references from the reference itself, not from a table indexed by id.
    #[inline]
    pub(crate) fn visible(&self) -> bool {
        self.hi.w != 0.0
    }
    /// The reference marked visible or not.
    #[inline]
    pub(crate) fn with_visibility(mut self, visible: bool) -> Self {
        self.hi.w = if visible { 1.0 } else { 0.0 };
        self
    }
    /// A reference to the same triangle, visible or not as this one, with box `b` (a part cut
    /// from this one by a spatial split).
    #[inline]
    pub(crate) fn with_bounds(&self, b: Box4) -> Self {
        PrimRef {
            lo: b.lo.truncate().extend(self.lo.w),
            hi: b.hi.truncate().extend(self.hi.w),
        }
    }
    /// Twice the centroid (the factor cancels in binning and saves a multiply).
    #[inline]
    pub(crate) fn centroid2(&self) -> Vec4 {
        self.lo + self.hi
    }
}

/// A box in the builder's 4-lane form; the fourth lane carries nothing meaningful (a box made
/// from references may hold their id and visibility lanes there).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Box4 {
    pub(crate) lo: Vec4,
    pub(crate) hi: Vec4,
}

impl Box4 {
    pub(crate) const EMPTY: Box4 = Box4 {
        lo: Vec4::splat(f32::INFINITY),
        hi: Vec4::splat(f32::NEG_INFINITY),
    };
    #[inline(always)]
    pub(crate) fn grow(&mut self, lo: Vec4, hi: Vec4) {
        self.lo = self.lo.min(lo);
        self.hi = self.hi.max(hi);
    }
    #[inline(always)]
    pub(crate) fn grow_box(&mut self, b: &Box4) {
        self.grow(b.lo, b.hi);
    }
    #[inline(always)]
    pub(crate) fn half_area(&self) -> f32 {
        let e = (self.hi - self.lo).truncate();
        if e.x < 0.0 {
            return 0.0;
        }
        e.x * e.y + e.y * e.z + e.z * e.x
    }
    pub(crate) fn to_aabb(self) -> Aabb {
        Aabb::new(self.lo.truncate(), self.hi.truncate())
    }
}

/// A bin's bounds: the upper corner negated so that one `min` grows both corners (one 8-lane
/// operation with AVX, see [`Corners::grow_avx`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub(crate) struct Corners {
    lo: Vec4,
    neg_hi: Vec4,
}

impl Corners {
    pub(crate) const EMPTY: Corners = Corners {
        lo: Vec4::splat(f32::INFINITY),
        neg_hi: Vec4::splat(f32::INFINITY),
    };
    #[inline(always)]
    pub(crate) fn bounds(&self) -> Box4 {
        Box4 {
            lo: self.lo,
            hi: -self.neg_hi,
        }
    }
    /// Grows by a reference (`neg_hi` is `-r.hi`, computed once for all its bins).
    #[inline(always)]
    pub(crate) fn grow(&mut self, r: &PrimRef, neg_hi: Vec4) {
        self.lo = self.lo.min(r.lo);
        self.neg_hi = self.neg_hi.min(neg_hi);
    }
    #[inline(always)]
    pub(crate) fn grow_box(&mut self, b: &Box4) {
        self.lo = self.lo.min(b.lo);
        self.neg_hi = self.neg_hi.min(-b.hi);
    }
    #[inline(always)]
    pub(crate) fn merge(&mut self, other: &Corners) {
        self.lo = self.lo.min(other.lo);
        self.neg_hi = self.neg_hi.min(other.neg_hi);
    }
    /// A reference's corners in the 8-lane form [`Self::grow_avx`] takes.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    #[inline]
    pub(crate) fn of_ref_avx(r: &PrimRef) -> std::arch::x86_64::__m256 {
        Self::of_box_avx(&Box4 { lo: r.lo, hi: r.hi })
    }
    /// A box's corners in the 8-lane form [`Self::grow_avx`] takes.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    #[inline]
    pub(crate) fn of_box_avx(r: &Box4) -> std::arch::x86_64::__m256 {
        use std::arch::x86_64::*;
        let flip_hi = _mm256_castsi256_ps(_mm256_set_epi32(
            i32::MIN,
            i32::MIN,
            i32::MIN,
            i32::MIN,
            0,
            0,
            0,
            0,
        ));
        _mm256_xor_ps(_mm256_set_m128(r.hi.into(), r.lo.into()), flip_hi)
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    #[inline]
    pub(crate) fn grow_avx(&mut self, v: std::arch::x86_64::__m256) {
        use std::arch::x86_64::*;
        let p = self as *mut Corners as *mut f32;
        // SAFETY: `Corners` is 8 floats (`repr(C)`), 32-byte aligned; AVX is enabled here.
        unsafe { _mm256_store_ps(p, _mm256_min_ps(_mm256_load_ps(p), v)) };
    }
}

/// A bin: the bounds of the references binned into it and their count.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Bin {
    corners: Corners,
    count: u32,
}

const EMPTY_BIN: Bin = Bin {
    corners: Corners::EMPTY,
    count: 0,
};

impl Bin {
    #[inline(always)]
    fn bounds(&self) -> Box4 {
        self.corners.bounds()
    }
}

/// Upper bound of `BuildSettings::bins`; bins live in fixed arrays of this size.
pub const MAX_BINS: usize = 256;

/// Subtrees smaller than this are built on the current thread.
pub(crate) const PARALLEL_SUBTREE: usize = 4096;
/// Nodes with more references than this bin in parallel.
const PARALLEL_BINNING: usize = 65536;
/// Past this depth, splits are object medians so the depth bound holds on any input.
pub(crate) const MEDIAN_DEPTH: usize = MAX_DEPTH - 33;

/// Builds a binned SAH BVH over `triangles` (the BVH keeps a leaf-ordered copy).
pub fn build_binned_sah(triangles: &[[Vec3; 3]], settings: &BuildSettings) -> Bvh {
    let start = Instant::now();
    let mut refs: Vec<PrimRef> = triangles
        .par_iter()
        .enumerate()
        .map(|(i, t)| PrimRef::of_triangle(i as u32, t))
        .collect();
    let mut bvh = build_from_refs(&mut refs, settings);
    bvh.triangles = refs
        .par_iter()
        .map(|r| triangles[r.id() as usize])
        .collect();
    bvh.triangle_ids = refs.par_iter().map(|r| r.id()).collect();
    bvh.build_ms = start.elapsed().as_secs_f64() * 1e3;
    bvh
}

fn build_from_refs(refs: &mut [PrimRef], settings: &BuildSettings) -> Bvh {
    build_sah_subtree(refs, settings, 0)
}

/// Binned SAH nodes over `refs` (reordered into leaf order), for a subtree whose root sits at
/// `depth` in a larger tree: the other builders hand subtrees that need no spatial or visibility
/// splits to this one. Leaf ranges index `refs`; triangles and ids are left to the caller.
pub(crate) fn build_sah_subtree(
    refs: &mut [PrimRef],
    settings: &BuildSettings,
    depth: usize,
) -> Bvh {
    Bvh {
        nodes: NodeArray::from_nodes(&build_sah_nodes(refs, settings, depth)),
        ..Bvh::default()
    }
}

/// The nodes of [`build_sah_subtree`] as a plain vector in the same layout (root, pad, sibling
/// pairs depth-first; empty for no references), for builders that graft the subtree into a tree
/// of their own.
pub(crate) fn build_sah_nodes(
    refs: &mut [PrimRef],
    settings: &BuildSettings,
    depth: usize,
) -> Vec<BvhNode> {
    let n = refs.len();
    if n == 0 {
        return Vec::new();
    }
    if 2 * n - 1 > SPARE_NODES_MAX {
        let (nodes, sizes) = build_uncompacted(refs, settings, depth);
        return compact(&nodes, &sizes);
    }
    // The split builders hand over thousands of subtrees: these build into the thread's spare
    // arrays (stale slots are never read: only the nodes the build writes are reachable), so
    // no zeroed arrays are allocated per subtree; small ones compact by a depth-first walk.
    // A build that runs while the spares are taken further up this thread's stack (rayon may
    // run another subtree inside a join) allocates its own.
    let (mut nodes, mut sizes) = SPARE_NODES.take().unwrap_or_default();
    if nodes.len() < 2 * n - 1 {
        nodes.resize(2 * n - 1, BvhNode::default());
        sizes.resize(2 * n - 1, 0);
    }
    let total = build_into(refs, settings, depth, &mut nodes, &mut sizes);
    let out = if n > PARALLEL_SUBTREE {
        compact(&nodes, &sizes)
    } else {
        compact_depth_first(&nodes, total as usize + 1)
    };
    SPARE_NODES.set(Some((nodes, sizes)));
    out
}

/// The most uncompacted nodes a thread keeps spare (4 MiB of nodes, 0.5 MiB of sizes): larger
/// subtrees allocate zeroed arrays of their own.
const SPARE_NODES_MAX: usize = 1 << 17;

thread_local! {
    /// A thread's spare uncompacted node and size arrays (see [`build_sah_nodes`]).
    static SPARE_NODES: std::cell::Cell<Option<(Vec<BvhNode>, Vec<u32>)>> =
        const { std::cell::Cell::new(None) };
}

/// The nodes of a build (non-empty `refs`) before compaction, with their subtree sizes.
fn build_uncompacted(
    refs: &mut [PrimRef],
    settings: &BuildSettings,
    depth: usize,
) -> (Vec<BvhNode>, Vec<u32>) {
    let n = refs.len();
    // A subtree over k references uses at most 2k - 2 nodes below its root.
    let mut nodes = zeroed_nodes(2 * n - 1);
    let mut sizes = vec![0u32; 2 * n - 1];
    build_into(refs, settings, depth, &mut nodes, &mut sizes);
    (nodes, sizes)
}

/// Builds over non-empty `refs` into `nodes` (root first; at least 2n - 1 of them), each node's
/// subtree size at the same index of `sizes` (for the parallel compaction); returns the root's.
fn build_into(
    refs: &mut [PrimRef],
    settings: &BuildSettings,
    depth: usize,
    nodes: &mut [BvhNode],
    sizes: &mut [u32],
) -> u32 {
    let (bounds, centroids) = bounds_of(refs);
    let (root, below) = nodes.split_at_mut(1);
    let (root_size, sizes_below) = sizes.split_at_mut(1);
    let ctx = Context {
        settings,
        bins: settings.bins.clamp(2, MAX_BINS),
    };
    let task = Task {
        first: 0,
        below_start: 1,
        bounds,
        centroids,
        depth,
    };
    let slots = Slots {
        below,
        sizes: sizes_below,
    };
    root_size[0] = with_other_buffer(refs.len(), |other| {
        let refs = Refs {
            cur: refs,
            other,
            in_place: true,
        };
        with_scratch(|scratch| ctx.build(refs, &mut root[0], slots, task, scratch))
    });
    root_size[0]
}

/// A node's references (`cur`) and the same range of the other buffer (`other`). A partition
/// moves the references from one buffer to the other rather than copying them back, so the two
/// swap roles from level to level; `in_place` says whether `cur` is the caller's array, where
/// a leaf's references must end up.
struct Refs<'a> {
    cur: &'a mut [PrimRef],
    other: &'a mut [PrimRef],
    in_place: bool,
}

impl<'a> Refs<'a> {
    /// The two sides of the references, split after the first `mid`.
    fn split_at(self, mid: usize) -> (Refs<'a>, Refs<'a>) {
        let (cur_l, cur_r) = self.cur.split_at_mut(mid);
        let (other_l, other_r) = self.other.split_at_mut(mid);
        let side = |cur, other| Refs {
            cur,
            other,
            in_place: self.in_place,
        };
        (side(cur_l, other_l), side(cur_r, other_r))
    }

    /// The same references after a partition moved them into `other`.
    fn swapped(self) -> Refs<'a> {
        Refs {
            cur: self.other,
            other: self.cur,
            in_place: !self.in_place,
        }
    }
}

/// Runs `f` with a buffer of `n` references: this thread's spare one, or for more than
/// [`SPARE_REFS_MAX`] references (the root of a large scene) one of its own. (Not from zeroed
/// memory: the allocator maps fresh pages for that on every build, and their faults cost more
/// than filling reused ones.)
fn with_other_buffer<R>(n: usize, f: impl FnOnce(&mut [PrimRef]) -> R) -> R {
    const STALE: PrimRef = PrimRef {
        lo: Vec4::ZERO,
        hi: Vec4::ZERO,
    };
    if n > SPARE_REFS_MAX {
        return f(&mut vec![STALE; n]);
    }
    let mut spare = SPARE_REFS.take();
    if spare.len() < n {
        spare.resize(n, STALE);
    }
    let result = f(&mut spare[..n]);
    SPARE_REFS.set(spare);
    result
}

/// `count` default nodes from zeroed memory (see [`zeroed_vec`]). Nodes the build never writes
/// stay default and are never read.
fn zeroed_nodes(count: usize) -> Vec<BvhNode> {
    // SAFETY: every field of `BvhNode` is an f32 or u32, for which all-zero bits are the value
    // 0, i.e. `BvhNode::default()`.
    unsafe { zeroed_vec::<BvhNode>(count) }
}

/// Where a subtree's descendants go: their nodes, and (same indices) their subtree sizes.
struct Slots<'a> {
    below: &'a mut [BvhNode],
    sizes: &'a mut [u32],
}

/// Bounds and (doubled) centroid bounds of some references.
pub(crate) fn bounds_of(refs: &[PrimRef]) -> (Box4, Box4) {
    let fold = |(mut b, mut c): (Box4, Box4), r: &PrimRef| {
        b.grow(r.lo, r.hi);
        let c2 = r.centroid2();
        c.grow(c2, c2);
        (b, c)
    };
    let merge = |a: (Box4, Box4), b: (Box4, Box4)| {
        let (mut x, mut y) = a;
        x.grow_box(&b.0);
        y.grow_box(&b.1);
        (x, y)
    };
    if refs.len() > PARALLEL_BINNING {
        refs.par_chunks(16384)
            .map(|chunk| chunk.iter().fold((Box4::EMPTY, Box4::EMPTY), fold))
            .reduce(|| (Box4::EMPTY, Box4::EMPTY), merge)
    } else {
        refs.iter().fold((Box4::EMPTY, Box4::EMPTY), fold)
    }
}

/// The bounds of some references' doubled centroids (the second half of [`bounds_of`]; kept
/// apart because folding both through one generic helper made the SAH builder slower).
pub(crate) fn centroid_bounds_of(refs: &[PrimRef]) -> Box4 {
    let fold = |mut c: Box4, r: &PrimRef| {
        let c2 = r.centroid2();
        c.grow(c2, c2);
        c
    };
    let merge = |mut a: Box4, b: Box4| {
        a.grow_box(&b);
        a
    };
    if refs.len() > PARALLEL_BINNING {
        refs.par_chunks(16384)
            .map(|chunk| chunk.iter().fold(Box4::EMPTY, fold))
            .reduce(|| Box4::EMPTY, merge)
    } else {
        refs.iter().fold(Box4::EMPTY, fold)
    }
}

struct Context<'a> {
    settings: &'a BuildSettings,
    bins: usize,
}

/// Where a subtree goes: its first reference slot, where its descendants' nodes start, its
/// bounds and centroid bounds, and its depth.
#[derive(Clone, Copy)]
struct Task {
    first: usize,
    below_start: usize,
    bounds: Box4,
    centroids: Box4,
    depth: usize,
}

/// One axis's bins: `MAX_BINS` of them, so a bin index (at most `MAX_BINS - 1`) masked to
/// `MAX_BINS - 1` needs no bounds check; a node uses the first `nb`.
type AxisBins = [Bin; MAX_BINS];

/// The bins of the three axes.
type Bins3 = [AxisBins; 3];

const _: () = assert!(MAX_BINS.is_power_of_two() && LANE_BINS.is_power_of_two());

fn new_bins() -> Box<Bins3> {
    vec![[EMPTY_BIN; MAX_BINS]; 3]
        .into_boxed_slice()
        .try_into()
        .expect("three axes")
}

thread_local! {
    /// A thread's spare [`Scratch`]: the split builders hand many small subtrees to this builder,
    /// and a fresh 37 KB scratch per subtree cost more than the subtrees' binning.
    static SPARE_SCRATCH: std::cell::Cell<Option<Box<Scratch>>> =
        const { std::cell::Cell::new(None) };
}

/// Runs `f` with this thread's spare scratch (a new one if it is in use further up the stack).
fn with_scratch<R>(f: impl FnOnce(&mut Scratch) -> R) -> R {
    let mut scratch = SPARE_SCRATCH
        .take()
        .unwrap_or_else(|| Box::new(Scratch::new()));
    let result = f(&mut scratch);
    SPARE_SCRATCH.set(Some(scratch));
    result
}

/// The most references a thread's spare partition buffer holds (4 MiB): a thread keeps one
/// only this large, or the root of a large scene would leave one its size on every thread.
const SPARE_REFS_MAX: usize = 1 << 17;

thread_local! {
    /// A thread's spare partition buffer (see [`with_other_buffer`]).
    static SPARE_REFS: std::cell::Cell<Vec<PrimRef>> = const { std::cell::Cell::new(Vec::new()) };
}

/// Per-thread working memory, reused down the recursion so small nodes allocate nothing.
struct Scratch {
    bins: Box<Bins3>,
    lanes: Box<BinLanes>,
    right_cost: Vec<f32>,
}

impl Scratch {
    fn new() -> Self {
        Scratch {
            bins: new_bins(),
            lanes: new_lanes(),
            right_cost: vec![0.0; MAX_BINS],
        }
    }
}

/// Consecutive references often fall into the same bin, and each then waits for the previous
/// one's update of that bin to be stored and loaded again. Nodes of [`LANES_MIN_REFS`] or more
/// references (with at most [`LANE_BINS`] bins) therefore bin in turn into [`BIN_LANES`]
/// copies of the bins, merged after: the merged bins equal one copy's exactly (minima, maxima
/// and integer sums), and the chains through a bin are a quarter as long.
pub(crate) const BIN_LANES: usize = 4;
const LANE_BINS: usize = 32;
pub(crate) const LANES_MIN_REFS: usize = 128;

/// The bins of the three axes in one lane.
type LaneBins3 = [[Bin; LANE_BINS]; 3];
type BinLanes = [LaneBins3; BIN_LANES];

fn new_lanes() -> Box<BinLanes> {
    Box::new([[[EMPTY_BIN; LANE_BINS]; 3]; BIN_LANES])
}

/// Hands `items` to `one(item, lane)` with consecutive items in consecutive lanes.
#[inline(always)]
pub(crate) fn in_lanes<T, L>(
    items: &[T],
    [a, b, c, d]: [&mut L; BIN_LANES],
    mut one: impl FnMut(&T, &mut L),
) {
    let quads = items.chunks_exact(BIN_LANES);
    let rest = quads.remainder();
    for q in quads {
        one(&q[0], a);
        one(&q[1], b);
        one(&q[2], c);
        one(&q[3], d);
    }
    for r in rest {
        one(r, a);
    }
}

/// The chosen split: references whose bin on `axis` is below `bin` go left.
struct Split {
    axis: usize,
    bin: usize,
    /// Bins per axis used for this node.
    nb: usize,
    cost: f32,
    left: Box4,
    right: Box4,
}

/// Maps doubled centroids to bin indices on all three axes at once.
#[derive(Clone, Copy)]
struct Binner {
    lo: Vec4,
    scale: Vec4,
    last: Vec4,
}

impl Binner {
    fn new(centroids: &Box4, bins: usize) -> Self {
        let extent = centroids.hi - centroids.lo;
        let scale = Vec4::select(
            extent.cmpgt(Vec4::ZERO),
            Vec4::splat(bins as f32 * (1.0 - 1e-6)) / extent,
            Vec4::ZERO,
        );
        Binner {
            lo: centroids.lo,
            scale,
            last: Vec4::splat((bins - 1) as f32),
        }
    }
    /// Bin indices on x, y, z (lane 3 is meaningless).
    #[inline(always)]
    fn bins(&self, c2: Vec4) -> [u32; 4] {
        bin_indices(c2, self.lo, self.scale, self.last)
    }
}

/// `min(max((c2 - lo) * scale, 0), last)` truncated to integers, lane by lane: the bin indices
/// of a doubled centroid `c2` (lanes whose `scale` is 0 get bin 0; lane 3 is meaningless).
#[inline(always)]
pub(crate) fn bin_indices(c2: Vec4, lo: Vec4, scale: Vec4, last: Vec4) -> [u32; 4] {
    truncate_lanes(((c2 - lo) * scale).max(Vec4::ZERO).min(last))
}

/// `f` truncated to integers lane by lane, for lanes in `[0, 2^31)` (what `as u32` gives
/// there); other lanes get unspecified values.
#[inline(always)]
pub(crate) fn truncate_lanes(f: Vec4) -> [u32; 4] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86_64 baseline. Lanes out of range (NaN, or values
        // past i32::MAX) convert to i32::MIN; callers only read lanes in range.
        unsafe {
            let v: __m128 = f.into();
            std::mem::transmute::<__m128i, [u32; 4]>(_mm_cvttps_epi32(v))
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        f.as_uvec4().to_array()
    }
}

impl Context<'_> {
    /// Builds the subtree of `node` over `refs`, its descendants in `slots`; returns its node
    /// count.
    fn build(
        &self,
        refs: Refs,
        node: &mut BvhNode,
        slots: Slots,
        task: Task,
        scratch: &mut Scratch,
    ) -> u32 {
        node.set_bounds(&task.bounds.to_aabb());
        let n = refs.cur.len();
        let s = self.settings;
        let split = if n <= s.unsplit_refs() || task.depth >= MEDIAN_DEPTH {
            None
        } else {
            self.find_split(refs.cur, &task, scratch)
        };
        let leaf_cost = s.intersection_cost * n as f32;
        let make_leaf = n <= s.unsplit_refs()
            || match &split {
                Some(sp) => n <= s.max_leaf_size && sp.cost >= leaf_cost,
                None => n <= s.max_leaf_size,
            };
        if make_leaf {
            if !refs.in_place {
                refs.other.copy_from_slice(refs.cur);
            }
            node.first = task.first as u32;
            node.count = n as u32;
            return 1;
        }
        let parts = split.and_then(|sp| {
            let binner = Binner::new(&task.centroids, sp.nb);
            let (src, dst) = (&*refs.cur, &mut *refs.other);
            let (mid, lc, rc) = match sp.axis {
                0 => partition::<0>(src, dst, sp.bin as u32, &binner),
                1 => partition::<1>(src, dst, sp.bin as u32, &binner),
                _ => partition::<2>(src, dst, sp.bin as u32, &binner),
            };
            (mid > 0 && mid < n).then_some((mid, (sp.left, lc), (sp.right, rc)))
        });
        let (refs, (mid, left, right)) = match parts {
            Some(parts) => (refs.swapped(), parts),
            // A partition that left one side empty wrote nothing `cur` still needs.
            None => {
                let median = median_split(refs.cur);
                (refs, median)
            }
        };

        let (pair, rest) = slots.below.split_at_mut(2);
        let (left_node, right_node) = pair.split_at_mut(1);
        let left_size = 2 * mid - 2;
        let (left_below, right_below) = rest.split_at_mut(left_size);
        let (pair_sizes, rest_sizes) = slots.sizes.split_at_mut(2);
        let (left_sizes, right_sizes) = rest_sizes.split_at_mut(left_size);
        let left_slots = Slots {
            below: left_below,
            sizes: left_sizes,
        };
        let right_slots = Slots {
            below: right_below,
            sizes: right_sizes,
        };
        node.first = task.below_start as u32;
        node.count = 0;
        let (left_refs, right_refs) = refs.split_at(mid);
        let left_task = Task {
            first: task.first,
            below_start: task.below_start + 2,
            bounds: left.0,
            centroids: left.1,
            depth: task.depth + 1,
        };
        let right_task = Task {
            first: task.first + mid,
            below_start: task.below_start + 2 + left_size,
            bounds: right.0,
            centroids: right.1,
            depth: task.depth + 1,
        };
        let (l, r) = if n > PARALLEL_SUBTREE {
            rayon::join(
                || self.build(left_refs, &mut left_node[0], left_slots, left_task, scratch),
                || {
                    with_scratch(|own| {
                        self.build(right_refs, &mut right_node[0], right_slots, right_task, own)
                    })
                },
            )
        } else {
            let l = self.build(left_refs, &mut left_node[0], left_slots, left_task, scratch);
            let r = self.build(
                right_refs,
                &mut right_node[0],
                right_slots,
                right_task,
                scratch,
            );
            (l, r)
        };
        pair_sizes[0] = l;
        pair_sizes[1] = r;
        1 + l + r
    }

    fn find_split(&self, refs: &[PrimRef], task: &Task, scratch: &mut Scratch) -> Option<Split> {
        // Small nodes need few bins: with n references at most n bins are occupied.
        let nb = self.bins.min(refs.len() + 2);
        let extent = (task.centroids.hi - task.centroids.lo).truncate();
        if extent.max_element() <= 0.0 {
            return None;
        }
        let binner = Binner::new(&task.centroids, nb);
        let Scratch {
            bins,
            lanes,
            right_cost,
            ..
        } = scratch;
        let bins: &mut Bins3 = bins;
        if refs.len() > PARALLEL_BINNING {
            *bins = *refs
                .par_chunks(16384)
                .map(|c| {
                    let mut local = new_bins();
                    bin_refs(c, &binner, nb, &mut local, &mut new_lanes());
                    local
                })
                .reduce(new_bins, |a, b| merge_bins(a, &b, nb));
        } else {
            clear_bins(bins, nb);
            bin_refs(refs, &binner, nb, bins, lanes);
        }
        let parent_area = task.bounds.half_area().max(f32::MIN_POSITIVE);
        let s = self.settings;
        let mut best: Option<(usize, usize, f32)> = None;
        for axis in 0..3 {
            if extent[axis] <= 0.0 {
                continue;
            }
            let axis_bins = &bins[axis][..nb];
            let right_cost = &mut right_cost[..nb];
            // Sweep from the right: right_cost[i] = area x count of bins i..nb. An empty bin
            // changes nothing, so its value is copied rather than recomputed.
            let mut acc = Box4::EMPTY;
            let mut count = 0u32;
            let mut cost = f32::NAN;
            for i in (1..nb).rev() {
                if axis_bins[i].count > 0 {
                    acc.grow_box(&axis_bins[i].bounds());
                    count += axis_bins[i].count;
                    cost = acc.half_area() * count as f32;
                }
                right_cost[i] = cost;
            }
            let mut acc = Box4::EMPTY;
            let mut count = 0u32;
            for i in 1..nb {
                let b = &axis_bins[i - 1];
                // A boundary after an empty bin repeats the previous partition: skip it.
                if b.count == 0 {
                    continue;
                }
                acc.grow_box(&b.bounds());
                count += b.count;
                // An empty right side has NaN cost and is never chosen.
                let cost = s.traversal_cost
                    + s.intersection_cost * (acc.half_area() * count as f32 + right_cost[i])
                        / parent_area;
                if best.is_none_or(|b| cost < b.2) {
                    best = Some((axis, i, cost));
                }
            }
        }
        let (axis, bin, cost) = best?;
        let axis_bins = &bins[axis][..nb];
        let mut left = Box4::EMPTY;
        let mut right = Box4::EMPTY;
        for (i, b) in axis_bins.iter().enumerate() {
            if i < bin {
                left.grow_box(&b.bounds());
            } else {
                right.grow_box(&b.bounds());
            }
        }
        Some(Split {
            axis,
            bin,
            nb,
            cost,
            left,
            right,
        })
    }
}

/// Empties the first `nb` bins of each axis.
fn clear_bins(bins: &mut Bins3, nb: usize) {
    for axis in bins.iter_mut() {
        axis[..nb].fill(EMPTY_BIN);
    }
}

/// Whether the builders' AVX binning loops run: AVX is present (and a test comparing them with
/// the portable loops has not turned them off on this thread).
#[inline]
pub(crate) fn use_avx() -> bool {
    #[cfg(test)]
    if PORTABLE_ONLY.get() {
        return false;
    }
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

#[cfg(test)]
thread_local! {
    /// Set by tests to run the portable binning loops on this thread.
    pub(crate) static PORTABLE_ONLY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f` with the portable binning loops and with the AVX ones (failing if AVX is absent:
/// then there is nothing to compare), for tests that the two agree.
#[cfg(test)]
pub(crate) fn portable_and_avx<R>(mut f: impl FnMut() -> R) -> (R, R) {
    assert!(
        use_avx(),
        "AVX not detected: the AVX binning loops cannot be compared"
    );
    PORTABLE_ONLY.set(true);
    let portable = f();
    PORTABLE_ONLY.set(false);
    (portable, f())
}

/// Bins `refs` by centroid on all three axes into `bins` (`nb` per axis), which the caller has
/// cleared; `lanes` is scratch for nodes that bin in lanes.
fn bin_refs(refs: &[PrimRef], binner: &Binner, nb: usize, bins: &mut Bins3, lanes: &mut BinLanes) {
    if refs.len() < LANES_MIN_REFS || nb > LANE_BINS {
        bin_refs_into(refs, binner, bins);
        return;
    }
    for lane in lanes.iter_mut() {
        for axis in lane.iter_mut() {
            axis[..nb].fill(EMPTY_BIN);
        }
    }
    let [a, b, c, d] = lanes;
    #[cfg(target_arch = "x86_64")]
    if use_avx() {
        // SAFETY: AVX is present (checked above).
        unsafe { bin_lanes_avx(refs, binner, [a, b, c, d]) };
    } else {
        in_lanes(refs, [a, b, c, d], |r, lane| bin_ref(r, binner, lane));
    }
    #[cfg(not(target_arch = "x86_64"))]
    in_lanes(refs, [a, b, c, d], |r, lane| bin_ref(r, binner, lane));
    for lane in lanes.iter() {
        for (into, from) in bins.iter_mut().zip(lane) {
            for (x, y) in into[..nb].iter_mut().zip(&from[..nb]) {
                x.corners.merge(&y.corners);
                x.count += y.count;
            }
        }
    }
}

/// [`bin_refs`] in one lane: straight into `bins`.
fn bin_refs_into(refs: &[PrimRef], binner: &Binner, bins: &mut Bins3) {
    #[cfg(target_arch = "x86_64")]
    if use_avx() {
        // SAFETY: AVX is present (checked above).
        unsafe { bin_refs_avx(refs, binner, bins) };
        return;
    }
    for r in refs {
        bin_ref(r, binner, bins);
    }
}

/// Bins one reference on all three axes.
#[inline(always)]
fn bin_ref<const N: usize>(r: &PrimRef, binner: &Binner, [bx, by, bz]: &mut [[Bin; N]; 3]) {
    let [ix, iy, iz, _] = binner.bins(r.centroid2());
    let neg_hi = -r.hi;
    // The indices are below nb <= N, a power of two: the masks only drop the bounds checks.
    for (axis, i) in [(bx, ix), (by, iy), (bz, iz)] {
        let bin = &mut axis[i as usize & (N - 1)];
        bin.corners.grow(r, neg_hi);
        bin.count += 1;
    }
}

/// [`bin_ref`] with each bin's two corners grown by one 8-lane `min`: a third of the
/// instructions per reference and axis, and one store instead of two on the chain through a
/// bin that consecutive references hit.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn bin_ref_avx<const N: usize>(r: &PrimRef, binner: &Binner, [bx, by, bz]: &mut [[Bin; N]; 3]) {
    let [ix, iy, iz, _] = binner.bins(r.centroid2());
    let corners = Corners::of_ref_avx(r);
    for (axis, i) in [(bx, ix), (by, iy), (bz, iz)] {
        let bin = &mut axis[i as usize & (N - 1)];
        bin.corners.grow_avx(corners);
        bin.count += 1;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn bin_refs_avx(refs: &[PrimRef], binner: &Binner, bins: &mut Bins3) {
    for r in refs {
        bin_ref_avx(r, binner, bins);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn bin_lanes_avx(refs: &[PrimRef], binner: &Binner, lanes: [&mut LaneBins3; BIN_LANES]) {
    // The closure has this function's target features.
    in_lanes(refs, lanes, |r, lane| bin_ref_avx(r, binner, lane));
}

fn merge_bins(mut a: Box<Bins3>, b: &Bins3, nb: usize) -> Box<Bins3> {
    for (xa, ya) in a.iter_mut().zip(b) {
        for (x, y) in xa[..nb].iter_mut().zip(&ya[..nb]) {
            x.corners.merge(&y.corners);
            x.count += y.count;
        }
    }
    a
}

/// Moves the references of `src` into `out` (as long), those whose bin on `AXIS` is below
/// `bin` to the front. Returns how many there are and the (doubled) centroid bounds of each
/// side. Branch-free: each reference is written to both ends of `out` and the side it belongs
/// to advances (the side a reference takes is as good as random, and a branch on it
/// mispredicted half the time). The left side keeps the references' order, the right side
/// reverses it.
fn partition<const AXIS: usize>(
    src: &[PrimRef],
    out: &mut [PrimRef],
    bin: u32,
    binner: &Binner,
) -> (usize, Box4, Box4) {
    let n = src.len();
    assert_eq!(out.len(), n, "one slot per reference");
    let mut lc = Box4::EMPTY;
    let mut rc = Box4::EMPTY;
    let (mut left, mut right) = (0, n);
    for r in src {
        let c = r.centroid2();
        let goes_left = binner.bins(c)[AXIS] < bin;
        // Before this reference, left + (n - right) references were placed, fewer than n, so
        // both slots are in `out`; the one of the other side is overwritten later.
        out[left] = *r;
        out[right - 1] = *r;
        left += goes_left as usize;
        right -= !goes_left as usize;
        let mask = glam::BVec4A::splat(goes_left);
        lc.grow(Vec4::select(mask, c, lc.lo), Vec4::select(mask, c, lc.hi));
        rc.grow(Vec4::select(mask, rc.lo, c), Vec4::select(mask, rc.hi, c));
    }
    (left, lc, rc)
}

/// Splits at the middle reference along the widest centroid axis (used when the SAH finds no
/// split, e.g. all centroids coincide, and past `MEDIAN_DEPTH`).
fn median_split(refs: &mut [PrimRef]) -> (usize, (Box4, Box4), (Box4, Box4)) {
    let mid = refs.len() / 2;
    let (_, c) = bounds_of(refs);
    let axis = (c.hi - c.lo).truncate().max_position();
    refs.select_nth_unstable_by(mid, |a, b| {
        a.centroid2()[axis]
            .total_cmp(&b.centroid2()[axis])
            .then(a.id().cmp(&b.id()))
    });
    let left = bounds_of(&refs[..mid]);
    let right = bounds_of(&refs[mid..]);
    (mid, left, right)
}

/// Renumbers the reachable nodes depth-first, keeping each sibling pair adjacent and at an even
/// index (after the root and one pad node), as [`NodeArray`] needs. `sizes[i]` is the node count
/// of node i's subtree, so every subtree's place is known up front and large subtrees are
/// copied in parallel.
fn compact(nodes: &[BvhNode], sizes: &[u32]) -> Vec<BvhNode> {
    let total = sizes[0] as usize;
    let mut out = zeroed_nodes(total + 1);
    out[0] = nodes[0];
    if !nodes[0].is_leaf() {
        place_below(nodes, sizes, &mut out[2..], 2, 0);
        out[0].first = 2;
    }
    out
}

/// Writes the descendants of `nodes[old]` (an interior node) into `out`, whose first slot is
/// index `at` of the final array: its child pair first, then the left child's descendants,
/// then the right child's (the order of a depth-first walk that visits left first).
fn place_below(nodes: &[BvhNode], sizes: &[u32], out: &mut [BvhNode], at: usize, old: usize) {
    let c = nodes[old].first as usize;
    let (pair, rest) = out.split_at_mut(2);
    pair[0] = nodes[c];
    pair[1] = nodes[c + 1];
    let left_len = sizes[c] as usize - 1;
    let (left_out, right_out) = rest.split_at_mut(left_len);
    let (left_at, right_at) = (at + 2, at + 2 + left_len);
    let inner = [!pair[0].is_leaf(), !pair[1].is_leaf()];
    if inner[0] {
        pair[0].first = left_at as u32;
    }
    if inner[1] {
        pair[1].first = right_at as u32;
    }
    let go = |out: &mut [BvhNode], at: usize, child: usize| {
        if inner[child - c] {
            place_below(nodes, sizes, out, at, child);
        }
    };
    if left_len + right_out.len() > PARALLEL_COMPACT {
        rayon::join(
            || go(left_out, left_at, c),
            || go(right_out, right_at, c + 1),
        );
    } else {
        go(left_out, left_at, c);
        go(right_out, right_at, c + 1);
    }
}

/// The serial form of [`compact`]: the same layout from one depth-first walk that visits left
/// children first; `total` is the compacted length (the root's subtree size plus the pad).
fn compact_depth_first(nodes: &[BvhNode], total: usize) -> Vec<BvhNode> {
    let mut out = Vec::with_capacity(total);
    out.extend([nodes[0], BvhNode::default()]);
    // A pending right child per level at most, so the stack stays within the depth bound.
    let mut stack = Vec::with_capacity(MAX_DEPTH + 2);
    stack.push(0usize);
    while let Some(i) = stack.pop() {
        if out[i].is_leaf() {
            continue;
        }
        let old = out[i].first as usize;
        let k = out.len();
        out.extend([nodes[old], nodes[old + 1]]);
        out[i].first = k as u32;
        stack.push(k + 1);
        stack.push(k);
    }
    out
}

/// Subtrees with more nodes than this are compacted in parallel.
const PARALLEL_COMPACT: usize = 8192;

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize) -> Vec<[Vec3; 3]> {
        let mut t = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let p = Vec3::new(i as f32, j as f32, ((i * 7 + j * 3) % 5) as f32);
                t.push([p, p + Vec3::X, p + Vec3::Y]);
            }
        }
        t
    }

    /// The references of [`grid`]`(n)`, ids in order.
    fn grid_refs(n: usize) -> Vec<PrimRef> {
        grid(n)
            .iter()
            .enumerate()
            .map(|(i, t)| PrimRef::of_triangle(i as u32, t))
            .collect()
    }

    #[test]
    fn partition_splits_by_bin_and_bounds_each_side() {
        let tris = crate::bvh::object_split::tests::scattered(3000);
        let refs = crate::bvh::object_split::tests::refs_of(&tris);
        let (_, centroids) = bounds_of(&refs);
        let binner = Binner::new(&centroids, 16);
        for (axis, bin) in [(0, 5u32), (1, 1), (2, 15), (0, 0)] {
            // Stale references in the output, as a thread's spare buffer holds.
            let mut parted = vec![refs[7]; refs.len()];
            let (mid, lc, rc) = match axis {
                0 => partition::<0>(&refs, &mut parted, bin, &binner),
                1 => partition::<1>(&refs, &mut parted, bin, &binner),
                _ => partition::<2>(&refs, &mut parted, bin, &binner),
            };
            let goes_left = |r: &PrimRef| binner.bins(r.centroid2())[axis] < bin;
            let ids = |rs: &[PrimRef]| {
                let mut v: Vec<u32> = rs.iter().map(|r| r.id()).collect();
                v.sort_unstable();
                v
            };
            let want_left: Vec<PrimRef> = refs.iter().copied().filter(goes_left).collect();
            let want_right: Vec<PrimRef> = refs.iter().copied().filter(|r| !goes_left(r)).collect();
            assert_eq!(mid, want_left.len(), "axis {axis} bin {bin}");
            assert_eq!(ids(&parted[..mid]), ids(&want_left));
            assert_eq!(ids(&parted[mid..]), ids(&want_right));
            if !want_left.is_empty() {
                assert_eq!(lc, centroid_bounds_of(&want_left));
            }
            if !want_right.is_empty() {
                assert_eq!(rc, centroid_bounds_of(&want_right));
            }
        }
    }

    #[test]
    fn avx_binning_equals_portable_binning() {
        let tris = crate::bvh::object_split::tests::scattered(5000);
        let refs = crate::bvh::object_split::tests::refs_of(&tris);
        let (_, centroids) = bounds_of(&refs);
        for nb in [2, 16, 37] {
            let binner = Binner::new(&centroids, nb);
            let (portable, avx) = portable_and_avx(|| {
                let mut bins = new_bins();
                bin_refs(&refs, &binner, nb, &mut bins, &mut new_lanes());
                bins
            });
            assert!(
                portable == avx,
                "{nb} bins: AVX and portable binning differ"
            );
            // The lanes (2 and 16 bins) merge to what one lane bins, on both paths.
            let (one_portable, one_avx) = portable_and_avx(|| {
                let mut bins = new_bins();
                bin_refs_into(&refs, &binner, &mut bins);
                bins
            });
            assert!(
                portable == one_portable && avx == one_avx,
                "{nb} bins: lanes differ"
            );
            let binned: u32 = portable[0][..nb].iter().map(|b| b.count).sum();
            assert_eq!(binned as usize, refs.len());
        }
    }

    #[test]
    fn id_lane_roundtrips_and_is_never_denormal() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        for id in [
            0,
            1,
            7,
            1 << 20,
            (1 << 23) - 1,
            1 << 23,
            (1 << 30) - 1,
            u32::MAX,
        ] {
            let r = PrimRef::of_triangle(id, &t);
            assert_eq!(r.id(), id);
            assert_eq!(PrimRef::new(id, r.bounds()).id(), id);
            if id < 1 << 30 {
                assert!(!r.lo.w.is_subnormal(), "id {id} stored as a denormal");
                assert!(
                    !r.centroid2().w.is_subnormal(),
                    "id {id}: centroid lane denormal"
                );
            }
        }
    }

    #[test]
    fn every_triangle_in_one_leaf_and_boxes_nest() {
        for n in [1, 2, 3, 10, 100] {
            let tris = grid(n);
            let bvh = build_binned_sah(&tris, &BuildSettings::default());
            bvh.validate().unwrap();
            let mut ids = bvh.triangle_ids.clone();
            ids.sort();
            assert_eq!(ids, (0..tris.len() as u32).collect::<Vec<_>>());
            for (slot, &id) in bvh.triangle_ids.iter().enumerate() {
                assert_eq!(bvh.triangles[slot], tris[id as usize]);
            }
        }
    }

    #[test]
    fn parallel_compaction_equals_serial_renumbering() {
        // 200^2 triangles: subtrees above PARALLEL_COMPACT nodes take the parallel path.
        for n in [1, 3, 200] {
            let mut refs = grid_refs(n);
            let (nodes, sizes) = build_uncompacted(&mut refs, &BuildSettings::default(), 0);
            let serial = compact_depth_first(&nodes, sizes[0] as usize + 1);
            assert_eq!(compact(&nodes, &sizes), serial);
        }
    }

    #[test]
    fn subtrees_built_over_stale_spare_arrays_equal_fresh_builds() {
        // Larger subtrees first leave their nodes in this thread's spare arrays; the smaller
        // builds after them must not see them. 260^2 references take the zeroed arrays of
        // their own, 80^2 the spares and the parallel compaction, the rest the depth-first one.
        let settings = BuildSettings::default();
        const { assert!(2 * 260 * 260 > SPARE_NODES_MAX && 2 * 80 * 80 > PARALLEL_SUBTREE) };
        for n in [260, 80, 40, 3, 12, 1] {
            let refs = grid_refs(n);
            let (mut a, mut b) = (refs.clone(), refs);
            let spare = build_sah_nodes(&mut a, &settings, 3);
            let (nodes, sizes) = build_uncompacted(&mut b, &settings, 3);
            assert_eq!(spare, compact(&nodes, &sizes), "grid({n})");
            let ids = |r: &[PrimRef]| r.iter().map(|r| r.id()).collect::<Vec<_>>();
            assert_eq!(ids(&a), ids(&b), "leaf order of grid({n})");
        }
    }

    #[test]
    fn a_thread_keeps_its_partition_buffer_only_up_to_the_bound() {
        // The root is binned and partitioned on the calling thread, with its spare scratch.
        let settings = BuildSettings::default();
        for (n, kept) in [(60, true), (400, false)] {
            let mut refs = grid_refs(n);
            SPARE_REFS.take();
            build_sah_nodes(&mut refs, &settings, 0);
            let spare = SPARE_REFS.take();
            let capacity = spare.capacity();
            assert!(
                capacity <= SPARE_REFS_MAX,
                "grid({n}) kept {capacity} references"
            );
            assert_eq!(capacity >= refs.len(), kept, "grid({n}) kept {capacity}");
        }
    }

    #[test]
    fn coincident_triangles_stay_within_depth_and_leaf_size() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let tris = vec![t; 1000];
        let s = BuildSettings::default();
        let bvh = build_binned_sah(&tris, &s);
        bvh.validate().unwrap();
        assert!(bvh
            .nodes
            .iter()
            .all(|n| n.count as usize <= s.max_leaf_size));
    }

    #[test]
    fn geometric_sequence_does_not_exceed_depth() {
        // Triangles at x = 2^-k: SAH peels one at a time; the median fallback bounds the depth.
        let tris: Vec<_> = (0..2000)
            .map(|k| {
                let x = 1e30f32 * 0.9f32.powi(k);
                [
                    Vec3::new(x, 0.0, 0.0),
                    Vec3::new(x, 1.0, 0.0),
                    Vec3::new(x, 0.0, 1.0),
                ]
            })
            .collect();
        let bvh = build_binned_sah(&tris, &BuildSettings::default());
        bvh.validate().unwrap();
        assert!(bvh.depth() <= MAX_DEPTH);
    }
}
