//! Seeded, stratified sample patterns. Every pixel's pattern is a pure function of the seed,
//! the pixel and the light, so renders are reproducible and independent of thread scheduling.

/// A small, fast hash (PCG-style permutation, "hash_pcg" of Jarzynski & Olano 2020).
#[inline]
pub fn hash_u32(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

#[inline]
pub fn hash_combine(a: u32, b: u32) -> u32 {
    hash_u32(a ^ hash_u32(b).wrapping_add(0x9e37_79b9))
}

/// A uniform float in [0, 1) from a hash.
#[inline]
pub fn unit_float(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// `n` stratified points in [0, 1)^2: the smallest grid of at least `n` cells, cells visited
/// in a seeded random order, one jittered point per cell.
pub fn stratified_2d(n: u32, seed: u32, out: &mut Vec<[f32; 2]>) {
    out.clear();
    extend_stratified_2d(n, seed, out);
}

/// [`stratified_2d`]'s points appended to `out`.
#[inline]
pub fn extend_stratified_2d(n: u32, seed: u32, out: &mut Vec<[f32; 2]>) {
    let side = (n as f32).sqrt().ceil().max(1.0) as u32;
    let cells = side * side;
    // A seeded bijection on 0..cells visits distinct strata for the first n samples: cell i is
    // (offset + i * stride) mod cells, stepped without a division (stride < cells).
    let mut cell = if cells.is_power_of_two() {
        hash_u32(seed) & (cells - 1)
    } else {
        hash_u32(seed) % cells
    };
    let stride = coprime_stride(cells, hash_u32(seed ^ 0x5bd1_e995));
    // A power-of-two side (4, 16, 64... samples) splits a cell by a shift and scales by an exact
    // reciprocal: the same values as the division, without one.
    let shift = side.trailing_zeros();
    let pow2 = side.is_power_of_two();
    let inv_side = 1.0 / side as f32;
    out.reserve(n as usize);
    for i in 0..n {
        let (cx, cy) = if pow2 {
            (cell & (side - 1), cell >> shift)
        } else {
            (cell % side, cell / side)
        };
        let h = hash_combine(seed, i);
        let (x, y) = (
            cx as f32 + unit_float(h),
            cy as f32 + unit_float(hash_u32(h)),
        );
        let (x, y) = if pow2 {
            (x * inv_side, y * inv_side)
        } else {
            (x / side as f32, y / side as f32)
        };
        out.push([x.min(1.0 - f32::EPSILON), y.min(1.0 - f32::EPSILON)]);
        cell += stride;
        if cell >= cells {
            cell -= cells;
        }
    }
}

fn coprime_stride(n: u32, h: u32) -> u32 {
    if n <= 1 {
        return 1;
    }
    // Coprime to a power of two (the grid of 4, 16, 64... samples) means odd: no gcd's divisions.
    let coprime = |s: u32| {
        if n.is_power_of_two() {
            s & 1 == 1
        } else {
            gcd(s, n) == 1
        }
    };
    let mut s = 1 + h % (n - 1);
    while !coprime(s) {
        // s % (n - 1) + 1 for s in 1..n
        s = if s == n - 1 { 1 } else { s + 1 };
    }
    s
}

fn gcd(mut a: u32, mut b: u32) -> u32 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Maps [0,1)^2 to the unit disk, preserving strata (Shirley & Chiu's concentric map).
///
/// The angle is pi/4 times a ratio in [-1, 1] (measured from the nearer axis), so its sine and
/// cosine come from short series with no range reduction ([`sin_cos_octant`]) instead of a libm
/// `sincosf` call per sample: the values are within an ulp of the libm form and the same on
/// every platform (docs/sampling.md).
#[inline]
pub fn concentric_disk(u: [f32; 2]) -> [f32; 2] {
    let a = 2.0 * u[0] - 1.0;
    let b = 2.0 * u[1] - 1.0;
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    // phi = pi/4 * b/a from the x axis, or pi/2 - pi/4 * a/b from the y axis (cos and sin
    // trade places): chosen by selects, as the side is a coin toss a branch would mispredict.
    let x_side = a.abs() > b.abs();
    let (num, den) = if x_side { (b, a) } else { (a, b) };
    let (sin, cos) = sin_cos_octant(std::f32::consts::FRAC_PI_4 * (num / den));
    let (x, y) = if x_side { (cos, sin) } else { (sin, cos) };
    [den * x, den * y]
}

/// `(sin x, cos x)` for |x| <= pi/4: Taylor series evaluated in f64 (truncation below 2^-33
/// relative) and rounded once to f32, so nearly always the correctly rounded values.
#[inline]
pub fn sin_cos_octant(x: f32) -> (f32, f32) {
    let x = x as f64;
    let x2 = x * x;
    let sin = x
        * (1.0
            + x2 * (-1.0 / 6.0
                + x2 * (1.0 / 120.0
                    + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0 - x2 / 39_916_800.0)))));
    let cos = 1.0
        + x2 * (-0.5
            + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0 - x2 / 3_628_800.0))));
    (sin as f32, cos as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strata_are_distinct_and_in_range() {
        let mut v = Vec::new();
        for n in [1u32, 4, 9, 16, 7, 64] {
            stratified_2d(n, 42, &mut v);
            let side = (n as f32).sqrt().ceil() as u32;
            let mut cells: Vec<u32> = v
                .iter()
                .map(|p| {
                    assert!(p[0] >= 0.0 && p[0] < 1.0 && p[1] >= 0.0 && p[1] < 1.0);
                    (p[0] * side as f32) as u32 + side * (p[1] * side as f32) as u32
                })
                .collect();
            cells.sort();
            cells.dedup();
            assert_eq!(cells.len(), n as usize);
        }
    }

    /// The stepped cells are the closed form's `(offset + i * stride) mod cells`.
    #[test]
    fn strata_follow_the_closed_form() {
        let mut v = Vec::new();
        for (n, seed) in [
            (2u32, 7u32),
            (4, 0),
            (9, 3),
            (10, 99),
            (16, 8),
            (4096, 5),
            (1, 1),
        ] {
            stratified_2d(n, seed, &mut v);
            let side = (n as f32).sqrt().ceil().max(1.0) as u32;
            let cells = side * side;
            let offset = hash_u32(seed) % cells;
            let stride = coprime_stride(cells, hash_u32(seed ^ 0x5bd1_e995));
            for (i, p) in v.iter().enumerate() {
                let cell = ((offset as u64 + i as u64 * stride as u64) % cells as u64) as u32;
                let h = hash_combine(seed, i as u32);
                let x = ((cell % side) as f32 + unit_float(h)) / side as f32;
                let y = ((cell / side) as f32 + unit_float(hash_u32(h))) / side as f32;
                assert_eq!(p[0], x.min(1.0 - f32::EPSILON));
                assert_eq!(p[1], y.min(1.0 - f32::EPSILON));
            }
        }
    }

    /// Ulps between two floats of the same sign.
    fn ulps(a: f32, b: f32) -> u32 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs() as u32
    }

    #[test]
    fn octant_series_is_within_an_ulp_of_libm() {
        let n = 200_000;
        let mut exact = 0;
        for i in 0..=n {
            let x = std::f32::consts::FRAC_PI_4 * (2.0 * i as f32 / n as f32 - 1.0);
            let (s, c) = sin_cos_octant(x);
            let (rs, rc) = ((x as f64).sin() as f32, (x as f64).cos() as f32);
            assert!(
                ulps(s, rs) <= 1 && ulps(c, rc) <= 1,
                "{x}: {s} {rs} {c} {rc}"
            );
            exact += u32::from(s == rs && c == rc);
        }
        assert!(
            exact as f64 > 0.999 * n as f64,
            "correctly rounded: {exact} of {n}"
        );
    }

    #[test]
    fn disk_map_is_the_trigonometric_one() {
        use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};
        for i in 0..20_000u32 {
            let u = [
                unit_float(hash_u32(i)),
                unit_float(hash_u32(i ^ 0xdead_beef)),
            ];
            let (a, b) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
            let (r, phi) = if a.abs() > b.abs() {
                (a as f64, (FRAC_PI_4 * (b / a)) as f64)
            } else {
                (b as f64, FRAC_PI_2 as f64 - (FRAC_PI_4 * (a / b)) as f64)
            };
            let d = concentric_disk(u);
            for (got, want) in [(d[0], r * phi.cos()), (d[1], r * phi.sin())] {
                assert!(
                    (got as f64 - want).abs() <= 2.5e-7 * r.abs(),
                    "{u:?}: {got} {want}"
                );
            }
        }
    }

    #[test]
    fn strides_are_the_first_coprime_from_the_hash() {
        for n in 2..300u32 {
            for h in [0u32, 1, 2, 7, 1000, 0xffff_ffff] {
                let mut s = 1 + h % (n - 1);
                while gcd(s, n) != 1 {
                    s = s % (n - 1) + 1;
                }
                assert_eq!(coprime_stride(n, h), s, "n {n} h {h}");
            }
        }
    }

    #[test]
    fn disk_points_inside() {
        for i in 0..100 {
            let u = [unit_float(hash_u32(i)), unit_float(hash_u32(i + 1000))];
            let d = concentric_disk(u);
            assert!(d[0] * d[0] + d[1] * d[1] <= 1.0 + 1e-6);
        }
    }
}
