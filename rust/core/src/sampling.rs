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
    let mut cell = hash_u32(seed) % cells;
    let stride = coprime_stride(cells, hash_u32(seed ^ 0x5bd1_e995));
    // A power-of-two side (4, 16, 64... samples) splits a cell by a shift and scales by an exact
    // reciprocal: the same values as the division, without one.
    let shift = side.trailing_zeros();
    let pow2 = side.is_power_of_two();
    let inv_side = 1.0 / side as f32;
    out.extend((0..n).map(|i| {
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
        cell += stride;
        if cell >= cells {
            cell -= cells;
        }
        [x.min(1.0 - f32::EPSILON), y.min(1.0 - f32::EPSILON)]
    }));
}

fn coprime_stride(n: u32, h: u32) -> u32 {
    if n <= 1 {
        return 1;
    }
    let mut s = 1 + h % (n - 1);
    while gcd(s, n) != 1 {
        s = s % (n - 1) + 1;
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
#[inline]
pub fn concentric_disk(u: [f32; 2]) -> [f32; 2] {
    let a = 2.0 * u[0] - 1.0;
    let b = 2.0 * u[1] - 1.0;
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, std::f32::consts::FRAC_PI_4 * (b / a))
    } else {
        (
            b,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (a / b),
        )
    };
    [r * phi.cos(), r * phi.sin()]
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

    #[test]
    fn disk_points_inside() {
        for i in 0..100 {
            let u = [unit_float(hash_u32(i)), unit_float(hash_u32(i + 1000))];
            let d = concentric_disk(u);
            assert!(d[0] * d[0] + d[1] * d[1] <= 1.0 + 1e-6);
        }
    }
}
