//! Binned SAH build (Wald 2007): primitive centroids are binned along each axis, the best of the
//! bin boundaries by surface-area cost splits the node. Subtrees are built in parallel with
//! rayon; each subtree writes into its own disjoint part of one preallocated node array, which a
//! final pass compacts into depth-first order with sibling pairs adjacent.

use std::time::Instant;

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use super::binning::Binner;
use super::primref::{bounds_of, Box4, PrimRef};
use super::scratch::{
    put_spare_nodes, take_spare_nodes, with_other_buffer, with_sah_scratch, SahScratch,
    SPARE_NODES_MAX,
};
use super::settings::{BuildSettings, MAX_BINS};
use crate::bvh::{zeroed_vec, Bvh, BvhNode, NodeArray, MAX_DEPTH};
use crate::geometry::Aabb;

/// Subtrees smaller than this are built on the current thread.
pub(crate) const PARALLEL_SUBTREE: usize = 4096;
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

/// Binned SAH over boxes (a top level over instances): leaves index `boxes` through
/// `triangle_ids`, in leaf order; `triangles` stays empty.
pub fn build_over_boxes(boxes: &[Aabb], settings: &BuildSettings) -> Bvh {
    let start = Instant::now();
    let mut refs: Vec<PrimRef> = boxes
        .par_iter()
        .enumerate()
        .map(|(i, b)| {
            let bounds = Box4 {
                lo: b.min.extend(0.0),
                hi: b.max.extend(0.0),
            };
            PrimRef::new(i as u32, bounds)
        })
        .collect();
    let mut bvh = build_from_refs(&mut refs, settings);
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
    let (mut nodes, mut sizes) = take_spare_nodes().unwrap_or_default();
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
    put_spare_nodes(nodes, sizes);
    out
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
        with_sah_scratch(|scratch| ctx.build(refs, &mut root[0], slots, task, scratch))
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

impl Context<'_> {
    /// Builds the subtree of `node` over `refs`, its descendants in `slots`; returns its node
    /// count.
    fn build(
        &self,
        refs: Refs,
        node: &mut BvhNode,
        slots: Slots,
        task: Task,
        scratch: &mut SahScratch,
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
                    with_sah_scratch(|own| {
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

    fn find_split(&self, refs: &[PrimRef], task: &Task, scratch: &mut SahScratch) -> Option<Split> {
        // Small nodes need few bins: with n references at most n bins are occupied.
        let nb = self.bins.min(refs.len() + 2);
        let extent = (task.centroids.hi - task.centroids.lo).truncate();
        if extent.max_element() <= 0.0 {
            return None;
        }
        let binner = Binner::new(&task.centroids, nb);
        let SahScratch { bins, right_cost } = scratch;
        let bins = bins.bin(refs, &binner, nb);
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
                if axis_bins[i].count() > 0 {
                    acc.grow_box(&axis_bins[i].bounds());
                    count += axis_bins[i].count();
                    cost = acc.half_area() * count as f32;
                }
                right_cost[i] = cost;
            }
            let mut acc = Box4::EMPTY;
            let mut count = 0u32;
            for i in 1..nb {
                let b = &axis_bins[i - 1];
                // A boundary after an empty bin repeats the previous partition: skip it.
                if b.count() == 0 {
                    continue;
                }
                acc.grow_box(&b.bounds());
                count += b.count();
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
    use crate::build::primref::centroid_bounds_of;
    use crate::build::primref::tests::{refs_of, scattered};
    use crate::build::scratch::{SPARE_REFS, SPARE_REFS_MAX};

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
        let tris = scattered(3000);
        let refs = refs_of(&tris);
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
