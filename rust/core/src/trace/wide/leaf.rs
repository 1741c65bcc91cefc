//! Leaf triangles several at a time (x86_64: four lanes with SSE, eight with AVX2): the
//! watertight test of [`intersect_triangle`] with the same f32 operations in the same order in
//! every lane, so each lane's answer is the scalar test's bit for bit. A lane with an edge
//! function exactly 0 (where the scalar test recomputes in f64) is handed to the scalar test.
//!
//! Triangles are read from [`TriangleRows`]: blocks of four consecutive triangle slots, each
//! block the nine coordinates (vertex x axis) as rows of four lanes, 144 contiguous bytes. A
//! leaf's triangles are then two or three neighbouring cache lines rather than nine scattered
//! rows. Leaves start at any slot: a test covers the aligned blocks a leaf touches (one with
//! SSE, two with AVX2) and masks the lanes outside it.

use crate::bvh::TriangleRows;
use crate::geometry::{intersect_triangle, WatertightRay};
use glam::Vec3;

/// How a traversal tests leaf triangles: one at a time (the reference, in the traversal's own
/// loop; here it means every lane takes the scalar test), or in SIMD windows of four (SSE) or
/// eight (AVX2, only inside functions compiled with that feature) lanes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LeafLanes {
    Scalar,
    Four,
    Eight,
}

impl LeafLanes {
    fn width(self) -> usize {
        match self {
            LeafLanes::Scalar | LeafLanes::Four => 4,
            LeafLanes::Eight => 8,
        }
    }
}

/// The windows covering slots `first..first + count`: per window its first block and the mask
/// of its lanes inside the range.
#[inline(always)]
fn windows(first: usize, count: usize, lanes: usize) -> impl Iterator<Item = (usize, u32)> {
    let end = first + count;
    (first / 4..end.div_ceil(4))
        .step_by(lanes / 4)
        .map(move |block| {
            let base = 4 * block;
            let lo = first.max(base) - base;
            let hi = end.min(base + lanes) - base;
            (block, ((1u32 << hi) - 1) & !((1u32 << lo) - 1))
        })
}

/// Slots `4 * block ..` against the ray for t in (`t_min`, `t_max`], lanes of `valid` only:
/// bit i of the result is set when slot `4 * block + i` is hit, `t[i]` is its distance and
/// (without `ANY`, the any-hit form) `bary[k][i]` its barycentric k, all bit for bit the
/// scalar test's.
#[inline(always)]
#[allow(clippy::too_many_arguments)] // the scalar test's arguments plus the window
fn test_window<const ANY: bool>(
    lanes: LeafLanes,
    rows: &TriangleRows,
    triangles: &[[Vec3; 3]],
    ray: &WatertightRay,
    block: usize,
    valid: u32,
    t_min: f32,
    t_max: f32,
    t: &mut [f32; 8],
    bary: &mut [[f32; 8]; 3],
) -> u32 {
    #[cfg(target_arch = "x86_64")]
    let (hits, zero) = match lanes {
        LeafLanes::Four => simd::four::<ANY>(rows, ray, block, t_min, t_max, t, bary),
        LeafLanes::Eight => simd::eight::<ANY>(rows, ray, block, t_min, t_max, t, bary),
        LeafLanes::Scalar => (0, u32::MAX),
    };
    #[cfg(not(target_arch = "x86_64"))]
    let (hits, zero) = {
        let _ = (lanes, rows);
        (0, u32::MAX)
    };
    // Lanes whose edge functions are exactly 0 (and every lane of the scalar path) take the
    // scalar test.
    let mut hits = hits & valid & !zero;
    let mut fallback = zero & valid;
    while fallback != 0 {
        let i = fallback.trailing_zeros() as usize;
        fallback &= fallback - 1;
        if let Some(h) = intersect_triangle(ray, &triangles[4 * block + i], t_min, t_max) {
            t[i] = h.t;
            [bary[0][i], bary[1][i], bary[2][i]] = [h.b0, h.b1, h.b2];
            hits |= 1 << i;
        }
    }
    hits
}

