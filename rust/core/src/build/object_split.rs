//! Object splits for the split builder: references binned by centroid (the shared binning,
//! with visible references counted per bin) so one sweep yields both the best SAH and the best
//! OSAH candidate.

use glam::Vec4;

use super::binning::Binner;
use super::osah_cost::{CostModel, Sides};
use super::primref::{centroid_bounds_of, Box4, PrimRef};
use super::scratch::with_object_bins;
use super::settings::MAX_BINS;

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
        self.bin_of(c2[self.axis])
    }
    /// [`Self::bin`] of a reference for `AXIS`, this mapper's axis, known at compile time.
    #[inline(always)]
    fn bin_on<const AXIS: usize>(&self, r: &PrimRef) -> usize {
        debug_assert_eq!(AXIS, self.axis);
        self.bin_of(r.lo[AXIS] + r.hi[AXIS])
    }
    #[inline(always)]
    fn bin_of(&self, c2: f32) -> usize {
        let f = (c2 - self.lo) * self.scale;
        // Clamped as floats (`max` drops a NaN), so the conversion needs none of the
        // saturating `as` checks: the same bin as `(f.max(0.0) as usize).min(count - 1)`.
        let f = f.max(0.0).min((self.count - 1) as f32);
        // SAFETY: `f` is finite and in [0, count - 1] (count <= MAX_BINS), so it fits a u32.
        unsafe { f.to_int_unchecked::<u32>() as usize }
    }
}

/// An object split: references whose centroid bin is below `bin` go left.
#[derive(Clone, Copy, Debug)]
pub(super) struct ObjectSplit {
    pub(super) bins: CentroidBins,
    pub(super) bin: usize,
    pub(super) sides: Sides,
}

impl ObjectSplit {
    pub(super) fn axis(&self) -> usize {
        self.bins.axis
    }
}

