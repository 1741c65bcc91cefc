//! Tight boxes of a triangle's part inside an axis-aligned slab, for spatial splits: a
//! reference cut by a split plane gets the box of its clipped polygon, not the cut of its box
//! (the "split clipping" of Havran & Bittner that Stich et al. use).

use glam::{BVec4A, Vec3, Vec4};

use super::primref::Box4;

/// The box of the part of `triangle` with `lo <= p[axis] <= hi`, intersected with `within`
/// (the reference's current box, which already bounds earlier cuts). Empty if nothing is left.
///
/// Conservative: points computed on the plane are rounded, so the box is widened by a few ulps
/// across the other two axes before it is cut back to `within`; along `axis` it ends exactly at
/// the planes, so the two halves of a cut meet without a gap.
pub(super) fn clipped_box(
    triangle: &[Vec3; 3],
    axis: usize,
    lo: f32,
    hi: f32,
    within: &Box4,
) -> Box4 {
    let mut b = plane_points(triangle, axis, lo);
    b.grow_box(&plane_points(triangle, axis, hi));
    cut_back(b, triangle, axis, lo, hi, within)
}

/// [`clipped_box`] for each of the consecutive slabs between `planes[j]` and `planes[j + 1]`,
/// handed to `emit(j, box)`: the same boxes, bit for bit, but each plane's edge crossings are
/// computed once for the two slabs that share it (spatial binning clips a reference into
/// every bin it spans, which made clipping half of an OSAH build's time), and the triangle's
/// vertices and edge vectors are put in 4-lane form once per reference instead of per plane.
pub(super) fn clipped_strips(
    triangle: &[Vec3; 3],
    axis: usize,
    planes: impl Iterator<Item = f32>,
    within: &Box4,
    mut emit: impl FnMut(usize, Box4),
) {
    let mut planes = planes;
    let Some(mut lo) = planes.next() else {
        return;
    };
    let tri = Tri4::new(triangle, axis);
    let mut at_lo = tri.plane_points(lo);
    for (j, hi) in planes.enumerate() {
        let at_hi = tri.plane_points(hi);
        let mut b = at_lo;
        b.grow_box(&at_hi);
        emit(j, tri.cut_back(b, lo, hi, within));
        (lo, at_lo) = (hi, at_hi);
    }
}

/// A triangle prepared for clipping along one axis: the same arithmetic as [`plane_points`]
/// and [`cut_back`] lane for lane (so the same bits), without per-plane indexing and 3-lane
/// scalar code.
struct Tri4 {
    /// Vertices (lane 3 zero).
    v: [Vec4; 3],
    /// Edge vectors `v[(i + 1) % 3] - v[i]`.
    d: [Vec4; 3],
    /// Vertex coordinates on the axis.
    ax: [f32; 3],
    axis: usize,
    /// Lane `axis` and lane 3 set: the lanes a plane point takes from [`Tri4::on_plane`].
    fixed: BVec4A,
    /// The two lanes across the slab (neither `axis` nor lane 3).
    across: BVec4A,
}

impl Tri4 {
    #[inline]
    fn new(t: &[Vec3; 3], axis: usize) -> Self {
        let v = [t[0].extend(0.0), t[1].extend(0.0), t[2].extend(0.0)];
        let lane = |i: usize| BVec4A::new(i == 0, i == 1, i == 2, i == 3);
        let is_axis = lane(axis);
        Tri4 {
            v,
            d: [t[1] - t[0], t[2] - t[1], t[0] - t[2]].map(|e| e.extend(0.0)),
            ax: [t[0][axis], t[1][axis], t[2][axis]],
            axis,
            fixed: is_axis | lane(3),
            across: !(is_axis | lane(3)),
        }
    }

    /// [`plane_points`].
    #[inline]
    fn plane_points(&self, plane: f32) -> Box4 {
        let on_plane = Vec4::select(
            BVec4A::new(self.axis == 0, self.axis == 1, self.axis == 2, false),
            Vec4::splat(plane),
            Vec4::ZERO,
        );
        let mut b = Box4::EMPTY;
        for i in 0..3 {
            let (da, dc) = (self.ax[i] - plane, self.ax[(i + 1) % 3] - plane);
            if (da < 0.0 && dc > 0.0) || (da > 0.0 && dc < 0.0) {
                let t = da / (da - dc);
                let p = Vec4::select(self.fixed, on_plane, self.v[i] + self.d[i] * t);
                b.grow(p, p);
            }
        }
        b
    }

