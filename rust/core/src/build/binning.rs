//! Centroid binning (Wald 2007), shared by the SAH builder and the split builder's object
//! splits: references are binned by doubled centroid on all three axes at once, each bin
//! keeping its bounds and a payload (a count, or a count and a visible count).
//!
//! The bin layout is tuned: the upper corner is stored negated so one `min` grows both corners
//! (one 8-lane instruction with AVX), and large nodes bin into [`BIN_LANES`] copies of the bins.

use glam::Vec4;
use rayon::prelude::*;

use super::primref::{Box4, PrimRef};
use super::settings::MAX_BINS;

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

/// What a bin counts besides its bounds. Sums of integers, so bins merge exactly in any order.
pub(crate) trait Payload: Copy + PartialEq + std::fmt::Debug + Send + Sync {
    const ZERO: Self;
    /// What one reference adds to its bin.
    fn of(r: &PrimRef) -> Self;
    fn add(&mut self, other: Self);
    /// The references counted.
    fn count(&self) -> u32;
}

/// The SAH builder's payload: the references in the bin.
impl Payload for u32 {
    const ZERO: Self = 0;
    #[inline(always)]
    fn of(_: &PrimRef) -> Self {
        1
    }
    #[inline(always)]
    fn add(&mut self, other: Self) {
        *self += other;
    }
    #[inline(always)]
    fn count(&self) -> u32 {
        *self
    }
}

/// The split builder's payload: the references in the bin and how many of them are visible,
/// so one sweep costs a split by SAH and by OSAH.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CountVisible {
    pub(crate) count: u32,
    pub(crate) visible: u32,
}

impl Payload for CountVisible {
    const ZERO: Self = CountVisible {
        count: 0,
        visible: 0,
    };
    #[inline(always)]
    fn of(r: &PrimRef) -> Self {
        CountVisible {
            count: 1,
            visible: r.visible() as u32,
        }
    }
    #[inline(always)]
    fn add(&mut self, other: Self) {
        self.count += other.count;
        self.visible += other.visible;
    }
    #[inline(always)]
    fn count(&self) -> u32 {
        self.count
    }
}

/// A bin: the bounds of the references binned into it and its payload.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Bin<P> {
    corners: Corners,
    pub(crate) payload: P,
}

impl<P: Payload> Bin<P> {
    const EMPTY: Self = Bin {
        corners: Corners::EMPTY,
        payload: P::ZERO,
    };
    #[inline(always)]
    pub(crate) fn bounds(&self) -> Box4 {
        self.corners.bounds()
    }
    #[inline(always)]
    pub(crate) fn count(&self) -> u32 {
        self.payload.count()
    }
    #[inline(always)]
    fn merge(&mut self, other: &Self) {
        self.corners.merge(&other.corners);
        self.payload.add(other.payload);
    }
}

/// Nodes with more references than this bin in parallel chunks.
const PARALLEL_BINNING: usize = 65536;
const BINNING_CHUNK: usize = 16384;

/// One axis's bins: `MAX_BINS` of them, so a bin index (at most `MAX_BINS - 1`) masked to
/// `MAX_BINS - 1` needs no bounds check; a node uses the first `nb`.
type AxisBins<P> = [Bin<P>; MAX_BINS];

/// The bins of the three axes.
pub(crate) type Bins3<P> = [AxisBins<P>; 3];

/// Consecutive references often fall into the same bin, and each then waits for the previous
/// one's update of that bin to be stored and loaded again. Nodes of [`LANES_MIN_REFS`] or more
/// references (with at most [`LANE_BINS`] bins) therefore bin in turn into [`BIN_LANES`]
/// copies of the bins, merged after: the merged bins equal one copy's exactly (minima, maxima
/// and integer sums), and the chains through a bin are a quarter as long.
pub(crate) const BIN_LANES: usize = 4;
const LANE_BINS: usize = 32;
pub(crate) const LANES_MIN_REFS: usize = 128;

const _: () = assert!(MAX_BINS.is_power_of_two() && LANE_BINS.is_power_of_two());

/// The bins of the three axes in one lane.
type LaneBins3<P> = [[Bin<P>; LANE_BINS]; 3];
type BinLanes<P> = [LaneBins3<P>; BIN_LANES];

fn new_bins<P: Payload>() -> Box<Bins3<P>> {
    vec![[Bin::<P>::EMPTY; MAX_BINS]; 3]
        .into_boxed_slice()
        .try_into()
        .expect("three axes")
}

