//! Spatial splits (Stich, Friedrich & Dietrich 2009): a node may be cut by a plane like a
//! kd-tree, and a reference straddling the plane goes to both children with the tight box of
//! its clipped part. Candidates are binned on the node's bounds (entry/exit counters per bin);
//! a straddling reference is "unsplit" into one child when that is cheaper than duplicating it.

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use super::binning::{in_lanes, truncate_lanes, use_avx, Corners, BIN_LANES, LANES_MIN_REFS};
use super::clip::{axis_lane, clipped_box, clipped_strips, cut_to_slab};
use super::osah_cost::{CostModel, Sides};
use super::primref::{Box4, PrimRef};

/// A spatial split: the plane `p[axis] = position` and the binned estimate of its sides.
#[derive(Clone, Copy, Debug)]
pub(super) struct SpatialSplit {
    pub(super) axis: usize,
    pub(super) position: f32,
    pub(super) sides: Sides,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Bin {
    corners: Corners,
    enter: u32,
    exit: u32,
    vis_enter: u32,
    vis_exit: u32,
}

const EMPTY_BIN: Bin = Bin {
    corners: Corners::EMPTY,
    enter: 0,
    exit: 0,
    vis_enter: 0,
    vis_exit: 0,
};

/// The best spatial split by SAH and (if `osah`) by OSAH cost, each with its cost, among the
/// planes on the axes flagged in `axes`. Splits that leave every reference on one side are
/// skipped: they would not shrink the node.
#[allow(clippy::too_many_arguments)]
pub(super) fn best_spatial_splits(
    refs: &[PrimRef],
    triangles: &[[Vec3; 3]],
    bounds: &Box4,
    parent_area: f32,
    bin_count: usize,
    axes: [bool; 3],
    clip: bool,
    model: &CostModel,
    osah: bool,
) -> [Option<(SpatialSplit, f32)>; 2] {
    let n = refs.len() as u32;
    let nb = bin_count.max(2);
    let extent = bounds.hi - bounds.lo;
    let axes: [bool; 3] = std::array::from_fn(|a| axes[a] && extent[a] > 0.0);
    let grid = Grid {
        bounds: *bounds,
        nb,
        axes,
        clip,
    };
    // Large nodes (the top levels) bin chunks in parallel and merge: every bin is a min/max and
    // integer sums, so the merged bins equal serial binning's exactly.
    let bins = if refs.len() > PARALLEL_BINNING {
        refs.par_chunks(BINNING_CHUNK)
            .map(|c| grid.bin(c, triangles))
            .reduce(|| vec![EMPTY_BIN; 3 * nb], merge_bins)
    } else {
        grid.bin(refs, triangles)
    };
    let mut best: [Option<(SpatialSplit, f32)>; 2] = [None, None];
    let mut right = vec![(Box4::EMPTY, 0u32, 0u32); nb];
    for axis in (0..3).filter(|&a| axes[a]) {
        grid.sweep(&bins, axis, n, &mut right, |i, sides| {
            let split = SpatialSplit {
                axis,
                position: grid.plane(axis, i),
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
        });
    }
    SPARE_BINS.set(bins);
    best
}

thread_local! {
    /// A thread's spare bins: [`Grid::bin`] takes them and [`best_spatial_splits`] gives them
    /// back, so the split builder's nodes do not allocate bins each.
    static SPARE_BINS: std::cell::Cell<Vec<Bin>> = const { std::cell::Cell::new(Vec::new()) };
}

/// Nodes with more references than this bin spatial candidates in parallel chunks.
const PARALLEL_BINNING: usize = 65536;
const BINNING_CHUNK: usize = 16384;

/// `nb` equal bins per axis over a node's bounds, on the flagged axes.
struct Grid {
    bounds: Box4,
    nb: usize,
    axes: [bool; 3],
    /// Whether a straddling reference's part in a bin is its clipped triangle's box (true) or
    /// its box cut at the bin's planes (false).
    clip: bool,
}

impl Grid {
    /// Plane `i` on `axis` (plane 0 and `nb` are the node's faces).
    #[inline]
    fn plane(&self, axis: usize, i: usize) -> f32 {
        if i == self.nb {
            self.bounds.hi[axis]
        } else {
            let step = (self.bounds.hi[axis] - self.bounds.lo[axis]) / self.nb as f32;
            self.bounds.lo[axis] + step * i as f32
        }
    }

    /// Hands `f(i, sides)` the two sides of every plane `i` (1..nb) on `axis` that leaves
    /// references of the node's `n` on both sides, from `all` as [`Grid::bin`] made it.
    /// `right` is scratch of `nb` entries.
    fn sweep(
        &self,
        all: &[Bin],
        axis: usize,
        n: u32,
        right: &mut [(Box4, u32, u32)],
        mut f: impl FnMut(usize, Sides),
    ) {
        let nb = self.nb;
        let bins = &all[axis * nb..(axis + 1) * nb];
        let on_axis = axis_lane(axis);
        let mut acc = (Box4::EMPTY, 0u32, 0u32);
        for i in (1..nb).rev() {
            acc.0.grow_box(&bins[i].corners.bounds());
            acc.1 += bins[i].exit;
            acc.2 += bins[i].vis_exit;
            right[i] = acc;
        }
        let mut left = (Box4::EMPTY, 0u32, 0u32);
        for i in 1..nb {
            let b = &bins[i - 1];
            left.0.grow_box(&b.corners.bounds());
            left.1 += b.enter;
            left.2 += b.vis_enter;
            let (n_left, n_right) = (left.1, right[i].1);
            if n_left == 0 || n_right == 0 || n_left >= n || n_right >= n {
                continue;
            }
            let (left_box, right_box) = if self.clip {
                (left.0, right[i].0)
            } else {
                // Cut boxes: a straddling reference's whole box sits in its first and last
                // bin (see `Grid::bin`), so each side is cut at the plane, which leaves on
                // the side the union of that reference's cuts to the bins it spans there.
                let p = self.plane(axis, i);
                let l = cut_to_slab(left.0.lo, left.0.hi, on_axis, f32::NEG_INFINITY, p);
                let r = cut_to_slab(right[i].0.lo, right[i].0.hi, on_axis, p, f32::INFINITY);
                (Box4 { lo: l.0, hi: l.1 }, Box4 { lo: r.0, hi: r.1 })
            };
            f(
                i,
                Sides {
                    left: left_box,
                    right: right_box,
                    n_left,
                    n_right,
                    vis_left: left.2,
                    vis_right: right[i].2,
                },
            );
        }
    }

    /// Bins `refs` on every flagged axis (axis a's bins at `a * nb..`): each reference enters
    /// the bin of its low end and exits the bin of its high end. With clipping, the tight box
    /// of its part in each bin it spans grows that bin; with cut boxes, its whole box grows
    /// its first and last bin, and [`Grid::sweep`] cuts the sides.
    fn bin(&self, refs: &[PrimRef], triangles: &[[Vec3; 3]]) -> Vec<Bin> {
        let nb = self.nb;
        let mut all = SPARE_BINS.take();
        self.clear_flagged(&mut all, 1);
        // One loop per path, each a separate instance: sharing one loop made the cut-box
        // path (most nodes) carry the clipping path's per-reference setup.
        if self.clip {
            // Clipping's planes on the flagged axes.
            let planes: [Vec<f32>; 3] = std::array::from_fn(|axis| {
                if self.axes[axis] {
                    (0..=nb).map(|i| self.plane(axis, i)).collect()
                } else {
                    Vec::new()
                }
            });
            // Counts and one-bin boxes first, then the straddling references' clipping in a
            // loop of its own: one loop doing both spilled the clipper's state on every
            // reference (the bins are minima, maxima and sums, so the order does not matter).
            let mut straddling: Vec<(&PrimRef, usize, usize, usize)> = Vec::new();
            self.bin_with(refs, &mut all, |_, b0, b1, r, axis| {
                straddling.push((r, axis, b0, b1));
            });
            for (r, axis, b0, b1) in straddling {
                let tri = &triangles[r.id() as usize];
                let strips = &mut all[axis * nb + b0..=axis * nb + b1];
                clipped_strips(
                    tri,
                    axis,
                    planes[axis][b0..=b1 + 1].iter().copied(),
                    &r.bounds(),
                    |j, part| strips[j].corners.grow_box(&part),
                );
            }
        } else {
            #[cfg(target_arch = "x86_64")]
            if use_avx() {
                if refs.len() < LANES_MIN_REFS {
                    // SAFETY: AVX is present (checked above).
                    unsafe { self.bin_cut_boxes_avx(refs, &mut [&mut all]) };
                    return all;
                }
                // In lanes, as the SAH builder bins, merged into the first.
                self.clear_flagged(&mut all, BIN_LANES);
                let mut it = all.chunks_exact_mut(3 * nb);
                let [a, b, c, d] = std::array::from_fn(|_| it.next().unwrap());
                // SAFETY: AVX is present (checked above).
                unsafe { self.bin_cut_boxes_avx(refs, &mut [a, b, c, d]) };
                let (first, rest) = all.split_at_mut(3 * nb);
                for lane in rest.chunks_exact(3 * nb).take(BIN_LANES - 1) {
                    for axis in self.flagged_axes().into_iter().flatten() {
                        let on_axis = axis * nb..(axis + 1) * nb;
                        merge_into(&mut first[on_axis.clone()], &lane[on_axis]);
                    }
                }
                all.truncate(3 * nb);
                return all;
            }
            self.bin_with(refs, &mut all, |bins, b0, b1, r, _| {
                // The whole box into its first and last bin only: `Grid::sweep` cuts each
                // side at its plane, which gives the sides the union of the box's cuts to
                // every bin it spans, in two updates instead of one per bin.
                bins[b0].corners.grow_box(&r.bounds());
                bins[b1].corners.grow_box(&r.bounds());
            });
        }
        all
    }

    /// The cut-box path of [`Grid::bin`] with each bin's corners grown by one 8-lane `min`,
    /// and without a branch on whether a reference straddles a plane: its box grows its first
    /// and its last bin, the same bin for a reference inside one (a min is idempotent). That
    /// branch is as good as random, and mispredicted it cost more than the second update.
    /// `lanes` holds one or [`BIN_LANES`] sets of bins (3 x `nb` each), which consecutive
    /// references take in turn.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn bin_cut_boxes_avx(&self, refs: &[PrimRef], lanes: &mut [&mut [Bin]]) {
        let map = self.bin_map();
        let nb = self.nb;
        let count = lanes.len();
        // Most nodes bin one axis (the best object split's): a loop of its own skips the
        // per-reference walk over the other two.
        if let [Some(axis), None, None] = self.flagged_axes() {
            let mut on_axis = lanes.iter_mut().map(|l| &mut l[axis * nb..(axis + 1) * nb]);
            match count {
                1 => {
                    let bins = on_axis.next().expect("one lane");
                    refs.iter()
                        .for_each(|r| cut_box_on_axis(&map, r, bins, axis));
                }
                BIN_LANES => {
                    let mut l: [&mut [Bin]; BIN_LANES] =
                        std::array::from_fn(|_| on_axis.next().expect("BIN_LANES lanes"));
                    let [a, b, c, d] = &mut l;
                    in_lanes(refs, [a, b, c, d], |r, bins| {
                        cut_box_on_axis(&map, r, bins, axis)
                    });
                }
                _ => unreachable!("one lane or BIN_LANES"),
            }
            return;
        }
        let axes = self.axes;
        let mut split = lanes.iter_mut().map(|l| {
            let mut it = l.chunks_exact_mut(nb);
            std::array::from_fn::<_, 3, _>(|_| it.next().expect("three axes"))
        });
        match count {
            1 => {
                let mut bins = split.next().expect("one lane");
                refs.iter()
                    .for_each(|r| cut_box_on_axes(&map, r, &mut bins, axes));
            }
            BIN_LANES => {
                let mut l: [[&mut [Bin]; 3]; BIN_LANES] =
                    std::array::from_fn(|_| split.next().expect("BIN_LANES lanes"));
                let [a, b, c, d] = &mut l;
                in_lanes(refs, [a, b, c, d], |r, bins| {
                    cut_box_on_axes(&map, r, bins, axes)
                });
            }
            _ => unreachable!("one lane or BIN_LANES"),
        }
    }

    /// Makes `all` hold `lanes` sets of 3 x `nb` bins with the flagged axes' bins empty. The
    /// other axes' bins keep whatever an earlier node left: nothing reads them, and a node
    /// usually bins one axis, so clearing all three (and merging them) was most of the work
    /// around the binning loop.
    fn clear_flagged(&self, all: &mut Vec<Bin>, lanes: usize) {
        let nb = self.nb;
        if all.len() < lanes * 3 * nb {
            all.resize(lanes * 3 * nb, EMPTY_BIN);
        }
        for lane in all.chunks_exact_mut(3 * nb).take(lanes) {
            for axis in self.flagged_axes().into_iter().flatten() {
                lane[axis * nb..(axis + 1) * nb].fill(EMPTY_BIN);
            }
        }
    }

    /// The flagged axes in order, then `None`s.
    fn flagged_axes(&self) -> [Option<usize>; 3] {
        let mut out = [None; 3];
        let flagged = (0..3).filter(|&a| self.axes[a]);
        for (slot, axis) in out.iter_mut().zip(flagged) {
            *slot = Some(axis);
        }
        out
    }

    fn bin_map(&self) -> BinMap {
        BinMap {
            lo: self.bounds.lo.truncate().extend(0.0),
            step: ((self.bounds.hi - self.bounds.lo) / self.nb as f32)
                .truncate()
                .extend(1.0),
            last: Vec4::splat((self.nb - 1) as f32),
        }
    }

    /// The loop of [`Grid::bin`] into `all` (3 x `nb` empty bins): entry and exit counts,
    /// and the box of a reference that stays in one bin; `straddling(bins, b0, b1, r, axis)`
    /// grows the bins `b0 < b1` of a reference that spans several.
    #[inline(always)]
    fn bin_with<'r>(
        &self,
        refs: &'r [PrimRef],
        all: &mut [Bin],
        mut straddling: impl FnMut(&mut [Bin], usize, usize, &'r PrimRef, usize),
    ) {
        let nb = self.nb;
        let map = self.bin_map();
        let (bx, rest) = all.split_at_mut(nb);
        let (by, bz) = rest.split_at_mut(nb);
        let flags = self.axes;
        for r in refs {
            let (first, final_) = map.range(r);
            let visible = r.visible() as u32;
            for (axis, bins) in [(0, &mut *bx), (1, &mut *by), (2, &mut *bz)] {
                if !flags[axis] {
                    continue;
                }
                let b0 = first[axis] as usize;
                let b1 = (final_[axis] as usize).max(b0);
                if b0 == b1 {
                    bins[b0].corners.grow_box(&r.bounds());
                } else {
                    straddling(bins, b0, b1, r, axis);
                }
                bins[b0].enter += 1;
                bins[b0].vis_enter += visible;
                bins[b1].exit += 1;
                bins[b1].vis_exit += visible;
            }
        }
    }
}

/// One reference's box into the cut-box bins of one axis: it grows its first and its last bin
/// (the same bin for a reference inside one; a min is idempotent) and enters and exits there.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn bin_cut_box_avx(
    bins: &mut [Bin],
    (first, last): (u32, u32),
    corners: std::arch::x86_64::__m256,
    visible: u32,
) {
    let b0 = first as usize;
    let b1 = (last as usize).max(b0);
    bins[b0].corners.grow_avx(corners);
    bins[b1].corners.grow_avx(corners);
    bins[b0].enter += 1;
    bins[b0].vis_enter += visible;
    bins[b1].exit += 1;
    bins[b1].vis_exit += visible;
}

