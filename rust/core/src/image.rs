//! A single-channel float image, the passes' output and the writers' input.

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

    /// Checks that the plane has pixels and that `data` holds exactly width × height of them.
    pub fn check_size(&self) -> crate::Result<()> {
        let field = || format!("image plane '{}'", self.name);
        if self.width == 0 || self.height == 0 {
            return Err(crate::Error::invalid(
                field(),
                format!("empty image ({}x{})", self.width, self.height),
            ));
        }
        let expected = self.width as usize * self.height as usize;
        if self.data.len() != expected {
            return Err(crate::Error::invalid(
                field(),
                format!(
                    "{}x{} needs {expected} values, has {}",
                    self.width,
                    self.height,
                    self.data.len()
                ),
            ));
        }
        Ok(())
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