fn new_lanes<P: Payload>() -> Box<BinLanes<P>> {
    Box::new([[[Bin::<P>::EMPTY; LANE_BINS]; 3]; BIN_LANES])
}

/// A thread's bins, reused from node to node so small nodes allocate nothing.
pub(crate) struct Binning<P> {
    bins: Box<Bins3<P>>,
    lanes: Box<BinLanes<P>>,
}

impl<P: Payload> Binning<P> {
    pub(crate) fn new() -> Self {
        Binning {
            bins: new_bins(),
            lanes: new_lanes(),
        }
    }

    /// Bins `refs` by centroid on all three axes into `nb` (at most `MAX_BINS`) bins per axis
    /// as `binner` maps them; each axis's first `nb` bins of the result hold them. Large nodes
    /// bin chunks in parallel: the merged bins equal serial binning's exactly.
    #[inline]
    pub(crate) fn bin(&mut self, refs: &[PrimRef], binner: &Binner, nb: usize) -> &Bins3<P> {
        let bins: &mut Bins3<P> = &mut self.bins;
        if refs.len() > PARALLEL_BINNING {
            *bins = *refs
                .par_chunks(BINNING_CHUNK)
                .map(|c| {
                    let mut local = new_bins();
                    bin_refs(c, binner, nb, &mut local, &mut new_lanes());
                    local
                })
                .reduce(new_bins, |a, b| merge_bins(a, &b, nb));
        } else {
            clear_bins(bins, nb);
            bin_refs(refs, binner, nb, bins, &mut self.lanes);
        }
        bins
    }
}

/// Maps doubled centroids to bin indices on all three axes at once.
#[derive(Clone, Copy)]
pub(crate) struct Binner {
    lo: Vec4,
    scale: Vec4,
    last: Vec4,
}