/// For the any-hit traversal: how many of the leaf's triangles the scalar loop would test
/// before and including the first hit, or `None` when none is hit.
#[inline(always)]
#[allow(clippy::too_many_arguments)] // the scalar test's arguments plus the leaf's range
pub(crate) fn first_hit(
    lanes: LeafLanes,
    rows: &TriangleRows,
    triangles: &[[Vec3; 3]],
    ray: &WatertightRay,
    first: usize,
    count: usize,
    t_min: f32,
    t_max: f32,
) -> Option<u32> {
    let (mut t, mut bary) = ([0f32; 8], [[0f32; 8]; 3]);
    for (block, valid) in windows(first, count, lanes.width()) {
        let hits = test_window::<true>(
            lanes, rows, triangles, ray, block, valid, t_min, t_max, &mut t, &mut bary,
        );
        if hits != 0 {
            let slot = 4 * block + hits.trailing_zeros() as usize;
            return Some((slot - first + 1) as u32);
        }
    }
    None
}

/// For the closest-hit traversal: calls `on_hit(slot, t, barycentrics)` for every slot of the
/// leaf the ray hits in (`t_min`, `t_max`], in slot order, with the scalar test's values;
/// `on_hit` returns the new `t_max` (a hit never makes it larger). Lanes are tested against the `t_max` at the start of their window, so
/// `on_hit` must re-check against its current `t_max`.
#[inline(always)]
#[allow(clippy::too_many_arguments)] // the scalar test's arguments plus the leaf's range
pub(crate) fn each_hit(
    lanes: LeafLanes,
    rows: &TriangleRows,
    triangles: &[[Vec3; 3]],
    ray: &WatertightRay,
    first: usize,
    count: usize,
    t_min: f32,
    mut t_max: f32,
    mut on_hit: impl FnMut(usize, f32, [f32; 3]) -> f32,
) {
    let (mut t, mut bary) = ([0f32; 8], [[0f32; 8]; 3]);
    for (block, valid) in windows(first, count, lanes.width()) {
        let mut hits = test_window::<false>(
            lanes, rows, triangles, ray, block, valid, t_min, t_max, &mut t, &mut bary,
        );
        while hits != 0 {
            let lane = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            let b = [bary[0][lane], bary[1][lane], bary[2][lane]];
            t_max = on_hit(4 * block + lane, t[lane], b);
        }
    }
}

/// For traversals with a hit filter: calls `stop(slot, t, barycentrics)` for every slot of the
/// leaf the ray hits in (`t_min`, `t_max`], in slot order, with the scalar test's values, until
/// it returns true. Returns the number of slots the scalar loop would have tested (up to and
/// including the stopping one) and whether one stopped.
#[inline(always)]
#[allow(clippy::too_many_arguments)] // the scalar test's arguments plus the leaf's range
pub(crate) fn hits_until(
    lanes: LeafLanes,
    rows: &TriangleRows,
    triangles: &[[Vec3; 3]],
    ray: &WatertightRay,
    first: usize,
    count: usize,
    t_min: f32,
    t_max: f32,
    mut stop: impl FnMut(usize, f32, [f32; 3]) -> bool,
) -> (u32, bool) {
    let (mut t, mut bary) = ([0f32; 8], [[0f32; 8]; 3]);
    for (block, valid) in windows(first, count, lanes.width()) {
        let mut hits = test_window::<false>(
            lanes, rows, triangles, ray, block, valid, t_min, t_max, &mut t, &mut bary,
        );
        while hits != 0 {
            let lane = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            let b = [bary[0][lane], bary[1][lane], bary[2][lane]];
            let slot = 4 * block + lane;
            if stop(slot, t[lane], b) {
                return ((slot - first + 1) as u32, true);
            }
        }
    }
    (count as u32, false)
}

