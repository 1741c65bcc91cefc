//! Object splits for the spatial/visibility builder: reference centroids binned per axis, with
//! visible references counted per bin so one sweep yields both the best SAH and the best OSAH
//! candidate.

use glam::Vec4;
use rayon::prelude::*;

use super::binned_sah::{
    bin_indices, centroid_bounds_of, in_lanes, Box4, Corners, PrimRef, BIN_LANES, LANES_MIN_REFS,
};
use super::osah_cost::{CostModel, Sides};

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

#[derive(Clone, Copy, Debug, PartialEq)]
struct Bin {
    corners: Corners,
    count: u32,
    visible: u32,
}

const EMPTY_BIN: Bin = Bin {
    corners: Corners::EMPTY,
    count: 0,
    visible: 0,
};

thread_local! {
    /// A thread's spare bins: [`bin_all`] takes them and [`best_object_splits`] gives them
    /// back, so the split builder's nodes do not allocate bins each.
    static SPARE_BINS: std::cell::Cell<Vec<Bin>> = const { std::cell::Cell::new(Vec::new()) };
}

/// Nodes with more references than this bin in parallel chunks (merged bins equal serial
/// binning's exactly: min/max and integer sums).
const PARALLEL_BINNING: usize = 65536;
const BINNING_CHUNK: usize = 16384;