/// The best object split by SAH and (if `osah`) by OSAH cost, each with its cost.
pub(super) fn best_object_splits(
    refs: &[PrimRef],
    centroids: &Box4,
    parent_area: f32,
    bin_count: usize,
    model: &CostModel,
    osah: bool,
) -> [Option<(ObjectSplit, f32)>; 2] {
    // Bins live in arrays of MAX_BINS (the settings' bound).
    let nb = bin_count.min(refs.len() + 2).clamp(2, MAX_BINS);
    let extent = centroids.hi - centroids.lo;
    let mappers: [Option<CentroidBins>; 3] = std::array::from_fn(|axis| {
        (extent[axis] > 0.0).then(|| CentroidBins {
            axis,
            lo: centroids.lo[axis],
            scale: nb as f32 * (1.0 - 1e-6) / extent[axis],
            count: nb,
        })
    });
    // The binner maps centroids to the same bins as `mappers`, on all three axes at once.
    let binner = Binner::new(centroids, nb);
    with_object_bins(|binning| {
        let all = binning.bin(refs, &binner, nb);
        let mut best: [Option<(ObjectSplit, f32)>; 2] = [None, None];
        let mut right: Vec<(Box4, u32, u32)> = vec![(Box4::EMPTY, 0, 0); nb];
        for (axis, mapper) in mappers.iter().enumerate() {
            let Some(mapper) = *mapper else {
                continue;
            };
            let bins = &all[axis][..nb];
            let mut acc = (Box4::EMPTY, 0u32, 0u32);
            for i in (1..nb).rev() {
                acc.0.grow_box(&bins[i].bounds());
                acc.1 += bins[i].payload.count;
                acc.2 += bins[i].payload.visible;
                right[i] = acc;
            }
            let mut left = (Box4::EMPTY, 0u32, 0u32);
            for i in 1..nb {
                let b = &bins[i - 1];
                left.0.grow_box(&b.bounds());
                left.1 += b.payload.count;
                left.2 += b.payload.visible;
                if b.payload.count == 0 || left.1 == 0 || right[i].1 == 0 {
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
    })
}

/// What the split builder needs of a child besides its references: its bounds, the bounds of
/// its doubled centroids (as [`bounds_of`](super::primref::bounds_of) gives them) and its
/// visible references.
#[derive(Clone, Copy, Debug)]
pub(super) struct ChildSummary {
    pub(super) bounds: Box4,
    pub(super) centroids: Box4,
    pub(super) visible: u32,
}

/// Splits `refs` by `split` into (left, right), each allocated once at its known size, both in
/// the order of `refs`. The branch-free path also returns both children's summaries: boxes and
/// visible counts from the binned sides (exact when the counts matched), centroid bounds from
/// one pass over each child.
pub(super) fn partition_object(
    refs: Vec<PrimRef>,
    split: &ObjectSplit,
) -> (Vec<PrimRef>, Vec<PrimRef>, Option<[ChildSummary; 2]>) {
    let goes_left = |r: &PrimRef| split.bins.bin(r.centroid2()) < split.bin;
    let (n_left, n_right) = (split.sides.n_left as usize, split.sides.n_right as usize);
    if n_left > 0 && n_right > 0 && n_left + n_right == refs.len() {
        let parts = match split.axis() {
            0 => scatter::<0>(&refs, split, n_left, n_right),
            1 => scatter::<1>(&refs, split, n_left, n_right),
            _ => scatter::<2>(&refs, split, n_left, n_right),
        };
        if let Some((left, right)) = parts {
            // The binned sides are exact for an object split whose counts matched.
            let sides = &split.sides;
            let summaries = [
                ChildSummary {
                    bounds: sides.left,
                    centroids: centroid_bounds_of(&left),
                    visible: sides.vis_left,
                },
                ChildSummary {
                    bounds: sides.right,
                    centroids: centroid_bounds_of(&right),
                    visible: sides.vis_right,
                },
            ];
            return (left, right, Some(summaries));
        }
    }
    let mut left = Vec::with_capacity(n_left);
    let mut right = Vec::with_capacity(n_right);
    for r in refs {
        if goes_left(&r) {
            left.push(r);
        } else {
            right.push(r);
        }
    }
    (left, right, None)
}

/// [`partition_object`] without a branch per reference (its side is as good as random to the
/// branch predictor): each reference is written to the next slot of the side it goes to, for
/// the binned counts `n_left` and `n_right` (both non-zero). `None` if the counts do not match
/// the references.
#[inline(always)]
fn scatter<const AXIS: usize>(
    refs: &[PrimRef],
    split: &ObjectSplit,
    n_left: usize,
    n_right: usize,
) -> Option<(Vec<PrimRef>, Vec<PrimRef>)> {
    let mut left: Vec<PrimRef> = Vec::with_capacity(n_left);
    let mut right: Vec<PrimRef> = Vec::with_capacity(n_right);
    let sides = [
        left.spare_capacity_mut().as_mut_ptr(),
        right.spare_capacity_mut().as_mut_ptr(),
    ];
    let last = [n_left - 1, n_right - 1];
    let mut next = [0usize; 2];
    for r in refs {
        let side = (split.bins.bin_on::<AXIS>(r) >= split.bin) as usize;
        // SAFETY: the slot index is clamped to the side's capacity; a count that would pass it
        // makes the sums below disagree and the result is discarded (never set_len).
        unsafe {
            sides[side]
                .add(next[side].min(last[side]))
                .write(std::mem::MaybeUninit::new(*r))
        };
        next[side] += 1;
    }
    if next != [n_left, n_right] {
        return None;
    }
    // SAFETY: each side's slots 0..count were written exactly once (indices below the count
    // never clamp).
    unsafe {
        left.set_len(n_left);
        right.set_len(n_right);
    }
    Some((left, right))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build::primref::tests::{refs_visible_every, scattered};
    use crate::build::primref::{bounds_of, count_visible};

    #[test]
    fn binner_maps_centroids_to_the_partitions_bins() {
        // The binned counts are exact only if the shared binning and the partition's
        // per-axis mapping agree on every reference's bin.
        let tris = scattered(3000);
        let refs = refs_visible_every(&tris, 3);
        let (_, c) = bounds_of(&refs);
        for nb in [2, 16, 37, 256] {
            let binner = Binner::new(&c, nb);
            for axis in 0..3 {
                let bins = CentroidBins {
                    axis,
                    lo: c.lo[axis],
                    scale: nb as f32 * (1.0 - 1e-6) / (c.hi[axis] - c.lo[axis]),
                    count: nb,
                };
                for r in &refs {
                    let c2 = r.centroid2();
                    assert_eq!(binner.bins(c2)[axis] as usize, bins.bin(c2), "{nb} bins");
                }
            }
        }
    }

    #[test]
    fn centroid_bins_clamp_as_the_saturating_cast_did() {
        let bins = CentroidBins {
            axis: 0,
            lo: -1.5,
            scale: 3.25,
            count: 16,
        };
        let odd = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            -f32::MAX,
            -0.0,
        ];
        let values = (-400..400).map(|i| i as f32 * 0.037).chain(odd);
        for c2 in values {
            let f = (c2 - bins.lo) * bins.scale;
            let want = (f.max(0.0) as usize).min(bins.count - 1);
            assert_eq!(bins.bin_of(c2), want, "centroid {c2}");
        }
    }

    #[test]
    fn partition_keeps_order_and_survives_wrong_counts() {
        let tris = scattered(3000);
        let refs = refs_visible_every(&tris, 3);
        let (bounds, centroids) = bounds_of(&refs);
        let model = CostModel {
            traversal: 1.0,
            intersection: 1.0,
            weight: 0.9,
        };
        let [best, _] =
            best_object_splits(&refs, &centroids, bounds.half_area(), 16, &model, false);
        let (split, _) = best.expect("a split");
        let ids = |v: &[PrimRef]| v.iter().map(|r| r.id()).collect::<Vec<_>>();
        let (want_left, want_right): (Vec<PrimRef>, Vec<PrimRef>) = refs
            .iter()
            .partition(|r| split.bins.bin(r.centroid2()) < split.bin);
        assert!(!want_left.is_empty() && !want_right.is_empty());
        let mut wrong = split;
        wrong.sides.n_left += 1;
        wrong.sides.n_right -= 1;
        for s in [split, wrong] {
            let (left, right, summaries) = partition_object(refs.clone(), &s);
            assert_eq!(ids(&left), ids(&want_left));
            assert_eq!(ids(&right), ids(&want_right));
            // With the right counts, the summaries gathered on the way equal counting afresh
            // (boxes compared on x, y, z: the fourth lane carries nothing).
            let Some(summaries) = summaries else {
                assert_eq!(
                    s.sides.n_left, wrong.sides.n_left,
                    "the right counts summarise"
                );
                continue;
            };
            for (got, side) in summaries.iter().zip([&left, &right]) {
                let (bounds, centroids) = bounds_of(side);
                let xyz = |b: &Box4| (b.lo.truncate(), b.hi.truncate());
                assert_eq!(xyz(&got.bounds), xyz(&bounds));
                assert_eq!(xyz(&got.centroids), xyz(&centroids));
                assert_eq!(got.visible, count_visible(side));
                assert!(got.visible > 0);
            }
        }
    }
}