#[cfg(target_arch = "x86_64")]
mod simd {
    use super::TriangleRows;
    use crate::geometry::WatertightRay;
    use std::arch::x86_64::*;

    /// The lane operations of the watertight test, written once for both vector widths.
    macro_rules! watertight_lanes {
        ($load:ident, $ray:expr, $any:expr, $t_min:expr, $t_max:expr, $t:expr, $bary:expr,
         $set1:ident, $sub:ident, $mul:ident, $add:ident, $div:ident, $and:ident, $andnot:ident,
         $xor:ident, $or:ident, $zero:ident, $eq:ident, $lt:ident, $gt:ident, $neq:ident,
         $le:ident, $store:ident, $movemask:ident) => {{
            let ray: &WatertightRay = $ray;
            // By reference: `to_array` copied the origin to the stack at every leaf.
            let o: &[f32; 3] = ray.origin.as_ref();
            let (kx, ky, kz) = (ray.kx, ray.ky, ray.kz);
            // SAFETY (the callers' unsafe blocks): `WatertightRay::new` is the only writer of
            // the axes (crate-private fields) and sets each to 0, 1 or 2. Said here because the
            // compiler does not prove it: a bounds check per row and origin component otherwise.
            std::hint::assert_unchecked(kx < 3 && ky < 3 && kz < 3);
            // Macros, not closures: a closure is a function of its own, compiled without the
            // caller's target features, so AVX intrinsics inside it would not inline.
            macro_rules! rel {
                ($v:expr, $axis:expr) => {
                    $sub($load!($axis, 3 * $v), $set1(o[$axis]))
                };
            }
            let (sx, sy, sz) = ($set1(ray.sx), $set1(ray.sy), $set1(ray.sz));
            // Per vertex: a[kx] - sx * a[kz], a[ky] - sy * a[kz], and a[kz] for the distance.
            macro_rules! project {
                ($v:expr) => {{
                    let (px, py, pz) = (rel!($v, kx), rel!($v, ky), rel!($v, kz));
                    ($sub(px, $mul(sx, pz)), $sub(py, $mul(sy, pz)), pz)
                }};
            }
            let (ax, ay, a_z) = project!(0);
            let (bx, by, b_z) = project!(1);
            let (cx, cy, c_z) = project!(2);
            let u = $sub($mul(cx, by), $mul(cy, bx));
            let v = $sub($mul(ax, cy), $mul(ay, cx));
            let w = $sub($mul(bx, ay), $mul(by, ax));
            let z = $zero();
            let zero = $or($or($eq!(u, z), $eq!(v, z)), $eq!(w, z));
            if $any {
                // Any hit: the hit mask alone, in fewer operations than the full form below.
                // Lanes with an edge 0 take the scalar test whatever the rest says.
                let zero = $movemask(zero) as u32;
                // Sign bits that differ: with no edge 0, the scalar test's "some edge < 0 and
                // some > 0", a miss (a NaN lane's `t` is NaN, also a miss either way).
                let mixed = $movemask($or($xor(u, v), $xor(u, w))) as u32;
                // The scalar test's `det` and `t`, the same operations per lane; its
                // `det == 0` is implied (edges of one sign, none 0, do not sum to 0).
                let det = $add($add(u, v), w);
                let t_scaled = $add(
                    $add($mul(u, $mul(sz, a_z)), $mul(v, $mul(sz, b_z))),
                    $mul(w, $mul(sz, c_z)),
                );
                let tt = $mul(t_scaled, $div($set1(1.0), det));
                $store($t.as_mut_ptr(), tt);
                let in_range = $and($gt!(tt, $set1($t_min)), $le!(tt, $set1($t_max)));
                ($movemask(in_range) as u32 & !mixed, zero)
            } else {
                // Closest hit: with barycentrics, and unchanged (the mask above made the
                // closest-hit loop's register allocation worse).
                let neg = $or($or($lt!(u, z), $lt!(v, z)), $lt!(w, z));
                let pos = $or($or($gt!(u, z), $gt!(v, z)), $gt!(w, z));
                let det = $add($add(u, v), w);
                let t_scaled = $add(
                    $add($mul(u, $mul(sz, a_z)), $mul(v, $mul(sz, b_z))),
                    $mul(w, $mul(sz, c_z)),
                );
                // The scalar test's `inv`, `t` and barycentrics, the same operations per lane.
                let inv = $div($set1(1.0), det);
                let tt = $mul(t_scaled, inv);
                let ok = $andnot(
                    $and(neg, pos),
                    $and(
                        $neq!(det, z),
                        $and($gt!(tt, $set1($t_min)), $le!(tt, $set1($t_max))),
                    ),
                );
                $store($t.as_mut_ptr(), tt);
                let bary: &mut [[f32; 8]; 3] = $bary;
                $store(bary[0].as_mut_ptr(), $mul(u, inv));
                $store(bary[1].as_mut_ptr(), $mul(v, inv));
                $store(bary[2].as_mut_ptr(), $mul(w, inv));
                ($movemask(ok) as u32, $movemask(zero) as u32)
            }
        }};
    }

