//! The builder of SBVH, ABVH and OSAH trees. Per node it finds the best object and spatial
//! split by SAH and, in OSAH nodes that hold both visible and invisible references, by the
//! occlusion heuristic, and takes the OSAH split if it is viable. Subtrees that need neither
//! spatial nor visibility splits (ABVH/OSAH nodes without visible references) are handed to the
//! fast binned SAH builder and grafted in, which is why these builds cost little more than SAH
//! when few triangles are visible.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use super::object_split::{
    best_object_splits, median_split, partition_object, ChildSummary, ObjectSplit,
};
use super::osah_cost::{osah_viable, CostModel, Sides};
use super::primref::{bounds_of, count_visible, Box4, PrimRef};
use super::sah::{build_sah_nodes, MEDIAN_DEPTH, PARALLEL_SUBTREE};
use super::settings::{BuildSettings, SpatialAxes};
use super::spatial_split::{best_spatial_splits, partition_spatial, SpatialSplit, Unsplit};
use crate::bvh::{Bvh, BvhNode, NodeArray};

/// Where a builder may use spatial splits and visibility-driven splits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum SplitPolicy {
    /// Spatial splits everywhere (Stich et al.).
    Sbvh,
    /// Spatial splits only in nodes with visible triangles; SAH elsewhere.
    Abvh,
    /// ABVH plus OSAH splits in mixed nodes near the root, more-visible child first.
    Osah,
}

/// Builds a tree over `triangles` with `policy`; `visible[i]` flags triangle i (ignored by SBVH).
pub(super) fn build_split_bvh(
    triangles: &[[Vec3; 3]],
    visible: Option<&[bool]>,
    policy: SplitPolicy,
    settings: &BuildSettings,
) -> Bvh {
    let start = Instant::now();
    let n = triangles.len();
    if n == 0 {
        return Bvh::default();
    }
    if let Some(v) = visible {
        assert_eq!(v.len(), n, "one visibility flag per triangle");
    }
    // SBVH ignores visibility: its references are all unmarked, so every count is 0.
    let flags = visible.filter(|_| policy != SplitPolicy::Sbvh);
    let refs: Vec<PrimRef> = triangles
        .par_iter()
        .enumerate()
        .map(|(i, t)| {
            PrimRef::of_triangle(i as u32, t).with_visibility(flags.is_some_and(|v| v[i]))
        })
        .collect();
    let (bounds, centroids) = bounds_of(&refs);
    let builder = Builder {
        triangles,
        settings,
        policy,
        model: CostModel {
            traversal: settings.traversal_cost,
            intersection: settings.intersection_cost,
            weight: settings.osah_weight,
        },
        root_area: bounds.half_area().max(f32::MIN_POSITIVE),
        osah_max_depth: 0.5 * (n as f32).log2(),
    };
    let budget = (settings.spatial.max_growth as f64 * n as f64) as usize;
    let visible = count_visible(&refs);
    let tree = builder.node(refs, (bounds, centroids), visible, 0, budget);
    let (nodes, ids) = flatten(tree);
    let mut bvh = Bvh {
        nodes,
        triangles: ids.par_iter().map(|&id| triangles[id as usize]).collect(),
        triangle_ids: ids,
        build_ms: 0.0,
    };
    bvh.build_ms = start.elapsed().as_secs_f64() * 1e3;
    bvh
}

/// A subtree under construction.
enum Built {
    Leaf(Box4, Vec<PrimRef>),
    Inner(Box4, Box<[Built; 2]>, Size),
    /// A binned SAH subtree: its compacted nodes, leaf ranges indexing its references.
    Sah(Vec<BvhNode>, Vec<PrimRef>),
}

/// The nodes below a subtree's root and the references under it, which place it in the
/// final arrays.
#[derive(Clone, Copy)]
struct Size {
    below: usize,
    refs: usize,
}

impl Built {
    fn size(&self) -> Size {
        match self {
            Built::Leaf(_, refs) => Size {
                below: 0,
                refs: refs.len(),
            },
            Built::Inner(_, _, size) => *size,
            // Root, pad, then the descendants.
            Built::Sah(nodes, refs) => Size {
                below: nodes.len().saturating_sub(2),
                refs: refs.len(),
            },
        }
    }
}

struct Builder<'a> {
    triangles: &'a [[Vec3; 3]],
    settings: &'a BuildSettings,
    policy: SplitPolicy,
    model: CostModel,
    root_area: f32,
    osah_max_depth: f32,
}

/// The split a node takes.
enum Choice {
    Object(ObjectSplit),
    Spatial(SpatialSplit, Unsplit),
}