/// One reference's cut box into the bins of `axis`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn cut_box_on_axis(map: &BinMap, r: &PrimRef, bins: &mut [Bin], axis: usize) {
    let (first, final_) = map.range(r);
    let corners = Corners::of_box_avx(&r.bounds());
    let range = (first[axis], final_[axis]);
    bin_cut_box_avx(bins, range, corners, r.visible() as u32);
}

/// One reference's cut box into the bins of each flagged axis.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn cut_box_on_axes(map: &BinMap, r: &PrimRef, bins: &mut [&mut [Bin]; 3], axes: [bool; 3]) {
    let (first, final_) = map.range(r);
    let visible = r.visible() as u32;
    let corners = Corners::of_box_avx(&r.bounds());
    for (axis, axis_bins) in bins.iter_mut().enumerate() {
        if axes[axis] {
            let range = (first[axis], final_[axis]);
            bin_cut_box_avx(axis_bins, range, corners, visible);
        }
    }
}

/// Per axis, the scalar mapping `((x - lo) / step).max(0)` clamped to the last bin, in 4 lanes
/// (lane 3 is unused) with the same arithmetic: one division gives a reference's low bins on
/// every axis, one more its high bins.
struct BinMap {
    lo: Vec4,
    step: Vec4,
    last: Vec4,
}

