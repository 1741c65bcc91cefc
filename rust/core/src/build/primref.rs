//! Primitive references: a triangle's box with its id (and visibility) packed into the spare
//! fourth lanes, the 4-lane box every builder grows, and the bounds of a set of references.

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use crate::geometry::Aabb;

/// A triangle's box, with its id in the fourth lane of `lo` (as bits), so a reference is two
/// 16-byte vectors that min/max in one instruction each.
///
/// The id lane rides along through 4-lane arithmetic (areas, centroids, bin indices). Raw ids
/// below 2^23 are denormal floats, and every multiply that met one took a microcode assist;
/// the id is stored XOR [`ID_LANE_BIAS`], a normal float for any id below 2^30.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PrimRef {
    pub(crate) lo: Vec4,
    pub(crate) hi: Vec4,
}

/// Flips the id's bit 30 so the id lane holds a normal (or infinite/NaN) float, never a denormal
/// (for ids below 2^30).
const ID_LANE_BIAS: u32 = 0x4000_0000;

impl PrimRef {
    /// A reference to triangle `id` with the given box (a spatial split's clipped part, or
    /// the whole triangle's box).
    #[inline]
    pub(crate) fn new(id: u32, b: Box4) -> Self {
        PrimRef {
            lo: b.lo.truncate().extend(f32::from_bits(id ^ ID_LANE_BIAS)),
            hi: b.hi.truncate().extend(0.0),
        }
    }
    /// A reference to the whole of triangle `id`.
    #[inline]
    pub(crate) fn of_triangle(id: u32, triangle: &[Vec3; 3]) -> Self {
        let b = Aabb::of_triangle(triangle);
        PrimRef {
            lo: b.min.extend(f32::from_bits(id ^ ID_LANE_BIAS)),
            hi: b.max.extend(0.0),
        }
    }
    #[inline]
    pub(crate) fn id(&self) -> u32 {
        self.lo.w.to_bits() ^ ID_LANE_BIAS
    }
    /// The reference's box (without the id lane).
    #[inline]
    pub(crate) fn bounds(&self) -> Box4 {
        Box4 {
            lo: self.lo.truncate().extend(0.0),
            hi: self.hi,
        }
    }
    /// Whether the reference's triangle is in the visible set the build was given: carried in
    /// the upper corner's fourth lane (1.0 visible, 0.0 not), so the visibility-driven builders
    /// count visible references from the reference itself, not from a table indexed by id.
    #[inline]
    pub(crate) fn visible(&self) -> bool {
        self.hi.w != 0.0
    }
    /// The reference marked visible or not.
    #[inline]
    pub(crate) fn with_visibility(mut self, visible: bool) -> Self {
        self.hi.w = if visible { 1.0 } else { 0.0 };
        self
    }
    /// A reference to the same triangle, visible or not as this one, with box `b` (a part cut
    /// from this one by a spatial split).
    #[inline]
    pub(crate) fn with_bounds(&self, b: Box4) -> Self {
        PrimRef {
            lo: b.lo.truncate().extend(self.lo.w),
            hi: b.hi.truncate().extend(self.hi.w),
        }
    }
    /// Twice the centroid (the factor cancels in binning and saves a multiply).
    #[inline]
    pub(crate) fn centroid2(&self) -> Vec4 {
        self.lo + self.hi
    }
}

/// A box in the builder's 4-lane form; the fourth lane carries nothing meaningful (a box made
/// from references may hold their id and visibility lanes there).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Box4 {
    pub(crate) lo: Vec4,
    pub(crate) hi: Vec4,
}

impl Box4 {
    pub(crate) const EMPTY: Box4 = Box4 {
        lo: Vec4::splat(f32::INFINITY),
        hi: Vec4::splat(f32::NEG_INFINITY),
    };
    #[inline(always)]
    pub(crate) fn grow(&mut self, lo: Vec4, hi: Vec4) {
        self.lo = self.lo.min(lo);
        self.hi = self.hi.max(hi);
    }
    #[inline(always)]
    pub(crate) fn grow_box(&mut self, b: &Box4) {
        self.grow(b.lo, b.hi);
    }
    #[inline(always)]
    pub(crate) fn half_area(&self) -> f32 {
        let e = (self.hi - self.lo).truncate();
        if e.x < 0.0 {
            return 0.0;
        }
        e.x * e.y + e.y * e.z + e.z * e.x
    }
    #[inline]
    pub(crate) fn to_aabb(self) -> Aabb {
        Aabb::new(self.lo.truncate(), self.hi.truncate())
    }
}

/// References above this many are bounded in parallel chunks.
const PARALLEL_BOUNDS: usize = 65536;

/// Bounds and (doubled) centroid bounds of some references.
pub(crate) fn bounds_of(refs: &[PrimRef]) -> (Box4, Box4) {
    let fold = |(mut b, mut c): (Box4, Box4), r: &PrimRef| {
        b.grow(r.lo, r.hi);
        let c2 = r.centroid2();
        c.grow(c2, c2);
        (b, c)
    };
    let merge = |a: (Box4, Box4), b: (Box4, Box4)| {
        let (mut x, mut y) = a;
        x.grow_box(&b.0);
        y.grow_box(&b.1);
        (x, y)
    };
    if refs.len() > PARALLEL_BOUNDS {
        refs.par_chunks(16384)
            .map(|chunk| chunk.iter().fold((Box4::EMPTY, Box4::EMPTY), fold))
            .reduce(|| (Box4::EMPTY, Box4::EMPTY), merge)
    } else {
        refs.iter().fold((Box4::EMPTY, Box4::EMPTY), fold)
    }
}

/// The bounds of some references' doubled centroids (the second half of [`bounds_of`]; kept
/// apart because folding both through one generic helper slowed the SAH builder).
pub(crate) fn centroid_bounds_of(refs: &[PrimRef]) -> Box4 {
    let fold = |mut c: Box4, r: &PrimRef| {
        let c2 = r.centroid2();
        c.grow(c2, c2);
        c
    };
    let merge = |mut a: Box4, b: Box4| {
        a.grow_box(&b);
        a
    };
    if refs.len() > PARALLEL_BOUNDS {
        refs.par_chunks(16384)
            .map(|chunk| chunk.iter().fold(Box4::EMPTY, fold))
            .reduce(|| Box4::EMPTY, merge)
    } else {
        refs.iter().fold(Box4::EMPTY, fold)
    }
}

/// How many of `refs` are visible ([`PrimRef::visible`]).
pub(crate) fn count_visible(refs: &[PrimRef]) -> u32 {
    refs.iter().filter(|r| r.visible()).count() as u32
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

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
    fn id_lane_roundtrips_and_is_never_denormal() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        for id in [
            0,
            1,
            7,
            1 << 20,
            (1 << 23) - 1,
            1 << 23,
            (1 << 30) - 1,
            u32::MAX,
        ] {
            let r = PrimRef::of_triangle(id, &t);
            assert_eq!(r.id(), id);
            assert_eq!(PrimRef::new(id, r.bounds()).id(), id);
            if id < 1 << 30 {
                assert!(!r.lo.w.is_subnormal(), "id {id} stored as a denormal");
                assert!(
                    !r.centroid2().w.is_subnormal(),
                    "id {id}: centroid lane denormal"
                );
            }
        }
    }
}