impl Builder<'_> {
    /// Builds the subtree over `refs` (`visible` of them visible; counted once, by the parent,
    /// as are their bounds and doubled-centroid bounds, `bounds_of(&refs)`).
    fn node(
        &self,
        mut refs: Vec<PrimRef>,
        (bounds, centroids): (Box4, Box4),
        visible: u32,
        depth: usize,
        budget: usize,
    ) -> Built {
        let n = refs.len();
        let spatial = self.settings.spatial.enabled
            && depth < MEDIAN_DEPTH
            && n >= self.settings.spatial.min_refs
            && (self.policy == SplitPolicy::Sbvh || visible > 0);
        let mixed = visible > 0 && (visible as usize) < n;
        let osah =
            self.policy == SplitPolicy::Osah && mixed && (depth as f32) <= self.osah_max_depth;
        if !spatial && !osah {
            let nodes = build_sah_nodes(&mut refs, self.settings, depth);
            return Built::Sah(nodes, refs);
        }
        if n <= self.settings.unsplit_refs() {
            return Built::Leaf(bounds, refs);
        }
        let (choice, cost) = self.choose(&refs, &bounds, &centroids, spatial, osah, budget);
        let leaf_cost = self.settings.intersection_cost * n as f32;
        if n <= self.settings.max_leaf_size && cost.is_none_or(|c| c >= leaf_cost) {
            return Built::Leaf(bounds, refs);
        }
        let (mut left, mut right, mut known) = match choice {
            Some(Choice::Spatial(s, unsplit)) => {
                let (left, right) = partition_spatial(refs, self.triangles, &s, unsplit);
                (left, right, None)
            }
            Some(Choice::Object(s)) => partition_object(refs, &s),
            None => {
                let (left, right) = median_split(refs, &centroids);
                (left, right, None)
            }
        };
        if left.is_empty() || right.is_empty() {
            let mut all = left;
            all.append(&mut right);
            (left, right) = median_split(all, &centroids);
            known = None;
        }
        let [mut l_sum, mut r_sum] = known.unwrap_or_else(|| [summary(&left), summary(&right)]);
        // OSAH: the child with more visible references first, so that a traversal that takes
        // the left child on equal entry distances reaches visible triangles first.
        if self.policy == SplitPolicy::Osah && mixed && r_sum.visible > l_sum.visible {
            std::mem::swap(&mut left, &mut right);
            std::mem::swap(&mut l_sum, &mut r_sum);
        }
        let grown = (left.len() + right.len()).saturating_sub(n);
        let remaining = budget.saturating_sub(grown);
        let left_budget = remaining * left.len() / (left.len() + right.len());
        let right_budget = remaining - left_budget;
        let (lb, rb) = (
            (l_sum.bounds, l_sum.centroids),
            (r_sum.bounds, r_sum.centroids),
        );
        let (vis_left, vis_right) = (l_sum.visible, r_sum.visible);
        let children = if n > PARALLEL_SUBTREE {
            rayon::join(
                || self.node(left, lb, vis_left, depth + 1, left_budget),
                || self.node(right, rb, vis_right, depth + 1, right_budget),
            )
        } else {
            (
                self.node(left, lb, vis_left, depth + 1, left_budget),
                self.node(right, rb, vis_right, depth + 1, right_budget),
            )
        };
        let (l, r) = (children.0.size(), children.1.size());
        let size = Size {
            below: 2 + l.below + r.below,
            refs: l.refs + r.refs,
        };
        Built::Inner(bounds, Box::new([children.0, children.1]), size)
    }

    /// The best split and its cost: the best SAH split (object or spatial), replaced by the best
    /// OSAH split if `osah` and the OSAH split is viable.
    fn choose(
        &self,
        refs: &[PrimRef],
        bounds: &Box4,
        centroids: &Box4,
        spatial: bool,
        osah: bool,
        budget: usize,
    ) -> (Option<Choice>, Option<f32>) {
        let area = bounds.half_area().max(f32::MIN_POSITIVE);
        let s = self.settings;
        let [obj_sah, obj_osah] =
            best_object_splits(refs, centroids, area, s.bins, &self.model, osah);
        let overlap = [&obj_sah, &obj_osah]
            .iter()
            .filter_map(|o| o.as_ref().map(|(x, _)| x.sides.overlap_half_area()))
            .fold(0.0f32, f32::max);
        let try_spatial = spatial
            && (obj_sah.is_none()
                || (overlap / self.root_area > s.spatial.alpha
                    && overlap >= s.spatial.node_overlap * area))
            && budget > 0;
        let [sp_sah, sp_osah] = if try_spatial {
            let mut axes = [true; 3];
            if s.spatial.axes == SpatialAxes::Object && obj_sah.is_some() {
                axes = [false; 3];
                for o in [&obj_sah, &obj_osah].into_iter().flatten() {
                    axes[o.0.axis()] = true;
                }
            }
            best_spatial_splits(
                refs,
                self.triangles,
                bounds,
                area,
                s.spatial.bins,
                axes,
                refs.len() >= s.spatial.clip_min_refs,
                &self.model,
                osah,
            )
        } else {
            [None, None]
        };
        let n = refs.len() as u32;
        let affordable =
            |sides: &Sides| (sides.n_left + sides.n_right).saturating_sub(n) as usize <= budget;
        let sp_sah = sp_sah.filter(|(x, _)| affordable(&x.sides));
        let sp_osah = sp_osah.filter(|(x, _)| affordable(&x.sides));

        // Candidates as (choice, cost, sides); the lower cost wins, objects win ties.
        let pick = |o: Option<(ObjectSplit, f32)>,
                    p: Option<(SpatialSplit, f32)>,
                    unsplit: Unsplit| {
            match (o, p) {
                (Some(o), Some(p)) if p.1 < o.1 => {
                    Some((Choice::Spatial(p.0, unsplit), p.1, p.0.sides))
                }
                (Some(o), _) => Some((Choice::Object(o.0), o.1, o.0.sides)),
                (None, Some(p)) => Some((Choice::Spatial(p.0, unsplit), p.1, p.0.sides)),
                (None, None) => None,
            }
        };
        let best_sah = pick(obj_sah, sp_sah, Unsplit::Both);
        if osah {
            let unsplit_of = |sides: &Sides| {
                if sides.vis_left >= sides.vis_right {
                    Unsplit::LeftOnly
                } else {
                    Unsplit::RightOnly
                }
            };
            let best_osah = match (obj_osah, sp_osah) {
                (Some(o), Some(p)) if p.1 < o.1 => {
                    Some((Choice::Spatial(p.0, unsplit_of(&p.0.sides)), p.1, p.0.sides))
                }
                (Some(o), _) => Some((Choice::Object(o.0), o.1, o.0.sides)),
                (None, Some(p)) => {
                    Some((Choice::Spatial(p.0, unsplit_of(&p.0.sides)), p.1, p.0.sides))
                }
                (None, None) => None,
            };
            if let Some((choice, cost, sides)) = best_osah {
                let strict = self.settings.osah_strict_viability;
                let viable = best_sah
                    .as_ref()
                    .is_none_or(|b| osah_viable(&sides, &b.2, strict));
                if viable {
                    return (Some(choice), Some(cost));
                }
            }
        }
        match best_sah {
            Some((choice, cost, _)) => (Some(choice), Some(cost)),
            None => (None, None),
        }
    }
}

