//! Leaf triangles four at a time (SSE, x86_64): the watertight test of
//! [`intersect_triangle`] with the same f32 operations in the same order in every lane, so each
//! lane's answer is the scalar test's bit for bit. A lane with an edge function exactly 0 (where
//! the scalar test recomputes in f64) is handed to the scalar test. Triangles are read from
//! [`TriangleRows`], nine rows of floats (vertex x axis) indexed by triangle slot, so any four
//! consecutive slots are four unaligned loads per row, whatever leaf they start.

use crate::geometry::{intersect_triangle, WatertightRay};
use glam::Vec3;

/// The triangles of a tree as rows: `rows[3 * v + axis][slot]`, padded with 3 zeros so that a
/// four-lane load at any slot stays inside.
#[derive(Clone, Debug, Default)]
pub struct TriangleRows {
    rows: [Vec<f32>; 9],
}

impl TriangleRows {
    pub fn new(triangles: &[[Vec3; 3]]) -> Self {
        let rows = std::array::from_fn(|r| {
            let (v, axis) = (r / 3, r % 3);
            let mut row: Vec<f32> = triangles.iter().map(|t| t[v][axis]).collect();
            row.extend([0.0; 3]);
            row
        });
        TriangleRows { rows }
    }

    pub fn bytes(&self) -> usize {
        self.rows.iter().map(|r| r.len() * 4).sum()
    }
}

/// Slots `first..first + count` (count in 1..=4) against the ray for t in (`t_min`, `t_max`]:
/// bit i of the result is set when slot `first + i` is hit, and `t[i]` is its distance.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(clippy::too_many_arguments)] // the scalar test's arguments plus the leaf's range
pub(crate) fn test4(
    rows: &TriangleRows,
    triangles: &[[Vec3; 3]],
    ray: &WatertightRay,
    first: usize,
    count: usize,
    t_min: f32,
    t_max: f32,
    t: &mut [f32; 4],
) -> u32 {
    use std::arch::x86_64::*;
    debug_assert!((1..=4).contains(&count));
    let valid = (1u32 << count) - 1;
    let r = &rows.rows;
    assert!(first + 4 <= r[0].len(), "leaf outside the triangle rows");
    let o = ray.origin.to_array();
    let (kx, ky, kz) = (ray.kx, ray.ky, ray.kz);
    // SAFETY: SSE/SSE2 are part of the x86_64 baseline; every row has the same length, checked
    // above to hold lanes `first..first + 4`.
    let (hits, zero) = unsafe {
        let load = |row: usize| _mm_loadu_ps(r[row].as_ptr().add(first));
        let rel = |v: usize, axis: usize| _mm_sub_ps(load(3 * v + axis), _mm_set1_ps(o[axis]));
        let (sx, sy, sz) = (
            _mm_set1_ps(ray.sx),
            _mm_set1_ps(ray.sy),
            _mm_set1_ps(ray.sz),
        );
        // Per vertex: a[kx] - sx * a[kz], a[ky] - sy * a[kz], and a[kz] for the distance.
        let project = |v: usize| {
            let (px, py, pz) = (rel(v, kx), rel(v, ky), rel(v, kz));
            (
                _mm_sub_ps(px, _mm_mul_ps(sx, pz)),
                _mm_sub_ps(py, _mm_mul_ps(sy, pz)),
                pz,
            )
        };
        let (ax, ay, a_z) = project(0);
        let (bx, by, b_z) = project(1);
        let (cx, cy, c_z) = project(2);
        let u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
        let v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
        let w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
        let z = _mm_setzero_ps();
        let zero = _mm_or_ps(
            _mm_or_ps(_mm_cmpeq_ps(u, z), _mm_cmpeq_ps(v, z)),
            _mm_cmpeq_ps(w, z),
        );
        let neg = _mm_or_ps(
            _mm_or_ps(_mm_cmplt_ps(u, z), _mm_cmplt_ps(v, z)),
            _mm_cmplt_ps(w, z),
        );
        let pos = _mm_or_ps(
            _mm_or_ps(_mm_cmpgt_ps(u, z), _mm_cmpgt_ps(v, z)),
            _mm_cmpgt_ps(w, z),
        );
        let det = _mm_add_ps(_mm_add_ps(u, v), w);
        let t_scaled = _mm_add_ps(
            _mm_add_ps(
                _mm_mul_ps(u, _mm_mul_ps(sz, a_z)),
                _mm_mul_ps(v, _mm_mul_ps(sz, b_z)),
            ),
            _mm_mul_ps(w, _mm_mul_ps(sz, c_z)),
        );
        let tt = _mm_mul_ps(t_scaled, _mm_div_ps(_mm_set1_ps(1.0), det));
        let ok = _mm_andnot_ps(
            _mm_and_ps(neg, pos),
            _mm_and_ps(
                _mm_cmpneq_ps(det, z),
                _mm_and_ps(
                    _mm_cmpgt_ps(tt, _mm_set1_ps(t_min)),
                    _mm_cmple_ps(tt, _mm_set1_ps(t_max)),
                ),
            ),
        );
        _mm_storeu_ps(t.as_mut_ptr(), tt);
        (
            _mm_movemask_ps(ok) as u32,
            _mm_movemask_ps(zero) as u32 & valid,
        )
    };
    let mut hits = hits & valid & !zero;
    let mut fallback = zero;
    while fallback != 0 {
        let i = fallback.trailing_zeros() as usize;
        fallback &= fallback - 1;
        if let Some(h) = intersect_triangle(ray, &triangles[first + i], t_min, t_max) {
            t[i] = h.t;
            hits |= 1 << i;
        }
    }
    hits
}

