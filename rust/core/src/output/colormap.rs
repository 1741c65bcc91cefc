//! Perceptual colour maps for heat maps: a value in [0, 1] to an 8-bit sRGB colour.

use super::colormap_tables::{TURBO, VIRIDIS};

/// A colour map for heat maps. Both are perceptually ordered, so brighter reads as "more work".
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum ColorMap {
    /// Google's Turbo: high contrast, dark blue → green → yellow → dark red.
    #[default]
    Turbo,
    /// matplotlib's Viridis: lightness rises steadily, safe for colour-blind readers and grey prints.
    Viridis,
}

impl ColorMap {
    /// Lower-case name, as printed next to a heat map's scale.
    pub fn name(&self) -> &'static str {
        match self {
            ColorMap::Turbo => "turbo",
            ColorMap::Viridis => "viridis",
        }
    }

    /// The colour of `t`, clamped to [0, 1]; NaN maps to black so missing data stands out.
    pub fn map(&self, t: f32) -> [u8; 3] {
        if t.is_nan() {
            return [0, 0, 0];
        }
        let table = match self {
            ColorMap::Turbo => &TURBO,
            ColorMap::Viridis => &VIRIDIS,
        };
        // Linear interpolation between the 256 published samples (entry i is at t = i / 255).
        let x = t.clamp(0.0, 1.0) * (table.len() - 1) as f32;
        let i = (x.floor() as usize).min(table.len() - 2);
        let f = x - i as f32;
        let (a, b) = (table[i], table[i + 1]);
        let mut rgb = [0u8; 3];
        for c in 0..3 {
            let v = a[c] + (b[c] - a[c]) * f;
            rgb[c] = (v * 255.0).round().clamp(0.0, 255.0) as u8;
        }
        rgb
    }
}

impl std::fmt::Display for ColorMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [u8; 3], b: [u8; 3], tol: i32) -> bool {
        a.iter()
            .zip(b)
            .all(|(&x, y)| (x as i32 - y as i32).abs() <= tol)
    }

    /// Rec. 709 luma, enough to compare "darker" and "lighter".
    fn luma(c: [u8; 3]) -> f32 {
        0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32
    }

    #[test]
    fn output_colormap_viridis_endpoints() {
        let v = ColorMap::Viridis;
        assert!(close(v.map(0.0), [68, 1, 84], 1), "{:?}", v.map(0.0));
        assert!(close(v.map(1.0), [253, 231, 37], 1), "{:?}", v.map(1.0));
    }

    #[test]
    fn output_colormap_turbo_endpoints() {
        let [r0, g0, b0] = ColorMap::Turbo.map(0.0);
        // Dark blue-ish: dark, blue dominant.
        assert!(
            b0 > r0 && b0 > g0 && luma([r0, g0, b0]) < 60.0,
            "{:?}",
            [r0, g0, b0]
        );
        let [r1, g1, b1] = ColorMap::Turbo.map(1.0);
        // Dark red-ish: red dominant, far from bright.
        assert!(r1 > 100 && r1 > 4 * g1 && r1 > 4 * b1 && luma([r1, g1, b1]) < 60.0);
        // The middle is bright: Turbo peaks in lightness inside, not at the ends.
        assert!(luma(ColorMap::Turbo.map(0.5)) > 150.0);
    }

    #[test]
    fn output_colormap_clamps_and_nan_is_black() {
        for m in [ColorMap::Turbo, ColorMap::Viridis] {
            assert_eq!(m.map(-5.0), m.map(0.0));
            assert_eq!(m.map(f32::NEG_INFINITY), m.map(0.0));
            assert_eq!(m.map(7.0), m.map(1.0));
            assert_eq!(m.map(f32::INFINITY), m.map(1.0));
            assert_eq!(m.map(f32::NAN), [0, 0, 0]);
        }
    }

    #[test]
    fn output_colormap_viridis_lightness_rises() {
        let mut last = -1.0;
        for i in 0..=64 {
            let l = luma(ColorMap::Viridis.map(i as f32 / 64.0));
            assert!(l > last, "lightness must rise at step {i}");
            last = l;
        }
    }

    #[test]
    fn output_colormap_is_continuous() {
        for m in [ColorMap::Turbo, ColorMap::Viridis] {
            let mut prev = m.map(0.0);
            for i in 1..=1000 {
                let c = m.map(i as f32 / 1000.0);
                assert!(close(c, prev, 3), "{m} jumps at {i}: {prev:?} -> {c:?}");
                prev = c;
            }
        }
    }
}