/// A child's summary counted from its references.
fn summary(refs: &[PrimRef]) -> ChildSummary {
    let (bounds, centroids) = bounds_of(refs);
    ChildSummary {
        bounds,
        centroids,
        visible: count_visible(refs),
    }
}

/// Lays the tree out as [`NodeArray`] needs (root, pad, then sibling pairs depth-first, left
/// subtree before right) and returns it with its references' triangle ids in leaf order. Each
/// subtree's place follows from the sizes below it, so subtrees are written in parallel, and a
/// grafted SAH subtree (already in that layout) is one linear copy with its indices offset.
fn flatten(tree: Built) -> (NodeArray, Vec<u32>) {
    let size = tree.size();
    let mut nodes = NodeArray::zeroed(2 + size.below);
    let mut ids = vec![0u32; size.refs];
    let (root, rest) = nodes.as_mut_slice().split_at_mut(2);
    place(tree, &mut root[0], rest, 2, &mut ids, 0);
    (nodes, ids)
}

/// Subtrees with more nodes than this are placed in parallel.
const PARALLEL_FLATTEN: usize = 4096;

/// Writes `built` into `slot`, its descendants into `below` (whose first node has index `at`
/// in the final array) and its references' ids into `ids` (whose first slot is reference
/// `base`).
fn place(
    built: Built,
    slot: &mut BvhNode,
    below: &mut [BvhNode],
    at: usize,
    ids: &mut [u32],
    base: usize,
) {
    match built {
        Built::Leaf(bounds, refs) => {
            slot.set_bounds(&bounds.to_aabb());
            slot.first = base as u32;
            slot.count = refs.len() as u32;
            for (id, r) in ids.iter_mut().zip(&refs) {
                *id = r.id();
            }
        }
        Built::Inner(bounds, children, size) => {
            slot.set_bounds(&bounds.to_aabb());
            slot.count = 0;
            slot.first = at as u32;
            let [l, r] = *children;
            let ls = l.size();
            let (pair, rest) = below.split_at_mut(2);
            let (l_slot, r_slot) = pair.split_at_mut(1);
            let (l_below, r_below) = rest.split_at_mut(ls.below);
            let (l_ids, r_ids) = ids.split_at_mut(ls.refs);
            let (l_at, r_at) = (at + 2, at + 2 + ls.below);
            let left = move || place(l, &mut l_slot[0], l_below, l_at, l_ids, base);
            let right = move || place(r, &mut r_slot[0], r_below, r_at, r_ids, base + ls.refs);
            if size.below > PARALLEL_FLATTEN {
                rayon::join(left, right);
            } else {
                left();
                right();
            }
        }
        Built::Sah(sub, refs) => {
            // The subtree's descendants start at its index 2; here they start at `at`.
            let offset = |mut node: BvhNode| {
                if node.is_leaf() {
                    node.first += base as u32;
                } else {
                    node.first = (at + node.first as usize - 2) as u32;
                }
                node
            };
            *slot = offset(sub[0]);
            for (out, node) in below.iter_mut().zip(&sub[2..]) {
                *out = offset(*node);
            }
            for (id, r) in ids.iter_mut().zip(&refs) {
                *id = r.id();
            }
        }
    }
}
