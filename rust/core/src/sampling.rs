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
    hash_u32(a ^ combine_key(b))
}

/// A uniform float in [0, 1) from a hash.
#[inline]
pub fn unit_float(h: u32) -> f32 {
    // Below 2^24: converted as a signed integer, which SIMD lanes have.
    ((h >> 8) as i32) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// `n` stratified points in [0, 1)^2: the smallest grid of at least `n` cells, cells visited
/// in a seeded random order, one jittered point per cell.
pub fn stratified_2d(n: u32, seed: u32, out: &mut Vec<[f32; 2]>) {
    out.clear();
    extend_stratified_2d(n, seed, out);
}

/// What [`hash_combine`]`(a, b)` mixes into `a`: a pattern's keys of its sample indices are
/// then made once for every pixel.
#[inline]
pub fn combine_key(b: u32) -> u32 {
    hash_u32(b).wrapping_add(0x9e37_79b9)
}

/// The grid of strata of an `n`-point pattern ([`stratified_2d`]): the smallest square of at
/// least `n` cells.
#[derive(Clone, Copy, Debug)]
pub struct Strata {
    pub side: u32,
    pub cells: u32,
    /// A power-of-two side (4, 16, 64... samples) splits a cell by a shift and scales by an
    /// exact reciprocal: the same values as the division, without one.
    pub pow2: bool,
    pub shift: u32,
    pub inv_side: f32,
    /// `u64::MAX / (cells - 1) + 1`: the remainder by `cells - 1` without a division
    /// ([`fast_rem`]).
    rem_magic: u64,
}

/// `h % d` by two multiplications, exact for every `h` and every `d >= 1` given `magic =
/// u64::MAX / d + 1` (wrapping; Lemire, Kaser & Kurz, "Faster remainder by direct computation",
/// 2019): a tile's strides divide by the same `d` for every pixel.
#[inline(always)]
pub fn fast_rem(h: u32, magic: u64, d: u32) -> u32 {
    ((magic.wrapping_mul(h as u64) as u128 * d as u128) >> 64) as u32
}

/// [`fast_rem`]'s `magic` for `d >= 1`.
pub fn rem_magic(d: u32) -> u64 {
    (u64::MAX / d as u64).wrapping_add(1)
}

impl Strata {
    pub fn new(n: u32) -> Self {
        let side = (n as f32).sqrt().ceil().max(1.0) as u32;
        Strata {
            side,
            cells: side * side,
            pow2: side.is_power_of_two(),
            shift: side.trailing_zeros(),
            inv_side: 1.0 / side as f32,
            rem_magic: rem_magic((side * side).max(2) - 1),
        }
    }

    /// A pattern's first cell and its step for `seed`: cell i is (first + i * stride) mod
    /// cells, a seeded bijection on 0..cells that visits distinct strata.
    #[inline]
    pub fn walk(&self, seed: u32) -> (u32, u32) {
        let first = if self.cells.is_power_of_two() {
            hash_u32(seed) & (self.cells - 1)
        } else {
            hash_u32(seed) % self.cells
        };
        let h = hash_u32(seed ^ 0x5bd1_e995);
        let stride = if self.cells.is_power_of_two() && self.cells > 1 {
            // [`coprime_stride`] for a power of two: the first odd number from 1 + h % (n - 1)
            // (n - 1 is odd, so no wrap), the remainder without a division.
            (1 + fast_rem(h, self.rem_magic, self.cells - 1)) | 1
        } else {
            coprime_stride(self.cells, h)
        };
        (first, stride)
    }

    /// The point of `cell` jittered by the hash `h`, clamped below 1.
    #[inline(always)]
    pub fn point(&self, cell: u32, h: u32) -> [f32; 2] {
        if self.pow2 {
            return self.point_pow2(cell, h);
        }
        let (cx, cy) = (cell % self.side, cell / self.side);
        let x = (cx as f32 + unit_float(h)) / self.side as f32;
        let y = (cy as f32 + unit_float(hash_u32(h))) / self.side as f32;
        [x.min(1.0 - f32::EPSILON), y.min(1.0 - f32::EPSILON)]
    }

    /// [`Self::point`] on a grid of a power-of-two side: no division, and every operation one
    /// a SIMD lane has (the cell's coordinates, below 2^31, convert as signed integers).
    #[inline(always)]
    pub fn point_pow2(&self, cell: u32, h: u32) -> [f32; 2] {
        let (cx, cy) = ((cell & (self.side - 1)) as i32, (cell >> self.shift) as i32);
        let x = (cx as f32 + unit_float(h)) * self.inv_side;
        let y = (cy as f32 + unit_float(hash_u32(h))) * self.inv_side;
        [x.min(1.0 - f32::EPSILON), y.min(1.0 - f32::EPSILON)]
    }
}

/// [`stratified_2d`]'s points appended to `out`.
#[inline]
pub fn extend_stratified_2d(n: u32, seed: u32, out: &mut Vec<[f32; 2]>) {
    let strata = Strata::new(n);
    // Cells are stepped without a division (stride < cells).
    let (mut cell, stride) = strata.walk(seed);
    out.reserve(n as usize);
    for i in 0..n {
        out.push(strata.point(cell, hash_u32(seed ^ combine_key(i))));
        cell += stride;
        if cell >= strata.cells {
            cell -= strata.cells;
        }
    }
}

pub fn coprime_stride(n: u32, h: u32) -> u32 {
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
    // phi = pi/4 * b/a from the x axis, or pi/2 - pi/4 * a/b from the y axis (cos and sin
    // trade places): chosen by selects, as the side is a coin toss a branch would mispredict.
    let x_side = a.abs() > b.abs();
    let (num, den) = if x_side { (b, a) } else { (a, b) };
    let (sin, cos) = sin_cos_octant(std::f32::consts::FRAC_PI_4 * (num / den));
    let (x, y) = if x_side { (cos, sin) } else { (sin, cos) };
    // The centre maps to itself (its ratio was 0/0): a select, not an early return, so the
    // map vectorises over a tile's samples (render/sample_lanes.rs).
    if a == 0.0 && b == 0.0 {
        [0.0, 0.0]
    } else {
        [den * x, den * y]
    }
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
    fn fast_remainders_are_remainders() {
        let mut hashes: Vec<u32> = (0..2000).map(hash_u32).collect();
        hashes.extend([0, 1, 2, u32::MAX, u32::MAX - 1, 1 << 31]);
        for d in (1..5000u32).chain([u32::MAX, u32::MAX - 1, 1 << 31, 65_535]) {
            let magic = rem_magic(d);
            for &h in hashes
                .iter()
                .chain([d, d.wrapping_sub(1), d.wrapping_add(1)].iter())
            {
                assert_eq!(fast_rem(h, magic, d), h % d, "{h} % {d}");
            }
        }
    }

    /// The walk's step is [`coprime_stride`]'s for every grid.
    #[test]
    fn walks_step_by_coprime_strides() {
        for n in [1u32, 2, 3, 4, 9, 16, 25, 64, 100, 256, 4096] {
            let strata = Strata::new(n);
            for seed in 0..500u32 {
                let (_, stride) = strata.walk(seed);
                let want = coprime_stride(strata.cells, hash_u32(seed ^ 0x5bd1_e995));
                assert_eq!(stride, want, "{n} samples, seed {seed}");
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
