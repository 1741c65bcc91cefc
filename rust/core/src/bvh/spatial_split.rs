//! Spatial splits (Stich, Friedrich & Dietrich 2009): a node may be cut by a plane like a
//! kd-tree, and a reference straddling the plane goes to both children with the tight box of
//! its clipped part. Candidates are binned on the node's bounds (entry/exit counters per bin);
//! a straddling reference is "unsplit" into one child when that is cheaper than duplicating it.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::binned_sah::{Box4, PrimRef};
use super::clip::{clipped_box, clipped_strips};
use super::osah_cost::{CostModel, Sides, Visibility};

/// Settings of spatial splits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SpatialSettings {
    /// Whether the SBVH, ABVH and OSAH builders may split space at all.
    pub enabled: bool,
    /// Spatial bins per axis (2..=256).
    pub bins: usize,
    /// Spatial splits are tried only in nodes whose best object split's children overlap by
    /// more than this fraction of the root's surface area (Stich et al.'s alpha; 1 disables).
    pub alpha: f32,
    /// References may grow to at most (1 + max_growth) x triangles; the budget is handed down
    /// the tree in proportion to child sizes, so the build stays deterministic.
    pub max_growth: f32,
}

impl Default for SpatialSettings {
    fn default() -> Self {
        SpatialSettings {
            enabled: true,
            bins: 32,
            alpha: 1e-5,
            max_growth: 0.5,
        }
    }
}

impl SpatialSettings {
    pub fn validate(&self) -> crate::Result<()> {
        if !(2..=256).contains(&self.bins) {
            return Err(crate::Error::invalid(
                "build.spatial.bins",
                format!("must be in 2..=256, got {}", self.bins),
            ));
        }
        if !(0.0..=1.0).contains(&self.alpha) {
            return Err(crate::Error::invalid(
                "build.spatial.alpha",
                format!("must be in 0..=1, got {}", self.alpha),
            ));
        }
        if !(0.0..=16.0).contains(&self.max_growth) {
            return Err(crate::Error::invalid(
                "build.spatial.max_growth",
                format!("must be in 0..=16, got {}", self.max_growth),
            ));
        }
        Ok(())
    }
}

/// A spatial split: the plane `p[axis] = position` and the binned estimate of its sides.
#[derive(Clone, Copy, Debug)]
pub(super) struct SpatialSplit {
    pub(super) axis: usize,
    pub(super) position: f32,
    pub(super) sides: Sides,
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Box4,
    enter: u32,
    exit: u32,
    vis_enter: u32,
    vis_exit: u32,
}

const EMPTY_BIN: Bin = Bin {
    bounds: Box4::EMPTY,
    enter: 0,
    exit: 0,
    vis_enter: 0,
    vis_exit: 0,
};

/// The best spatial split by SAH and (if `osah`) by OSAH cost, each with its cost. Splits that
/// leave every reference on one side are skipped: they would not shrink the node.
#[allow(clippy::too_many_arguments)]
pub(super) fn best_spatial_splits(
    refs: &[PrimRef],
    triangles: &[[Vec3; 3]],
    vis: Visibility,
    bounds: &Box4,
    parent_area: f32,
    bin_count: usize,
    model: &CostModel,
    osah: bool,
) -> [Option<(SpatialSplit, f32)>; 2] {
    let n = refs.len() as u32;
    let nb = bin_count.max(2);
    let extent = bounds.hi - bounds.lo;
    let mut best: [Option<(SpatialSplit, f32)>; 2] = [None, None];
    let mut bins = vec![EMPTY_BIN; nb];
    let mut right = vec![(Box4::EMPTY, 0u32, 0u32); nb];
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let lo = bounds.lo[axis];
        let step = extent[axis] / nb as f32;
        let plane = |i: usize| {
            if i == nb {
                bounds.hi[axis]
            } else {
                lo + step * i as f32
            }
        };
        let bin_of = |x: f32| (((x - lo) / step).max(0.0) as usize).min(nb - 1);
        bins.fill(EMPTY_BIN);
        for r in refs {
            let (b0, b1) = (
                bin_of(r.lo[axis]),
                bin_of(r.hi[axis]).max(bin_of(r.lo[axis])),
            );
            let visible = vis.of(r) as u32;
            if b0 == b1 {
                bins[b0].bounds.grow_box(&r.bounds());
            } else {
                let tri = &triangles[r.id() as usize];
                let planes = (b0..=b1 + 1).map(plane);
                clipped_strips(tri, axis, planes, &r.bounds(), |j, part| {
                    bins[b0 + j].bounds.grow_box(&part);
                });
            }
            bins[b0].enter += 1;
            bins[b0].vis_enter += visible;
            bins[b1].exit += 1;
            bins[b1].vis_exit += visible;
        }
        let mut acc = (Box4::EMPTY, 0u32, 0u32);
        for i in (1..nb).rev() {
            acc.0.grow_box(&bins[i].bounds);
            acc.1 += bins[i].exit;
            acc.2 += bins[i].vis_exit;
            right[i] = acc;
        }
        let mut left = (Box4::EMPTY, 0u32, 0u32);
        for i in 1..nb {
            let b = &bins[i - 1];
            left.0.grow_box(&b.bounds);
            left.1 += b.enter;
            left.2 += b.vis_enter;
            let (n_left, n_right) = (left.1, right[i].1);
            if n_left == 0 || n_right == 0 || n_left >= n || n_right >= n {
                continue;
            }
            let sides = Sides {
                left: left.0,
                right: right[i].0,
                n_left,
                n_right,
                vis_left: left.2,
                vis_right: right[i].2,
            };
            let split = SpatialSplit {
                axis,
                position: plane(i),
                sides,
            };
            let sah = model.sah(&sides, parent_area);
            if best[0].as_ref().is_none_or(|b| sah < b.1) {
                best[0] = Some((split, sah));
            }
            if osah {
                let c = model.osah(&sides, parent_area);
                if best[1].as_ref().is_none_or(|b| c < b.1) {
                    best[1] = Some((split, c));
                }
            }
        }
    }
    best
}