    /// [`cut_back`].
    #[inline]
    fn cut_back(&self, mut b: Box4, lo: f32, hi: f32, within: &Box4) -> Box4 {
        for i in 0..3 {
            if (lo..=hi).contains(&self.ax[i]) {
                b.grow(self.v[i], self.v[i]);
            }
        }
        if b.lo.x > b.hi.x {
            return Box4::EMPTY;
        }
        let pad = Vec4::select(
            self.across,
            b.lo.abs().max(b.hi.abs()) * (4.0 * f32::EPSILON),
            Vec4::ZERO,
        );
        padded_within_slab(b, pad, self.axis, lo, hi, within)
    }
}

/// The box of the points where the triangle's edges cross `p[axis] = plane` strictly (the
/// points are put exactly on the plane).
#[inline]
fn plane_points(triangle: &[Vec3; 3], axis: usize, plane: f32) -> Box4 {
    let mut b = Box4::EMPTY;
    for i in 0..3 {
        let a = triangle[i];
        let c = triangle[(i + 1) % 3];
        let (da, dc) = (a[axis] - plane, c[axis] - plane);
        if (da < 0.0 && dc > 0.0) || (da > 0.0 && dc < 0.0) {
            let t = da / (da - dc);
            let mut p = a + (c - a) * t;
            p[axis] = plane;
            let p4 = p.extend(0.0);
            b.grow(p4, p4);
        }
    }
    b
}

/// Adds the vertices inside the slab to `b` (the slab's plane points), widens it by a few ulps
/// across the slab and cuts it back to `within` and the slab.
#[inline]
fn cut_back(
    mut b: Box4,
    triangle: &[Vec3; 3],
    axis: usize,
    lo: f32,
    hi: f32,
    within: &Box4,
) -> Box4 {
    for a in triangle {
        if (lo..=hi).contains(&a[axis]) {
            let p4 = a.extend(0.0);
            b.grow(p4, p4);
        }
    }
    if b.lo.x > b.hi.x {
        return Box4::EMPTY;
    }
    let pad = (b.lo.abs().max(b.hi.abs()) * (4.0 * f32::EPSILON)).truncate();
    let mut pad = pad.extend(0.0);
    pad[axis] = 0.0;
    padded_within_slab(b, pad, axis, lo, hi, within)
}

/// `b` widened by `pad`, cut back to `within` and to the slab `lo..=hi` on `axis`; empty if
/// nothing is left. The last lane is zeroed.
#[inline(always)]
fn padded_within_slab(b: Box4, pad: Vec4, axis: usize, lo: f32, hi: f32, within: &Box4) -> Box4 {
    let lo4 = (b.lo - pad).max(within.lo);
    let hi4 = (b.hi + pad).min(within.hi);
    let (lo4, hi4) = cut_to_slab(lo4, hi4, axis_lane(axis), lo, hi);
    if lo4.truncate().cmpgt(hi4.truncate()).any() {
        return Box4::EMPTY;
    }
    Box4 {
        lo: lo4 * Vec4::new(1.0, 1.0, 1.0, 0.0),
        hi: hi4 * Vec4::new(1.0, 1.0, 1.0, 0.0),
    }
}

/// The lane of `axis` (0, 1 or 2) as a mask.
#[inline(always)]
pub(super) fn axis_lane(axis: usize) -> BVec4A {
    BVec4A::new(axis == 0, axis == 1, axis == 2, false)
}

