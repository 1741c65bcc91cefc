//! Image output: float planes written as 32-bit float EXR (for numbers) and as PNG (masks in
//! grey, heat maps through a perceptual colour map with their scale).

/// A single-channel float image, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct ImagePlane {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub data: Vec<f32>,
}

impl ImagePlane {
    pub fn new(name: impl Into<String>, width: u32, height: u32) -> Self {
        ImagePlane {
            name: name.into(),
            width,
            height,
            data: vec![0.0; width as usize * height as usize],
        }
    }

    pub fn get(&self, x: u32, y: u32) -> f32 {
        self.data[y as usize * self.width as usize + x as usize]
    }

    /// Smallest and largest finite value (0, 0 for an empty image).
    pub fn range(&self) -> (f32, f32) {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for &v in self.data.iter().filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if lo > hi {
            (0.0, 0.0)
        } else {
            (lo, hi)
        }
    }
}