impl BinMap {
    /// The bins of a reference's low and high ends on every axis.
    #[inline(always)]
    fn range(&self, r: &PrimRef) -> ([u32; 4], [u32; 4]) {
        let bin =
            |x: Vec4| truncate_lanes(((x - self.lo) / self.step).max(Vec4::ZERO).min(self.last));
        (bin(r.lo), bin(r.hi))
    }
}

fn merge_bins(mut a: Vec<Bin>, b: Vec<Bin>) -> Vec<Bin> {
    merge_into(&mut a, &b);
    a
}

fn merge_into(a: &mut [Bin], b: &[Bin]) {
    for (x, y) in a.iter_mut().zip(b) {
        x.corners.merge(&y.corners);
        x.enter += y.enter;
        x.exit += y.exit;
        x.vis_enter += y.vis_enter;
        x.vis_exit += y.vis_exit;
    }
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
            left.push(r.with_bounds(lpart));
            right.push(r.with_bounds(rpart));
        }
    }
    (left, right)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build::binning::portable_and_avx;
    use crate::build::primref::bounds_of;
    use crate::build::primref::tests::{refs_visible_every, scattered};

    #[test]
    fn chunked_and_avx_binning_equal_serial_portable_binning() {
        let tris = scattered(5000);
        let refs = refs_visible_every(&tris, 3);
        let (bounds, _) = bounds_of(&refs);
        for axes in [[true; 3], [false, true, false], [true, false, true]] {
            let grid = Grid {
                bounds,
                nb: 32,
                axes,
                clip: true,
            };
            let serial = grid.bin(&refs, &tris);
            let merged = refs
                .chunks(613)
                .map(|c| grid.bin(c, &tris))
                .fold(vec![EMPTY_BIN; 3 * 32], merge_bins);
            assert_eq!(serial, merged);
            let entered: u32 = serial.iter().map(|b| b.enter).sum();
            assert_eq!(entered as usize, 5000 * axes.iter().filter(|&&a| a).count());
            // The cut-box path has an AVX loop of its own.
            let cut = Grid {
                clip: false,
                ..grid
            };
            let (portable, avx) = portable_and_avx(|| cut.bin(&refs, &tris));
            assert_eq!(portable, avx, "AVX and portable cut-box binning differ");
            // Chunks under LANES_MIN_REFS bin in one lane, the whole in lanes: the same bins.
            let (_, one_lane) = portable_and_avx(|| {
                refs.chunks(LANES_MIN_REFS - 1)
                    .map(|c| cut.bin(c, &tris))
                    .fold(vec![EMPTY_BIN; 3 * 32], merge_bins)
            });
            assert_eq!(one_lane, avx, "AVX: one lane and lanes differ");
        }
    }

    #[test]
    fn bins_left_by_an_earlier_node_do_not_change_the_best_splits() {
        // A thread's spare bins keep an earlier node's bins on the axes a node does not bin;
        // the axes it bins must start empty whatever was there (other bin counts, lanes).
        let tris = scattered(3000);
        let refs = refs_visible_every(&tris, 3);
        let model = CostModel {
            traversal: 1.0,
            intersection: 1.0,
            weight: 0.9,
        };
        let best = |refs: &[PrimRef], nb: usize, axes: [bool; 3]| {
            let (bounds, _) = bounds_of(refs);
            let area = bounds.half_area();
            let found =
                best_spatial_splits(refs, &tris, &bounds, area, nb, axes, false, &model, true);
            format!("{found:?}")
        };
        let on_own_thread =
            |f: &(dyn Fn() -> String + Sync)| std::thread::scope(|s| s.spawn(f).join().unwrap());
        // 1000 references bin in lanes, 100 in one.
        for (n, nb, axes) in [
            (1000, 16, [false, true, false]),
            (100, 8, [false, false, true]),
        ] {
            let fresh = on_own_thread(&|| best(&refs[..n], nb, axes));
            let after = on_own_thread(&|| {
                best(&refs, 32, [true; 3]);
                best(&refs[n..], 24, [true, false, true]);
                best(&refs[..n], nb, axes)
            });
            assert_eq!(after, fresh, "{n} references, {nb} bins, axes {axes:?}");
        }
    }

    /// The sides of every plane on every axis.
    fn all_sides(grid: &Grid, refs: &[PrimRef], tris: &[[Vec3; 3]]) -> Vec<Sides> {
        let bins = grid.bin(refs, tris);
        let mut right = vec![(Box4::EMPTY, 0, 0); grid.nb];
        let mut out = Vec::new();
        for axis in 0..3 {
            grid.sweep(&bins, axis, refs.len() as u32, &mut right, |_, s| {
                out.push(s)
            });
        }
        out
    }

    /// The cut-box estimate as first written: a straddling reference's box cut to every bin
    /// it spans, swept without cutting the sides.
    fn sides_of_cuts_per_bin(grid: &Grid, refs: &[PrimRef]) -> Vec<Sides> {
        let nb = grid.nb;
        let mut bins = vec![EMPTY_BIN; 3 * nb];
        for axis in 0..3 {
            let bins = &mut bins[axis * nb..(axis + 1) * nb];
            let (lo, hi) = (grid.bounds.lo[axis], grid.bounds.hi[axis]);
            let step = (hi - lo) / nb as f32;
            let bin_of = |x: f32| (((x - lo) / step).max(0.0) as usize).min(nb - 1);
            for r in refs {
                let (b0, b1) = (bin_of(r.lo[axis]), bin_of(r.hi[axis]));
                let b1 = b1.max(b0);
                for (j, bin) in bins[b0..=b1].iter_mut().enumerate() {
                    let mut part = r.bounds();
                    part.lo[axis] = part.lo[axis].max(grid.plane(axis, b0 + j));
                    part.hi[axis] = part.hi[axis].min(grid.plane(axis, b0 + j + 1));
                    bin.corners.grow_box(&part);
                }
                let v = r.visible() as u32;
                bins[b0].enter += 1;
                bins[b0].vis_enter += v;
                bins[b1].exit += 1;
                bins[b1].vis_exit += v;
            }
        }
        let clipped_grid = Grid {
            clip: true,
            ..*grid
        };
        let mut right = vec![(Box4::EMPTY, 0, 0); nb];
        let mut out = Vec::new();
        for axis in 0..3 {
            // `clip: true` sweeps without cutting the sides, as the first version did.
            clipped_grid.sweep(&bins, axis, refs.len() as u32, &mut right, |_, s| {
                out.push(s)
            });
        }
        out
    }

    #[test]
    fn cut_boxes_bound_clipped_boxes_with_the_same_counts() {
        // Binning without clipping (small nodes, `clip_min_refs`) must see the same entries and
        // exits on every side, and each side's box must contain the clipped one (it is the
        // looser estimate); it must equal cutting the box to every bin it spans.
        let tris = scattered(3000);
        let refs = refs_visible_every(&tris, 4);
        let (bounds, _) = bounds_of(&refs);
        let grid = |clip| Grid {
            bounds,
            nb: 32,
            axes: [true; 3],
            clip,
        };
        let clipped = all_sides(&grid(true), &refs, &tris);
        let cut = all_sides(&grid(false), &refs, &tris);
        let per_bin = sides_of_cuts_per_bin(&grid(false), &refs);
        assert_eq!(clipped.len(), cut.len());
        assert_eq!(cut.len(), per_bin.len());
        assert!(
            cut.len() > 3 * 20,
            "most planes split the scattered triangles"
        );
        let counts = |s: &Sides| (s.n_left, s.n_right, s.vis_left, s.vis_right);
        let contains = |a: &Box4, b: &Box4| a.lo.cmple(b.lo).all() && a.hi.cmpge(b.hi).all();
        let mut looser = 0;
        for ((c, x), p) in clipped.iter().zip(&cut).zip(&per_bin) {
            assert_eq!(counts(c), counts(x));
            assert_eq!(counts(c), counts(p));
            for (xb, cb, pb) in [(&x.left, &c.left, &p.left), (&x.right, &c.right, &p.right)] {
                assert!(contains(xb, cb), "cut {xb:?} must contain clipped {cb:?}");
                assert_eq!(xb, pb, "cut at the plane must equal cuts per bin");
                looser += (xb != cb) as usize;
            }
        }
        assert!(looser > 0, "the scattered triangles straddle bins");
    }
}