    /// Four lanes: block `block`. Returns (hits, lanes with an edge function exactly 0). With
    /// `ANY` (the any-hit traversal) `bary` is not written.
    #[inline(always)]
    pub(super) fn four<const ANY: bool>(
        rows: &TriangleRows,
        ray: &WatertightRay,
        block: usize,
        t_min: f32,
        t_max: f32,
        t: &mut [f32; 8],
        bary: &mut [[f32; 8]; 3],
    ) -> (u32, u32) {
        let b = &rows.blocks[block];
        // SAFETY: SSE/SSE2 are part of the x86_64 baseline; each load reads one 16-byte row of
        // a block (bounds-checked above; row `axis + 3 * v` < 9 as every axis is < 3), the
        // store writes the first four of `t`'s eight.
        unsafe {
            // Row `axis + off`: the axis part a per-ray register, `off` (3 per vertex) a
            // constant displacement (indexing `rows[3 * v + axis]` made the compiler keep nine
            // per-ray row offsets and shift another at every load).
            macro_rules! load {
                ($axis:expr, $off:expr) => {
                    _mm_load_ps(b.rows.as_ptr().add($axis).add($off).cast::<f32>())
                };
            }
            macro_rules! cmp {
                ($name:ident, $f:ident) => {
                    macro_rules! $name {
                        ($a:expr, $b:expr) => {
                            $f($a, $b)
                        };
                    }
                };
            }
            cmp!(eq, _mm_cmpeq_ps);
            cmp!(lt, _mm_cmplt_ps);
            cmp!(gt, _mm_cmpgt_ps);
            cmp!(neq, _mm_cmpneq_ps);
            cmp!(le, _mm_cmple_ps);
            watertight_lanes!(
                load,
                ray,
                ANY,
                t_min,
                t_max,
                t,
                bary,
                _mm_set1_ps,
                _mm_sub_ps,
                _mm_mul_ps,
                _mm_add_ps,
                _mm_div_ps,
                _mm_and_ps,
                _mm_andnot_ps,
                _mm_xor_ps,
                _mm_or_ps,
                _mm_setzero_ps,
                eq,
                lt,
                gt,
                neq,
                le,
                _mm_storeu_ps,
                _mm_movemask_ps
            )
        }
    }