impl Binner {
    /// `bins` bins per axis over `centroids` (doubled centroid bounds); an axis without extent
    /// puts every reference in its bin 0.
    #[inline]
    pub(crate) fn new(centroids: &Box4, bins: usize) -> Self {
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
    pub(crate) fn bins(&self, c2: Vec4) -> [u32; 4] {
        truncate_lanes(((c2 - self.lo) * self.scale).max(Vec4::ZERO).min(self.last))
    }
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

/// Empties the first `nb` bins of each axis.
fn clear_bins<P: Payload>(bins: &mut Bins3<P>, nb: usize) {
    for axis in bins.iter_mut() {
        axis[..nb].fill(Bin::EMPTY);
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
    static PORTABLE_ONLY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
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
fn bin_refs<P: Payload>(
    refs: &[PrimRef],
    binner: &Binner,
    nb: usize,
    bins: &mut Bins3<P>,
    lanes: &mut BinLanes<P>,
) {
    if refs.len() < LANES_MIN_REFS || nb > LANE_BINS {
        bin_refs_into(refs, binner, bins);
        return;
    }
    for lane in lanes.iter_mut() {
        for axis in lane.iter_mut() {
            axis[..nb].fill(Bin::EMPTY);
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
                x.merge(y);
            }
        }
    }
}

/// [`bin_refs`] in one lane: straight into `bins`.
fn bin_refs_into<P: Payload>(refs: &[PrimRef], binner: &Binner, bins: &mut Bins3<P>) {
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
fn bin_ref<P: Payload, const N: usize>(
    r: &PrimRef,
    binner: &Binner,
    [bx, by, bz]: &mut [[Bin<P>; N]; 3],
) {
    let [ix, iy, iz, _] = binner.bins(r.centroid2());
    let neg_hi = -r.hi;
    let payload = P::of(r);
    // The indices are below nb <= N, a power of two: the masks only drop the bounds checks.
    for (axis, i) in [(bx, ix), (by, iy), (bz, iz)] {
        let bin = &mut axis[i as usize & (N - 1)];
        bin.corners.grow(r, neg_hi);
        bin.payload.add(payload);
    }
}

/// [`bin_ref`] with each bin's two corners grown by one 8-lane `min`: a third of the
/// instructions per reference and axis, and one store instead of two on the chain through a
/// bin that consecutive references hit.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn bin_ref_avx<P: Payload, const N: usize>(
    r: &PrimRef,
    binner: &Binner,
    [bx, by, bz]: &mut [[Bin<P>; N]; 3],
) {
    let [ix, iy, iz, _] = binner.bins(r.centroid2());
    let corners = Corners::of_ref_avx(r);
    let payload = P::of(r);
    for (axis, i) in [(bx, ix), (by, iy), (bz, iz)] {
        let bin = &mut axis[i as usize & (N - 1)];
        bin.corners.grow_avx(corners);
        bin.payload.add(payload);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn bin_refs_avx<P: Payload>(refs: &[PrimRef], binner: &Binner, bins: &mut Bins3<P>) {
    for r in refs {
        bin_ref_avx(r, binner, bins);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn bin_lanes_avx<P: Payload>(
    refs: &[PrimRef],
    binner: &Binner,
    lanes: [&mut LaneBins3<P>; BIN_LANES],
) {
    // The closure has this function's target features.
    in_lanes(refs, lanes, |r, lane| bin_ref_avx(r, binner, lane));
}

fn merge_bins<P: Payload>(mut a: Box<Bins3<P>>, b: &Bins3<P>, nb: usize) -> Box<Bins3<P>> {
    for (xa, ya) in a.iter_mut().zip(b) {
        for (x, y) in xa[..nb].iter_mut().zip(&ya[..nb]) {
            x.merge(y);
        }
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build::primref::bounds_of;
    use crate::build::primref::tests::{refs_visible_every, scattered};

    /// The AVX loops equal the portable ones, lanes equal one lane, parallel chunks equal serial
    /// binning, for both payloads.
    fn binning_paths_agree<P: Payload>() {
        let tris = scattered(5000);
        let refs = refs_visible_every(&tris, 3);
        let (_, centroids) = bounds_of(&refs);
        let bin = |refs: &[PrimRef], binner: &Binner, nb: usize| {
            let mut bins = new_bins::<P>();
            bin_refs(refs, binner, nb, &mut bins, &mut new_lanes());
            bins
        };
        for nb in [2, 16, 37] {
            let binner = Binner::new(&centroids, nb);
            let (portable, avx) = portable_and_avx(|| bin(&refs, &binner, nb));
            assert!(
                portable == avx,
                "{nb} bins: AVX and portable binning differ"
            );
            // The lanes (2 and 16 bins) merge to what one lane bins, on both paths.
            let (one_portable, one_avx) = portable_and_avx(|| {
                let mut bins = new_bins::<P>();
                bin_refs_into(&refs, &binner, &mut bins);
                bins
            });
            assert!(
                portable == one_portable && avx == one_avx,
                "{nb} bins: lanes differ"
            );
            // Chunks (some under LANES_MIN_REFS, so in one lane) merge to the serial bins.
            for chunk in [777, LANES_MIN_REFS - 1] {
                let merged = refs
                    .chunks(chunk)
                    .map(|c| bin(c, &binner, nb))
                    .fold(new_bins(), |a, b| merge_bins(a, &b, nb));
                assert!(merged == avx, "{nb} bins: chunks of {chunk} differ");
            }
            let binned: u32 = portable[0][..nb].iter().map(|b| b.count()).sum();
            assert_eq!(binned as usize, refs.len());
        }
    }

    #[test]
    fn avx_lanes_and_chunks_equal_portable_binning_of_counts() {
        binning_paths_agree::<u32>();
    }

    #[test]
    fn avx_lanes_and_chunks_equal_portable_binning_of_visible_counts() {
        binning_paths_agree::<CountVisible>();
        // The visible counts are the references': every third.
        let tris = scattered(5000);
        let refs = refs_visible_every(&tris, 3);
        let (_, centroids) = bounds_of(&refs);
        let mut binning = Binning::<CountVisible>::new();
        let bins = binning.bin(&refs, &Binner::new(&centroids, 16), 16);
        let visible: u32 = bins[1][..16].iter().map(|b| b.payload.visible).sum();
        assert_eq!(visible as usize, 5000usize.div_ceil(3));
    }

    #[test]
    fn parallel_binning_equals_serial_binning() {
        // More than PARALLEL_BINNING references take the parallel chunks.
        let tris = scattered(PARALLEL_BINNING + 3000);
        let refs = refs_visible_every(&tris, 3);
        let (_, centroids) = bounds_of(&refs);
        let binner = Binner::new(&centroids, 16);
        let mut binning = Binning::<CountVisible>::new();
        let parallel = *binning.bin(&refs, &binner, 16);
        let mut serial = new_bins::<CountVisible>();
        bin_refs(&refs, &binner, 16, &mut serial, &mut new_lanes());
        assert!(parallel == *serial);
    }
}