/// Portable stand-in (no SIMD kernel selects it off x86_64): the scalar test per slot.
#[cfg(not(target_arch = "x86_64"))]
#[allow(clippy::too_many_arguments)] // the scalar test's arguments plus the leaf's range
pub(crate) fn test4(
    _rows: &TriangleRows,
    triangles: &[[Vec3; 3]],
    ray: &WatertightRay,
    first: usize,
    count: usize,
    t_min: f32,
    t_max: f32,
    t: &mut [f32; 4],
) -> u32 {
    let mut hits = 0;
    for (i, tri) in triangles[first..first + count].iter().enumerate() {
        if let Some(h) = intersect_triangle(ray, tri, t_min, t_max) {
            t[i] = h.t;
            hits |= 1 << i;
        }
    }
    hits
}

/// For the any-hit traversal: how many of the leaf's triangles the scalar loop would test
/// before and including the first hit, or `None` when none is hit.
#[inline(always)]
pub(crate) fn first_hit(
    rows: &TriangleRows,
    triangles: &[[Vec3; 3]],
    ray: &WatertightRay,
    first: usize,
    count: usize,
    t_min: f32,
    t_max: f32,
) -> Option<u32> {
    let mut t = [0f32; 4];
    let mut base = 0;
    while base < count {
        let n = (count - base).min(4);
        let hits = test4(rows, triangles, ray, first + base, n, t_min, t_max, &mut t);
        if hits != 0 {
            return Some((base + hits.trailing_zeros() as usize + 1) as u32);
        }
        base += 4;
    }
    None
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::geometry::Ray;
    use crate::sampling::hash_combine;

    fn unit(h: u32) -> f32 {
        (h >> 8) as f32 / (1u32 << 24) as f32
    }

    /// Every lane equals the scalar test (hit and distance) on a fan of triangles sharing edges
    /// and vertices, for rays through their vertices, edge midpoints and random points.
    #[test]
    fn four_lanes_equal_the_scalar_test() {
        let c = Vec3::new(0.1, 0.2, 0.3);
        let ring: Vec<Vec3> = (0..7)
            .map(|k| {
                let a = k as f32 * 0.9;
                Vec3::new(a.cos(), a.sin(), 0.25 * (k % 3) as f32)
            })
            .collect();
        let tris: Vec<[Vec3; 3]> = (0..6).map(|k| [c, ring[k], ring[k + 1]]).collect();
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
        let (mut hits, mut cases) = (0, 0);
        for &o in &origins {
            for &p in &targets {
                let ray = Ray::new(o, p - o, 0.0, 1.5);
                let wt = WatertightRay::new(&ray);
                for first in 0..tris.len() {
                    let count = (tris.len() - first).min(4);
                    let mut t = [0f32; 4];
                    let mask = test4(&rows, &tris, &wt, first, count, 0.0, 1.5, &mut t);
                    for lane in 0..count {
                        let scalar = intersect_triangle(&wt, &tris[first + lane], 0.0, 1.5);
                        assert_eq!(mask & (1 << lane) != 0, scalar.is_some(), "{o} {p} {first}");
                        if let Some(s) = scalar {
                            assert_eq!(t[lane].to_bits(), s.t.to_bits());
                            hits += 1;
                        }
                        cases += 1;
                    }
                    assert_eq!(mask >> count, 0, "lanes past the leaf never hit");
                }
            }
        }
        assert!(hits > cases / 10, "{hits} hits of {cases}");
    }
}