    /// Eight lanes: blocks `block` and `block + 1`. Only for callers compiled with AVX2 (the
    /// wide traversal's AVX2 instantiation), like the AVX2 box kernel. Returns as [`four`].
    #[inline(always)]
    pub(super) fn eight<const ANY: bool>(
        rows: &TriangleRows,
        ray: &WatertightRay,
        block: usize,
        t_min: f32,
        t_max: f32,
        t: &mut [f32; 8],
        bary: &mut [[f32; 8]; 3],
    ) -> (u32, u32) {
        let (lo, hi) = (&rows.blocks[block], &rows.blocks[block + 1]);
        // SAFETY: only instantiated inside functions compiled with `target_feature(enable =
        // "avx2")` and called after `is_x86_feature_detected!("avx2")`; each load reads one
        // 16-byte row of two blocks (bounds-checked above; row `axis + 3 * v` < 9 as every
        // axis is < 3), the store writes all of `t`.
        unsafe {
            macro_rules! load {
                ($axis:expr, $off:expr) => {
                    _mm256_set_m128(
                        _mm_load_ps(hi.rows.as_ptr().add($axis).add($off).cast::<f32>()),
                        _mm_load_ps(lo.rows.as_ptr().add($axis).add($off).cast::<f32>()),
                    )
                };
            }
            macro_rules! cmp {
                ($name:ident, $p:ident) => {
                    macro_rules! $name {
                        ($a:expr, $b:expr) => {
                            _mm256_cmp_ps::<$p>($a, $b)
                        };
                    }
                };
            }
            cmp!(eq, _CMP_EQ_OQ);
            cmp!(lt, _CMP_LT_OQ);
            cmp!(gt, _CMP_GT_OQ);
            cmp!(neq, _CMP_NEQ_UQ);
            cmp!(le, _CMP_LE_OQ);
            watertight_lanes!(
                load,
                ray,
                ANY,
                t_min,
                t_max,
                t,
                bary,
                _mm256_set1_ps,
                _mm256_sub_ps,
                _mm256_mul_ps,
                _mm256_add_ps,
                _mm256_div_ps,
                _mm256_and_ps,
                _mm256_andnot_ps,
                _mm256_xor_ps,
                _mm256_or_ps,
                _mm256_setzero_ps,
                eq,
                lt,
                gt,
                neq,
                le,
                _mm256_storeu_ps,
                _mm256_movemask_ps
            )
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::geometry::Ray;
    use crate::sampling::hash_combine;

    /// The scalar test's answer per triangle on (0, 1.5]: distance and barycentrics as bits.
    fn scalar_answers(wt: &WatertightRay, tris: &[[Vec3; 3]]) -> Vec<Option<[u32; 4]>> {
        tris.iter()
            .map(|t| {
                intersect_triangle(wt, t, 0.0, 1.5)
                    .map(|h| [h.t, h.b0, h.b1, h.b2].map(f32::to_bits))
            })
            .collect()
    }

    /// The leaf tests compiled with AVX2, as the wide traversal's AVX2 instantiation is.
    #[target_feature(enable = "avx2")]
    unsafe fn each_hit_with(
        lanes: LeafLanes,
        rows: &TriangleRows,
        tris: &[[Vec3; 3]],
        ray: &WatertightRay,
        first: usize,
        count: usize,
        seen: &mut Vec<(usize, [u32; 4])>,
    ) {
        each_hit(
            lanes,
            rows,
            tris,
            ray,
            first,
            count,
            0.0,
            1.5,
            |slot, t, b| {
                seen.push((slot, [t, b[0], b[1], b[2]].map(f32::to_bits)));
                1.5
            },
        );
    }

    #[target_feature(enable = "avx2")]
    unsafe fn first_hit_with(
        lanes: LeafLanes,
        rows: &TriangleRows,
        tris: &[[Vec3; 3]],
        ray: &WatertightRay,
        first: usize,
        count: usize,
    ) -> Option<u32> {
        first_hit(lanes, rows, tris, ray, first, count, 0.0, 1.5)
    }

    /// One kind of triangle at every slot of an eleven-slot leaf among triangles the lane test
    /// must reject by other means (edge signs differ, behind the origin, past the segment,
    /// degenerate, NaN): both leaf tests equal the scalar test, for rays along every axis and
    /// both directions. The kinds include a strict hit of either winding, hits and misses
    /// decided by the scalar fallback (the ray through an edge or a vertex, a degenerate
    /// triangle on the ray's line, a triangle in a plane holding the ray) and edge functions
    /// that overflow.
    #[test]
    fn lane_masks_equal_the_scalar_test_per_kind() {
        let v = Vec3::new;
        let at = |z: f32| [v(0.0, 0.0, z), v(1.0, 0.0, z), v(0.0, 1.0, z)];
        let fillers = [
            [v(2.0, 2.0, 0.0), v(3.0, 2.0, 0.0), v(2.0, 3.0, 0.0)],
            at(2.0),
            at(-3.0),
            [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(2.0, 0.0, 0.0)],
            [v(f32::NAN, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)],
        ];
        let kinds = [
            at(0.0),
            [v(0.0, 0.0, 0.0), v(0.0, 1.0, 0.0), v(1.0, 0.0, 0.0)],
            [v(0.25, 0.0, 0.0), v(0.25, 1.0, 0.0), v(-1.0, 0.5, 0.0)],
            [v(0.25, 0.0, 0.0), v(-1.0, 0.5, 0.0), v(0.25, 1.0, 0.0)],
            [v(0.25, 0.25, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)],
            [v(0.0, 0.0, 0.0), v(1.0, 1.0, 0.0), v(2.0, 2.0, 0.0)],
            [v(0.25, 0.0, 1.0), v(0.25, 0.0, -1.0), v(0.25, 1.0, 0.0)],
            [v(-3e19, -3e19, 0.0), v(3e19, -3e19, 0.0), v(0.0, 3e19, 0.0)],
            fillers[0],
        ];
        let mut kernels = vec![LeafLanes::Four];
        if std::arch::is_x86_feature_detected!("avx2") {
            kernels.push(LeafLanes::Eight);
        }
        let mut hits_at = [0usize; 11];
        let mut fallback_hits = 0;
        // Axis permutations and a flip of the ray: every dominant axis, both windings.
        for perm in 0..3 {
            for flip in [false, true] {
                let map = |p: Vec3| {
                    let a = p.to_array();
                    let (z, p) = if flip { (1.0 - a[2], a) } else { (a[2], a) };
                    let mut out = [0.0; 3];
                    out[perm] = p[0];
                    out[(perm + 1) % 3] = p[1];
                    out[(perm + 2) % 3] = z;
                    Vec3::from_array(out)
                };
                let (o, d) = (map(v(0.25, 0.25, 1.0)), map(v(0.25, 0.25, -1.0)));
                let ray = Ray::new(o, d - o, 0.0, 1.5);
                let wt = WatertightRay::new(&ray);
                for (k, kind) in kinds.iter().enumerate() {
                    for (pos, hits) in hits_at.iter_mut().enumerate() {
                        let tris: Vec<[Vec3; 3]> = (0..11)
                            .map(|s| {
                                if s == pos {
                                    *kind
                                } else {
                                    fillers[s % fillers.len()]
                                }
                            })
                            .map(|t| t.map(map))
                            .collect();
                        let rows = TriangleRows::new(&tris);
                        let scalar = scalar_answers(&wt, &tris);
                        // Only the kind's slot can hit: the fillers never do.
                        let expected: Vec<(usize, [u32; 4])> =
                            (0..11).filter_map(|s| scalar[s].map(|h| (s, h))).collect();
                        assert!(expected.iter().all(|&(s, _)| s == pos));
                        if !expected.is_empty() {
                            *hits += 1;
                            fallback_hits += usize::from((2..7).contains(&k));
                        }
                        for first in 0..11 {
                            for &lanes in &kernels {
                                let mut seen = Vec::new();
                                let count = 11 - first;
                                // SAFETY: Eight is only in the list when AVX2 was detected.
                                unsafe {
                                    each_hit_with(lanes, &rows, &tris, &wt, first, count, &mut seen)
                                };
                                let want: Vec<_> = expected
                                    .iter()
                                    .filter(|&&(s, _)| s >= first)
                                    .copied()
                                    .collect();
                                assert_eq!(seen, want, "{lanes:?} kind {k} at {pos} from {first}");
                                // SAFETY: as above.
                                let got = unsafe {
                                    first_hit_with(lanes, &rows, &tris, &wt, first, count)
                                };
                                let want = want.first().map(|&(s, _)| (s - first + 1) as u32);
                                assert_eq!(got, want, "{lanes:?} kind {k} at {pos} from {first}");
                            }
                        }
                    }
                }
            }
        }
        // The strict hits hit in every slot, and some fallback lanes hit.
        assert!(hits_at.iter().all(|&n| n >= 12), "{hits_at:?}");
        assert!(fallback_hits > 0);
    }

    fn unit(h: u32) -> f32 {
        (h >> 8) as f32 / (1u32 << 24) as f32
    }

    /// Every lane of both SIMD widths equals the scalar test (hit, distance and barycentrics,
    /// bit for bit) on a fan of triangles sharing edges and vertices, for rays through their
    /// vertices, edge midpoints and random points, for every leaf range (any start, any
    /// length, across blocks).
    #[test]
    fn simd_lanes_equal_the_scalar_test() {
        let c = Vec3::new(0.1, 0.2, 0.3);
        // Eleven triangles: leaf ranges span up to three blocks.
        let ring: Vec<Vec3> = (0..12)
            .map(|k| {
                let a = k as f32 * 0.55;
                Vec3::new(a.cos(), a.sin(), 0.25 * (k % 3) as f32)
            })
            .collect();
        let tris: Vec<[Vec3; 3]> = (0..11).map(|k| [c, ring[k], ring[k + 1]]).collect();
        let rows = TriangleRows::new(&tris);
        let mut targets: Vec<Vec3> = ring.clone();
        targets.push(c);
        targets.extend(ring.iter().map(|&v| (v + c) * 0.5));
        targets.extend(ring.windows(2).map(|w| (w[0] + w[1]) * 0.5));
        for k in 0..200u32 {
            let h = hash_combine(7, k);
            let (x, y) = (unit(hash_combine(h, 1)), unit(hash_combine(h, 2)));
            targets.push(Vec3::new(2.0 * x - 1.0, 2.0 * y - 1.0, 0.2));
        }
        let origins = [
            Vec3::new(0.0, 0.0, 2.0),
            Vec3::new(0.3, -0.4, -1.5),
            Vec3::new(3.0, 0.1, 0.2),
        ];
        let mut kernels = vec![LeafLanes::Four];
        if std::arch::is_x86_feature_detected!("avx2") {
            kernels.push(LeafLanes::Eight);
        }
        let (mut hits, mut cases) = (0, 0);
        for &o in &origins {
            for &p in &targets {
                let ray = Ray::new(o, p - o, 0.0, 1.5);
                let wt = WatertightRay::new(&ray);
                let scalar = scalar_answers(&wt, &tris);
                for first in 0..tris.len() {
                    for count in 1..=tris.len() - first {
                        let range = first..first + count;
                        for &lanes in &kernels {
                            let mut seen = Vec::new();
                            // SAFETY: Eight is only in the list when AVX2 was detected.
                            unsafe {
                                each_hit_with(lanes, &rows, &tris, &wt, first, count, &mut seen)
                            };
                            let expected: Vec<(usize, [u32; 4])> = range
                                .clone()
                                .filter_map(|s| scalar[s].map(|h| (s, h)))
                                .collect();
                            assert_eq!(seen, expected, "{lanes:?} {o} {p} {first}+{count}");
                            let first_scalar = range.clone().position(|s| scalar[s].is_some());
                            // SAFETY: as above.
                            let got =
                                unsafe { first_hit_with(lanes, &rows, &tris, &wt, first, count) };
                            assert_eq!(got, first_scalar.map(|i| i as u32 + 1));
                        }
                        hits += scalar[range.clone()].iter().flatten().count();
                        cases += count;
                    }
                }
            }
        }
        assert!(hits > cases / 20, "{hits} hits of {cases}");
    }
}
