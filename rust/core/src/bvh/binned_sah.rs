//! Binned SAH build (Wald 2007): primitive centroids are binned along each axis, the best of the
//! bin boundaries by surface-area cost splits the node. Subtrees are built in parallel with
//! rayon; each subtree writes into its own disjoint part of one preallocated node array, which a
//! final pass compacts into depth-first order with sibling pairs adjacent.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::node::{Bvh, BvhNode, MAX_DEPTH};
use crate::geometry::Aabb;

/// Settings of the binned SAH builder.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BuildSettings {
    /// Bins per axis (2..=256). More bins find better splits at a higher build cost.
    pub bins: usize,
    /// Leaves never hold more triangles than this (1..=64).
    pub max_leaf_size: usize,
    /// SAH cost of one traversal step, relative to `intersection_cost`.
    pub traversal_cost: f32,
    /// SAH cost of one ray/triangle test.
    pub intersection_cost: f32,
}

impl Default for BuildSettings {
    fn default() -> Self {
        BuildSettings {
            bins: 16,
            max_leaf_size: 8,
            traversal_cost: 1.0,
            intersection_cost: 1.0,
        }
    }
}

impl BuildSettings {
    pub fn validate(&self) -> crate::Result<()> {
        if !(2..=256).contains(&self.bins) {
            return Err(crate::Error::invalid(
                "build.bins",
                format!("must be in 2..=256, got {}", self.bins),
            ));
        }
        if !(1..=64).contains(&self.max_leaf_size) {
            return Err(crate::Error::invalid(
                "build.max_leaf_size",
                format!("must be in 1..=64, got {}", self.max_leaf_size),
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
        Ok(())
    }
}

/// A triangle's box and its id; what the builder partitions.
#[derive(Clone, Copy, Debug)]
struct PrimRef {
    min: Vec3,
    id: u32,
    max: Vec3,
}

impl PrimRef {
    #[inline]
    fn centroid(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    centroids: Aabb,
    count: u32,
}

const EMPTY_BIN: Bin = Bin {
    bounds: Aabb::EMPTY,
    centroids: Aabb::EMPTY,
    count: 0,
};

/// Subtrees smaller than this are built on the current thread.
const PARALLEL_SUBTREE: usize = 4096;
/// Nodes with more references than this bin in parallel.
const PARALLEL_BINNING: usize = 65536;
/// Past this depth, splits are object medians so the depth bound holds on any input.
const MEDIAN_DEPTH: usize = MAX_DEPTH - 33;

/// Builds a binned SAH BVH over `triangles` (the BVH keeps a leaf-ordered copy).
pub fn build_binned_sah(triangles: &[[Vec3; 3]], settings: &BuildSettings) -> Bvh {
    let start = Instant::now();
    let mut refs: Vec<PrimRef> = triangles
        .par_iter()
        .enumerate()
        .map(|(i, t)| {
            let b = Aabb::of_triangle(t);
            PrimRef {
                min: b.min,
                id: i as u32,
                max: b.max,
            }
        })
        .collect();
    let mut bvh = build_from_refs(&mut refs, settings);
    bvh.triangles = refs.par_iter().map(|r| triangles[r.id as usize]).collect();
    bvh.triangle_ids = refs.iter().map(|r| r.id).collect();
    bvh.build_ms = start.elapsed().as_secs_f64() * 1e3;
    bvh
}

fn build_from_refs(refs: &mut [PrimRef], settings: &BuildSettings) -> Bvh {
    let n = refs.len();
    if n == 0 {
        return Bvh::default();
    }
    let (bounds, centroids) = bounds_of(refs);
    // A subtree over k references uses at most 2k - 2 nodes below its root.
    let mut nodes = vec![BvhNode::default(); 2 * n - 1];
    let (root, below) = nodes.split_at_mut(1);
    let ctx = Context { settings };
    ctx.build(refs, 0, &mut root[0], below, 1, bounds, centroids, 0);
    Bvh {
        nodes: compact(&nodes),
        ..Bvh::default()
    }
}

fn bounds_of(refs: &[PrimRef]) -> (Aabb, Aabb) {
    let fold = |(mut b, mut c): (Aabb, Aabb), r: &PrimRef| {
        b.grow(&Aabb::new(r.min, r.max));
        c.grow_point(r.centroid());
        (b, c)
    };
    if refs.len() > PARALLEL_BINNING {
        refs.par_chunks(16384)
            .map(|chunk| chunk.iter().fold((Aabb::EMPTY, Aabb::EMPTY), fold))
            .reduce(
                || (Aabb::EMPTY, Aabb::EMPTY),
                |a, b| (a.0.union(&b.0), a.1.union(&b.1)),
            )
    } else {
        refs.iter().fold((Aabb::EMPTY, Aabb::EMPTY), fold)
    }
}

struct Context<'a> {
    settings: &'a BuildSettings,
}

/// The chosen split: references with bin index < `bin` on `axis` go left.
struct Split {
    axis: usize,
    bin: usize,
    cost: f32,
    left: (Aabb, Aabb),
    right: (Aabb, Aabb),
}

impl Context<'_> {
    #[allow(clippy::too_many_arguments)]
    fn build(
        &self,
        refs: &mut [PrimRef],
        first: usize,
        node: &mut BvhNode,
        below: &mut [BvhNode],
        below_start: usize,
        bounds: Aabb,
        centroids: Aabb,
        depth: usize,
    ) {
        node.set_bounds(&bounds);
        let n = refs.len();
        let s = self.settings;
        let leaf_cost = s.intersection_cost * n as f32;
        let split = if n <= 1 {
            None
        } else if depth >= MEDIAN_DEPTH {
            None
        } else {
            self.find_split(refs, &bounds, &centroids)
        };
        let make_leaf = match &split {
            _ if n <= 1 => true,
            Some(sp) => n <= s.max_leaf_size && sp.cost >= leaf_cost,
            None => n <= s.max_leaf_size,
        };
        if make_leaf {
            node.first = first as u32;
            node.count = n as u32;
            return;
        }
        let (mid, left, right) = match split {
            Some(sp) => {
                let mid = partition(refs, sp.axis, sp.bin, &centroids, self.settings.bins);
                if mid == 0 || mid == n {
                    median_split(refs)
                } else {
                    (mid, sp.left, sp.right)
                }
            }
            None => median_split(refs),
        };
        let (pair, rest) = below.split_at_mut(2);
        let (left_node, right_node) = pair.split_at_mut(1);
        let left_size = 2 * mid - 2;
        let (left_below, right_below) = rest.split_at_mut(left_size);
        node.first = below_start as u32;
        node.count = 0;
        let (left_refs, right_refs) = refs.split_at_mut(mid);
        let mut build_left = || {
            self.build(
                left_refs,
                first,
                &mut left_node[0],
                left_below,
                below_start + 2,
                left.0,
                left.1,
                depth + 1,
            )
        };
        let mut build_right = || {
            self.build(
                right_refs,
                first + mid,
                &mut right_node[0],
                right_below,
                below_start + 2 + left_size,
                right.0,
                right.1,
                depth + 1,
            )
        };
        if n > PARALLEL_SUBTREE {
            rayon::join(build_left, build_right);
        } else {
            build_left();
            build_right();
        }
    }

    fn find_split(&self, refs: &[PrimRef], bounds: &Aabb, centroids: &Aabb) -> Option<Split> {
        let nb = self.settings.bins;
        let extent = centroids.extent();
        if extent.max_element() <= 0.0 {
            return None;
        }
        let bins = if refs.len() > PARALLEL_BINNING {
            refs.par_chunks(16384)
                .map(|c| bin_refs(c, centroids, nb))
                .reduce(|| vec![EMPTY_BIN; 3 * nb], merge_bins)
        } else {
            bin_refs(refs, centroids, nb)
        };
        let parent_area = bounds.half_area().max(f32::MIN_POSITIVE);
        let s = self.settings;
        let mut best: Option<Split> = None;
        let mut right_acc = vec![(Aabb::EMPTY, Aabb::EMPTY, 0u32); nb];
        for axis in 0..3 {
            if extent[axis] <= 0.0 {
                continue;
            }
            let axis_bins = &bins[axis * nb..(axis + 1) * nb];
            // Sweep from the right: right_acc[i] holds bins i..nb.
            let mut acc = (Aabb::EMPTY, Aabb::EMPTY, 0u32);
            for i in (1..nb).rev() {
                acc.0.grow(&axis_bins[i].bounds);
                acc.1.grow(&axis_bins[i].centroids);
                acc.2 += axis_bins[i].count;
                right_acc[i] = acc;
            }
            let mut left = (Aabb::EMPTY, Aabb::EMPTY, 0u32);
            for i in 1..nb {
                let b = &axis_bins[i - 1];
                left.0.grow(&b.bounds);
                left.1.grow(&b.centroids);
                left.2 += b.count;
                let right = &right_acc[i];
                if left.2 == 0 || right.2 == 0 {
                    continue;
                }
                let cost = s.traversal_cost
                    + s.intersection_cost
                        * (left.0.half_area() * left.2 as f32
                            + right.0.half_area() * right.2 as f32)
                        / parent_area;
                if best.as_ref().is_none_or(|b| cost < b.cost) {
                    best = Some(Split {
                        axis,
                        bin: i,
                        cost,
                        left: (left.0, left.1),
                        right: (right.0, right.1),
                    });
                }
            }
        }
        best
    }
}

#[inline]
fn bin_index(c: f32, lo: f32, scale: f32, nb: usize) -> usize {
    (((c - lo) * scale) as usize).min(nb - 1)
}

#[inline]
fn bin_scale(centroids: &Aabb, axis: usize, nb: usize) -> f32 {
    let e = centroids.extent()[axis];
    if e > 0.0 {
        nb as f32 * (1.0 - 1e-6) / e
    } else {
        0.0
    }
}

fn bin_refs(refs: &[PrimRef], centroids: &Aabb, nb: usize) -> Vec<Bin> {
    let mut bins = vec![EMPTY_BIN; 3 * nb];
    let scale = [0, 1, 2].map(|a| bin_scale(centroids, a, nb));
    for r in refs {
        let c = r.centroid();
        let b = Aabb::new(r.min, r.max);
        for axis in 0..3 {
            let i = axis * nb + bin_index(c[axis], centroids.min[axis], scale[axis], nb);
            let bin = &mut bins[i];
            bin.bounds.grow(&b);
            bin.centroids.grow_point(c);
            bin.count += 1;
        }
    }
    bins
}

fn merge_bins(mut a: Vec<Bin>, b: Vec<Bin>) -> Vec<Bin> {
    for (x, y) in a.iter_mut().zip(&b) {
        x.bounds.grow(&y.bounds);
        x.centroids.grow(&y.centroids);
        x.count += y.count;
    }
    a
}

/// Moves references with bin index < `bin` to the front; returns how many there are.
fn partition(refs: &mut [PrimRef], axis: usize, bin: usize, centroids: &Aabb, nb: usize) -> usize {
    let scale = bin_scale(centroids, axis, nb);
    let lo = centroids.min[axis];
    let goes_left = |r: &PrimRef| bin_index(r.centroid()[axis], lo, scale, nb) < bin;
    let mut i = 0;
    let mut j = refs.len();
    while i < j {
        if goes_left(&refs[i]) {
            i += 1;
        } else {
            j -= 1;
            refs.swap(i, j);
        }
    }
    i
}

/// Splits at the middle reference along the widest centroid axis (used when the SAH finds no
/// split, e.g. all centroids coincide, and past `MEDIAN_DEPTH`).
fn median_split(refs: &mut [PrimRef]) -> (usize, (Aabb, Aabb), (Aabb, Aabb)) {
    let mid = refs.len() / 2;
    let (_, c) = bounds_of(refs);
    let axis = c.extent().max_position();
    refs.select_nth_unstable_by(mid, |a, b| {
        a.centroid()[axis]
            .total_cmp(&b.centroid()[axis])
            .then(a.id.cmp(&b.id))
    });
    let left = bounds_of(&refs[..mid]);
    let right = bounds_of(&refs[mid..]);
    (mid, left, right)
}

/// Renumbers the reachable nodes depth-first, keeping each sibling pair adjacent.
fn compact(nodes: &[BvhNode]) -> Vec<BvhNode> {
    let mut out = Vec::with_capacity(nodes.len());
    out.push(nodes[0]);
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        if out[i].is_leaf() {
            continue;
        }
        let old = out[i].first as usize;
        let k = out.len();
        out.push(nodes[old]);
        out.push(nodes[old + 1]);
        out[i].first = k as u32;
        stack.push(k + 1);
        stack.push(k);
    }
    out.shrink_to_fit();
    out
}

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