/// The box `lo..hi` cut to `slab_lo..=slab_hi` in the lanes of `on_axis`. A select rather
/// than a write to one lane: writing a lane of a vector goes through the stack, and the wide
/// reload that follows stalls on store forwarding (a quarter of spatial binning's time).
#[inline(always)]
pub(super) fn cut_to_slab(
    lo: Vec4,
    hi: Vec4,
    on_axis: BVec4A,
    slab_lo: f32,
    slab_hi: f32,
) -> (Vec4, Vec4) {
    (
        Vec4::select(on_axis, lo.max(Vec4::splat(slab_lo)), lo),
        Vec4::select(on_axis, hi.min(Vec4::splat(slab_hi)), hi),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn whole(t: &[Vec3; 3]) -> Box4 {
        let mut b = Box4::EMPTY;
        for v in t {
            b.grow(v.extend(0.0), v.extend(0.0));
        }
        b
    }

    #[test]
    fn clipped_box_is_tighter_than_the_cut_box() {
        // A diagonal triangle: cutting its box at x = 0.5 would keep y up to 1 on the right,
        // but the triangle's right part only reaches y = 0.5.
        let t = [
            Vec3::ZERO,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let right = clipped_box(&t, 0, 0.5, 1.0, &whole(&t));
        assert_eq!(right.lo.truncate(), Vec3::new(0.5, 0.0, 0.0));
        assert!((right.hi.y - 0.5).abs() < 1e-6, "{right:?}");
        let left = clipped_box(&t, 0, 0.0, 0.5, &whole(&t));
        assert_eq!(left.hi.x, 0.5);
        assert!((left.hi.y - 1.0).abs() < 1e-6);
    }

    #[test]
    fn strips_equal_one_clip_per_slab() {
        let t = [
            Vec3::new(0.1, -0.3, 0.2),
            Vec3::new(0.9, 0.7, -0.4),
            Vec3::new(0.35, 0.2, 0.8),
        ];
        let within = whole(&t);
        let planes = [0.0, 0.25, 0.35, 0.5, 0.75, 1.0];
        for axis in 0..3 {
            let mut seen = 0;
            clipped_strips(&t, axis, planes.iter().copied(), &within, |j, b| {
                let one = clipped_box(&t, axis, planes[j], planes[j + 1], &within);
                assert_eq!(b, one, "axis {axis} slab {j}");
                seen += 1;
            });
            assert_eq!(seen, planes.len() - 1);
        }
    }

    #[test]
    fn strips_equal_one_clip_per_slab_on_random_triangles() {
        // The 4-lane strip clipper against the per-slab clipper, bit for bit, over triangles of
        // every orientation and size, with planes that hit vertices exactly.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut rand = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32 * 8.0 - 4.0
        };
        for k in 0..2000 {
            let mut t = [Vec3::ZERO; 3];
            for v in &mut t {
                *v = Vec3::new(rand(), rand(), rand());
            }
            if k % 7 == 0 {
                t[2].y = t[0].y; // an edge parallel to a plane
            }
            let within = whole(&t);
            for axis in 0..3 {
                let (lo, hi) = (within.lo[axis], within.hi[axis]);
                let n = 1 + k % 9;
                let step = (hi - lo) / n as f32;
                let mut planes: Vec<f32> = (0..=n).map(|i| lo + step * i as f32).collect();
                planes[n] = hi;
                if n > 2 {
                    planes[1] = t[k % 3][axis].clamp(planes[0], planes[2]);
                }
                let mut seen = 0;
                clipped_strips(&t, axis, planes.iter().copied(), &within, |j, b| {
                    let one = clipped_box(&t, axis, planes[j], planes[j + 1], &within);
                    assert_eq!(
                        (
                            b.lo.to_array().map(f32::to_bits),
                            b.hi.to_array().map(f32::to_bits)
                        ),
                        (
                            one.lo.to_array().map(f32::to_bits),
                            one.hi.to_array().map(f32::to_bits)
                        ),
                        "triangle {k} axis {axis} slab {j}"
                    );
                    seen += 1;
                });
                assert_eq!(seen, n);
            }
        }
    }

    #[test]
    fn slab_missing_the_triangle_is_empty() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let b = clipped_box(&t, 2, 1.0, 2.0, &whole(&t));
        assert!(b.lo.x > b.hi.x);
    }

    #[test]
    fn result_stays_inside_the_reference_box() {
        let t = [
            Vec3::ZERO,
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(0.0, 4.0, 1.0),
        ];
        let within = Box4 {
            lo: Vec4::new(0.0, 0.0, 0.0, 0.0),
            hi: Vec4::new(2.0, 1.0, 1.0, 0.0),
        };
        let b = clipped_box(&t, 0, 1.0, 3.0, &within);
        assert!(b.lo.cmpge(within.lo).all() && b.hi.cmple(within.hi).all());
        assert_eq!((b.lo.x, b.hi.x), (1.0, 2.0));
    }
}
