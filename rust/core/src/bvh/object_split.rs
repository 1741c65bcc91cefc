//! Object splits for the spatial/visibility builder: reference centroids binned per axis, with
//! visible references counted per bin so one sweep yields both the best SAH and the best OSAH
//! candidate.

use glam::Vec4;

use super::binned_sah::{Box4, PrimRef};
use super::osah_cost::{CostModel, Sides, Visibility};

/// Maps a doubled centroid to its bin on one axis.
#[derive(Clone, Copy, Debug)]
pub(super) struct CentroidBins {
    axis: usize,
    lo: f32,
    scale: f32,
    count: usize,
}

impl CentroidBins {
    #[inline]
    fn bin(&self, c2: Vec4) -> usize {
        let f = (c2[self.axis] - self.lo) * self.scale;
        (f.max(0.0) as usize).min(self.count - 1)
    }
}

/// An object split: references whose centroid bin is below `bin` go left.
#[derive(Clone, Copy, Debug)]
pub(super) struct ObjectSplit {
    pub(super) bins: CentroidBins,
    pub(super) bin: usize,
    pub(super) sides: Sides,
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Box4,
    count: u32,
    visible: u32,
}

/// The best object split by SAH and (if `osah`) by OSAH cost, each with its cost.
pub(super) fn best_object_splits(
    refs: &[PrimRef],
    vis: Visibility,
    centroids: &Box4,
    parent_area: f32,
    bin_count: usize,
    model: &CostModel,
    osah: bool,
) -> [Option<(ObjectSplit, f32)>; 2] {
    let nb = bin_count.min(refs.len() + 2).max(2);
    let extent = centroids.hi - centroids.lo;
    let mut best: [Option<(ObjectSplit, f32)>; 2] = [None, None];
    let empty = Bin {
        bounds: Box4::EMPTY,
        count: 0,
        visible: 0,
    };
    let mut bins = vec![empty; nb];
    let mut right: Vec<(Box4, u32, u32)> = vec![(Box4::EMPTY, 0, 0); nb];
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let mapper = CentroidBins {
            axis,
            lo: centroids.lo[axis],
            scale: nb as f32 * (1.0 - 1e-6) / extent[axis],
            count: nb,
        };
        bins.fill(empty);
        for r in refs {
            let b = &mut bins[mapper.bin(r.centroid2())];
            b.bounds.grow(r.lo, r.hi);
            b.count += 1;
            b.visible += vis.of(r) as u32;
        }
        let mut acc = (Box4::EMPTY, 0u32, 0u32);
        for i in (1..nb).rev() {
            acc.0.grow_box(&bins[i].bounds);
            acc.1 += bins[i].count;
            acc.2 += bins[i].visible;
            right[i] = acc;
        }
        let mut left = (Box4::EMPTY, 0u32, 0u32);
        for i in 1..nb {
            let b = &bins[i - 1];
            left.0.grow_box(&b.bounds);
            left.1 += b.count;
            left.2 += b.visible;
            if b.count == 0 || left.1 == 0 || right[i].1 == 0 {
                continue;
            }
            let sides = Sides {
                left: left.0,
                right: right[i].0,
                n_left: left.1,
                n_right: right[i].1,
                vis_left: left.2,
                vis_right: right[i].2,
            };
            let split = ObjectSplit {
                bins: mapper,
                bin: i,
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

/// Splits `refs` by `split` into (left, right).
pub(super) fn partition_object(
    refs: Vec<PrimRef>,
    split: &ObjectSplit,
) -> (Vec<PrimRef>, Vec<PrimRef>) {
    refs.into_iter()
        .partition(|r| split.bins.bin(r.centroid2()) < split.bin)
}

/// Splits at the middle reference along the widest centroid axis: the fallback when no binned
/// split separates anything (coincident centroids).
pub(super) fn median_split(
    mut refs: Vec<PrimRef>,
    centroids: &Box4,
) -> (Vec<PrimRef>, Vec<PrimRef>) {
    let axis = (centroids.hi - centroids.lo).truncate().max_position();
    let mid = refs.len() / 2;
    refs.select_nth_unstable_by(mid, |a, b| {
        a.centroid2()[axis]
            .total_cmp(&b.centroid2()[axis])
            .then(a.id().cmp(&b.id()))
    });
    let right = refs.split_off(mid);
    (refs, right)
}