/// The best object split by SAH and (if `osah`) by OSAH cost, each with its cost.
pub(super) fn best_object_splits(
    refs: &[PrimRef],
    centroids: &Box4,
    parent_area: f32,
    bin_count: usize,
    model: &CostModel,
    osah: bool,
) -> [Option<(ObjectSplit, f32)>; 2] {
    let nb = bin_count.min(refs.len() + 2).max(2);
    let extent = centroids.hi - centroids.lo;
    let mappers: [Option<CentroidBins>; 3] = std::array::from_fn(|axis| {
        (extent[axis] > 0.0).then(|| CentroidBins {
            axis,
            lo: centroids.lo[axis],
            scale: nb as f32 * (1.0 - 1e-6) / extent[axis],
            count: nb,
        })
    });
    let all = if refs.len() > PARALLEL_BINNING {
        refs.par_chunks(BINNING_CHUNK)
            .map(|c| bin_all(c, &mappers, nb))
            .reduce(|| vec![EMPTY_BIN; 3 * nb], merge_bins)
    } else {
        bin_all(refs, &mappers, nb)
    };
    let mut best: [Option<(ObjectSplit, f32)>; 2] = [None, None];
    let mut right: Vec<(Box4, u32, u32)> = vec![(Box4::EMPTY, 0, 0); nb];
    for (axis, mapper) in mappers.iter().enumerate() {
        let Some(mapper) = *mapper else {
            continue;
        };
        let bins = &all[axis * nb..(axis + 1) * nb];
        let mut acc = (Box4::EMPTY, 0u32, 0u32);
        for i in (1..nb).rev() {
            acc.0.grow_box(&bins[i].corners.bounds());
            acc.1 += bins[i].count;
            acc.2 += bins[i].visible;
            right[i] = acc;
        }
        let mut left = (Box4::EMPTY, 0u32, 0u32);
        for i in 1..nb {
            let b = &bins[i - 1];
            left.0.grow_box(&b.corners.bounds());
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
    SPARE_BINS.set(all);
    best
}

/// Bins `refs` on every axis with a mapper in one pass (axis a's bins at `a * nb..`); nodes of
/// [`LANES_MIN_REFS`] or more references bin in lanes, as the SAH builder does.
fn bin_all(refs: &[PrimRef], mappers: &[Option<CentroidBins>; 3], nb: usize) -> Vec<Bin> {
    // All three axes' bins from one 4-lane computation (the same arithmetic as
    // `CentroidBins::bin`); an axis without a mapper gets scale 0, so all its references land in
    // its bin 0, which the sweep never reads.
    let lane = |f: fn(&CentroidBins) -> f32| {
        Vec4::from_array(std::array::from_fn(|a| {
            mappers.get(a).copied().flatten().map_or(0.0, |m| f(&m))
        }))
    };
    let map = (
        lane(|m| m.lo),
        lane(|m| m.scale),
        Vec4::splat((nb - 1) as f32),
    );
    let lanes = if refs.len() >= LANES_MIN_REFS {
        BIN_LANES
    } else {
        1
    };
    let mut bins = SPARE_BINS.take();
    bins.clear();
    bins.resize(lanes * 3 * nb, EMPTY_BIN);
    {
        let mut axes = bins.chunks_exact_mut(nb);
        let mut next = || -> [&mut [Bin]; 3] { std::array::from_fn(|_| axes.next().unwrap()) };
        #[cfg(target_arch = "x86_64")]
        let avx = super::binned_sah::use_avx();
        if lanes == 1 {
            let mut one = next();
            #[cfg(target_arch = "x86_64")]
            if avx {
                // SAFETY: AVX is present (checked above).
                unsafe { bin_one_lane_avx(refs, &mut one, map) };
                return merged(bins, nb);
            }
            for r in refs {
                bin_ref(r, &mut one, map);
            }
        } else {
            let [mut a, mut b, mut c, mut d] = std::array::from_fn(|_| next());
            let lanes = [&mut a, &mut b, &mut c, &mut d];
            #[cfg(target_arch = "x86_64")]
            if avx {
                // SAFETY: AVX is present (checked above).
                unsafe { bin_lanes_avx(refs, lanes, map) };
            } else {
                in_lanes(refs, lanes, |r, lane| bin_ref(r, lane, map));
            }
            #[cfg(not(target_arch = "x86_64"))]
            in_lanes(refs, lanes, |r, lane| bin_ref(r, lane, map));
        }
    }
    merged(bins, nb)
}

/// The first lane of `bins` (lanes of `3 * nb` bins each) with the others merged into it.
fn merged(mut bins: Vec<Bin>, nb: usize) -> Vec<Bin> {
    let (first, rest) = bins.split_at_mut(3 * nb);
    for lane in rest.chunks_exact(3 * nb) {
        merge_into(first, lane);
    }
    bins.truncate(3 * nb);
    bins
}

/// The bin indices' mapping: low corner, scale and last bin per axis.
type BinMapping = (Vec4, Vec4, Vec4);

#[inline(always)]
fn bin_ref(r: &PrimRef, [bx, by, bz]: &mut [&mut [Bin]; 3], (lo, scale, last): BinMapping) {
    let [ix, iy, iz, _] = bin_indices(r.centroid2(), lo, scale, last);
    let visible = r.visible() as u32;
    let neg_hi = -r.hi;
    for (axis, i) in [(&mut **bx, ix), (&mut **by, iy), (&mut **bz, iz)] {
        let b = &mut axis[i as usize];
        b.corners.grow(r, neg_hi);
        b.count += 1;
        b.visible += visible;
    }
}

/// [`bin_ref`] with each bin's corners grown by one 8-lane `min` (as `binned_sah`'s binning
/// does).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn bin_ref_avx(r: &PrimRef, [bx, by, bz]: &mut [&mut [Bin]; 3], (lo, scale, last): BinMapping) {
    let [ix, iy, iz, _] = bin_indices(r.centroid2(), lo, scale, last);
    let visible = r.visible() as u32;
    let corners = Corners::of_ref_avx(r);
    for (axis, i) in [(&mut **bx, ix), (&mut **by, iy), (&mut **bz, iz)] {
        let b = &mut axis[i as usize];
        b.corners.grow_avx(corners);
        b.count += 1;
        b.visible += visible;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn bin_one_lane_avx(refs: &[PrimRef], lane: &mut [&mut [Bin]; 3], map: BinMapping) {
    for r in refs {
        bin_ref_avx(r, lane, map);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn bin_lanes_avx(refs: &[PrimRef], lanes: [&mut [&mut [Bin]; 3]; BIN_LANES], map: BinMapping) {
    // The closure has this function's target features.
    in_lanes(refs, lanes, |r, lane| bin_ref_avx(r, lane, map));
}

fn merge_into(a: &mut [Bin], b: &[Bin]) {
    for (x, y) in a.iter_mut().zip(b) {
        x.corners.merge(&y.corners);
        x.count += y.count;
        x.visible += y.visible;
    }
}

fn merge_bins(mut a: Vec<Bin>, b: Vec<Bin>) -> Vec<Bin> {
    merge_into(&mut a, &b);
    a
}

/// What the split builder needs of a child besides its references: its bounds, the bounds of
/// its doubled centroids (as [`bounds_of`](super::binned_sah::bounds_of) gives them) and its
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
pub(crate) mod tests {
    use super::*;
    use crate::bvh::osah_cost::count_visible;
    use glam::Vec3;

    /// Boxes of scattered triangles (a hash of the index), every third visible.
    pub(crate) fn scattered(n: usize) -> Vec<[Vec3; 3]> {
        (0..n)
            .map(|i| {
                let h = (i as u32).wrapping_mul(2654435761);
                let p = Vec3::new(
                    (h % 1000) as f32,
                    ((h >> 10) % 1000) as f32,
                    ((h >> 20) % 1000) as f32,
                );
                let s = 1.0 + (h % 37) as f32;
                [
                    p,
                    p + Vec3::new(s, 0.5, 0.0),
                    p + Vec3::new(0.0, s, 0.3 * s),
                ]
            })
            .collect()
    }

    pub(crate) fn refs_of(tris: &[[Vec3; 3]]) -> Vec<PrimRef> {
        tris.iter()
            .enumerate()
            .map(|(i, t)| PrimRef::of_triangle(i as u32, t))
            .collect()
    }

    /// The references of `tris`, every `k`-th marked visible.
    pub(crate) fn refs_visible_every(tris: &[[Vec3; 3]], k: usize) -> Vec<PrimRef> {
        let refs: Vec<PrimRef> = refs_of(tris)
            .into_iter()
            .enumerate()
            .map(|(i, r)| r.with_visibility(i % k == 0))
            .collect();
        assert_eq!(count_visible(&refs) as usize, tris.len().div_ceil(k));
        refs
    }

    #[test]
    fn chunked_and_avx_binning_equal_serial_portable_binning() {
        let tris = scattered(5000);
        let refs = refs_visible_every(&tris, 3);
        let (_, c) = super::super::binned_sah::bounds_of(&refs);
        let nb = 16;
        let mappers: [Option<CentroidBins>; 3] = std::array::from_fn(|axis| {
            Some(CentroidBins {
                axis,
                lo: c.lo[axis],
                scale: nb as f32 * (1.0 - 1e-6) / (c.hi[axis] - c.lo[axis]),
                count: nb,
            })
        });
        let serial = bin_all(&refs, &mappers, nb);
        let merged = refs
            .chunks(777)
            .map(|c| bin_all(c, &mappers, nb))
            .fold(vec![EMPTY_BIN; 3 * nb], merge_bins);
        assert_eq!(serial, merged);
        assert_eq!(serial.iter().map(|b| b.count).sum::<u32>(), 3 * 5000);
        let (portable, avx) =
            super::super::binned_sah::portable_and_avx(|| bin_all(&refs, &mappers, nb));
        assert_eq!(portable, avx, "AVX and portable binning differ");
        // Chunks under LANES_MIN_REFS bin in one lane, the whole in lanes: the same bins.
        let one_lane = || {
            refs.chunks(LANES_MIN_REFS - 1)
                .map(|c| bin_all(c, &mappers, nb))
                .fold(vec![EMPTY_BIN; 3 * nb], merge_bins)
        };
        let (portable_one, avx_one) = super::super::binned_sah::portable_and_avx(one_lane);
        assert_eq!(portable_one, serial, "portable: one lane and lanes differ");
        assert_eq!(avx_one, serial, "AVX: one lane and lanes differ");
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
        let (bounds, centroids) = super::super::binned_sah::bounds_of(&refs);
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
                let (bounds, centroids) = super::super::binned_sah::bounds_of(side);
                let xyz = |b: &Box4| (b.lo.truncate(), b.hi.truncate());
                assert_eq!(xyz(&got.bounds), xyz(&bounds));
                assert_eq!(xyz(&got.centroids), xyz(&centroids));
                assert_eq!(got.visible, count_visible(side));
                assert!(got.visible > 0);
            }
        }
    }
}