/// Where a straddling reference may go whole instead of being duplicated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Unsplit {
    /// Either side (SBVH).
    Both,
    /// Only into the left child (OSAH: the visible child; moving an invisible triangle's whole
    /// box into the invisible child could make it overlap visible ones).
    LeftOnly,
    RightOnly,
}

/// Distributes `refs` by the plane of `split`. A straddling reference is cut into two tight
/// boxes unless moving it whole into an allowed side costs less (SAH of the two sides, with the
/// sides as binned and updated as references are placed).
pub(super) fn partition_spatial(
    refs: Vec<PrimRef>,
    triangles: &[[Vec3; 3]],
    split: &SpatialSplit,
    unsplit: Unsplit,
) -> (Vec<PrimRef>, Vec<PrimRef>) {
    let (axis, pos) = (split.axis, split.position);
    let mut left = Vec::with_capacity(split.sides.n_left as usize);
    let mut right = Vec::with_capacity(split.sides.n_right as usize);
    let mut straddling = Vec::new();
    let mut left_box = Box4::EMPTY;
    let mut right_box = Box4::EMPTY;
    for r in refs {
        if r.hi[axis] <= pos {
            left_box.grow_box(&r.bounds());
            left.push(r);
        } else if r.lo[axis] >= pos {
            right_box.grow_box(&r.bounds());
            right.push(r);
        } else {
            straddling.push(r);
        }
    }
    // Costs use the binned boxes as in Stich et al.; the exact boxes of the references placed so
    // far are folded in as they grow.
    left_box.grow_box(&split.sides.left);
    right_box.grow_box(&split.sides.right);
    let mut n_left = (left.len() + straddling.len()) as f32;
    let mut n_right = (right.len() + straddling.len()) as f32;
    for r in straddling {
        let tri = &triangles[r.id() as usize];
        let within = r.bounds();
        let lpart = clipped_box(tri, axis, r.lo[axis], pos, &within);
        let rpart = clipped_box(tri, axis, pos, r.hi[axis], &within);
        let l_empty = lpart.lo.x > lpart.hi.x;
        let r_empty = rpart.lo.x > rpart.hi.x;
        let grown = |mut b: Box4, p: &Box4| {
            b.grow_box(p);
            b
        };
        let split_cost = grown(left_box, &lpart).half_area() * n_left
            + grown(right_box, &rpart).half_area() * n_right;
        let to_left =
            grown(left_box, &within).half_area() * n_left + right_box.half_area() * (n_right - 1.0);
        let to_right =
            left_box.half_area() * (n_left - 1.0) + grown(right_box, &within).half_area() * n_right;
        let may_left = unsplit != Unsplit::RightOnly;
        let may_right = unsplit != Unsplit::LeftOnly;
        if r_empty || (may_left && to_left < split_cost && (!may_right || to_left <= to_right)) {
            left_box.grow_box(&within);
            left.push(r);
            n_right -= 1.0;
        } else if l_empty || (may_right && to_right < split_cost) {
            right_box.grow_box(&within);
            right.push(r);
            n_left -= 1.0;
        } else {
            left_box.grow_box(&lpart);
            right_box.grow_box(&rpart);
            left.push(PrimRef::new(r.id(), lpart));
            right.push(PrimRef::new(r.id(), rpart));
        }
    }
    (left, right)
}
