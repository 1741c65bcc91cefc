//! An alpha image and its sampling, mirroring Cycles' CPU kernel
//! (`intern/cycles/kernel/device/cpu/image.h`, `TextureInterpolator::interp_closest`,
//! `interp_linear`, `interp_cubic`, `frac`, `wrap_periodic`, `wrap_clamp`, `wrap_mirror`,
//! `read_clip`): the same pixel-centre convention, wrap rules and f32 operations in the same
//! order. The UV reaches it unchanged (`svm_node_tex_image` with flat projection: no V flip), so
//! row 0 of the texels is the image's bottom row (v in [0, 1/height)), as Blender stores images.

use serde::{Deserialize, Serialize};

use crate::{Error, Result};
use xxhash_rust::xxh3::Xxh3;

/// The Image Texture node's interpolation (Cycles' `InterpolationType`; Smart is Cubic).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Interpolation {
    Closest,
    Linear,
    Cubic,
}

/// The Image Texture node's extension (Cycles' `ExtensionType`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Extension {
    Repeat,
    Extend,
    Clip,
    Mirror,
}

/// One alpha value per texel, rows of `width` from the bottom row up (Blender's order).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlphaImage {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<f32>,
}

impl AlphaImage {
    /// Checks the size (at least one texel, `width * height` texels) and that no texel is NaN
    /// or infinite. `name` is how the error names the image.
    pub fn validate(&self, name: &str) -> Result<()> {
        if self.width == 0 || self.height == 0 {
            return Err(Error::invalid(
                format!("{name}.size"),
                format!("image of {}x{} pixels (0 pixels)", self.width, self.height),
            ));
        }
        let want = self.width as u64 * self.height as u64;
        if self.texels.len() as u64 != want {
            return Err(Error::invalid(
                format!("{name}.texels"),
                format!(
                    "{} texels for a {}x{} image ({want} expected)",
                    self.texels.len(),
                    self.width,
                    self.height
                ),
            ));
        }
        if let Some(i) = self.texels.iter().position(|t| !t.is_finite()) {
            return Err(Error::NonFinite {
                owner: name.to_string(),
                what: "texels",
                index: i,
                value: self.texels[i] as f64,
            });
        }
        Ok(())
    }

    /// The image's identity on the wire (`UploadImage.hash`): XXH3 over the width and height
    /// (u32 LE each) and the texels (f32 LE, rows bottom-up), so a client uploads each image once
    /// per daemon, as meshes ([`crate::scene::Mesh::content_hash`]).
    pub fn content_hash(&self) -> u64 {
        let mut h = Xxh3::new();
        h.update(&self.width.to_le_bytes());
        h.update(&self.height.to_le_bytes());
        // In chunks, so hashing a large image allocates nothing proportional to it.
        let mut buf = [0u8; 4096];
        for chunk in self.texels.chunks(buf.len() / 4) {
            for (out, t) in buf.chunks_exact_mut(4).zip(chunk) {
                out.copy_from_slice(&t.to_le_bytes());
            }
            h.update(&buf[..chunk.len() * 4]);
        }
        h.digest()
    }

    /// The alpha at texture coordinate (u, v) (Cycles' `TextureInterpolator::interp`). Requires
    /// a validated image; a NaN coordinate reads texel column/row 0 (validation rejects NaN
    /// UVs, so only a NaN from the caller reaches here).
    #[inline]
    pub fn sample(
        &self,
        interpolation: Interpolation,
        extension: Extension,
        u: f32,
        v: f32,
    ) -> f32 {
        match interpolation {
            Interpolation::Closest => self.closest(extension, u, v),
            Interpolation::Linear => self.linear(extension, u, v),
            Interpolation::Cubic => self.cubic(extension, u, v),
        }
    }

    #[inline(always)]
    fn read(&self, x: i32, y: i32) -> f32 {
        self.texels[y as usize * self.width as usize + x as usize]
    }

    /// Cycles' `read_clip`: 0 outside the image.
    #[inline(always)]
    fn read_clip(&self, x: i32, y: i32) -> f32 {
        let (w, h) = (self.width as i32, self.height as i32);
        if x < 0 || x >= w || y < 0 || y >= h {
            return 0.0;
        }
        self.read(x, y)
    }

    /// Cycles' `interp_closest`.
    fn closest(&self, extension: Extension, u: f32, v: f32) -> f32 {
        let (w, h) = (self.width as i32, self.height as i32);
        let (_, mut ix) = frac(u * w as f32);
        let (_, mut iy) = frac(v * h as f32);
        match extension {
            Extension::Repeat => {
                ix = wrap_periodic(ix, w);
                iy = wrap_periodic(iy, h);
            }
            Extension::Clip => {
                if ix < 0 || ix >= w || iy < 0 || iy >= h {
                    return 0.0;
                }
            }
            Extension::Extend => {
                ix = wrap_clamp(ix, w);
                iy = wrap_clamp(iy, h);
            }
            Extension::Mirror => {
                ix = wrap_mirror(ix, w);
                iy = wrap_mirror(iy, h);
            }
        }
        self.read(ix, iy)
    }

    /// Cycles' `interp_linear`: samples centred by a -0.5 offset.
    fn linear(&self, extension: Extension, u: f32, v: f32) -> f32 {
        let (w, h) = (self.width as i32, self.height as i32);
        let (tx, mut ix) = frac(u * w as f32 - 0.5);
        let (ty, mut iy) = frac(v * h as f32 - 0.5);
        let (nix, niy);
        match extension {
            Extension::Repeat => {
                ix = wrap_periodic(ix, w);
                nix = wrap_periodic(ix.wrapping_add(1), w);
                iy = wrap_periodic(iy, h);
                niy = wrap_periodic(iy.wrapping_add(1), h);
            }
            Extension::Clip => {
                if ix < -1 || ix >= w || iy < -1 || iy >= h {
                    return 0.0;
                }
                let (nix, niy) = (ix + 1, iy + 1);
                return (1.0 - ty) * (1.0 - tx) * self.read_clip(ix, iy)
                    + (1.0 - ty) * tx * self.read_clip(nix, iy)
                    + ty * (1.0 - tx) * self.read_clip(ix, niy)
                    + ty * tx * self.read_clip(nix, niy);
            }
            Extension::Extend => {
                nix = wrap_clamp(ix.wrapping_add(1), w);
                ix = wrap_clamp(ix, w);
                niy = wrap_clamp(iy.wrapping_add(1), h);
                iy = wrap_clamp(iy, h);
            }
            Extension::Mirror => {
                nix = wrap_mirror(ix.wrapping_add(1), w);
                ix = wrap_mirror(ix, w);
                niy = wrap_mirror(iy.wrapping_add(1), h);
                iy = wrap_mirror(iy, h);
            }
        }
        (1.0 - ty) * (1.0 - tx) * self.read(ix, iy)
            + (1.0 - ty) * tx * self.read(nix, iy)
            + ty * (1.0 - tx) * self.read(ix, niy)
            + ty * tx * self.read(nix, niy)
    }

    /// Cycles' `interp_cubic` (uniform cubic B-spline weights, `SET_CUBIC_SPLINE_WEIGHTS`).
    fn cubic(&self, extension: Extension, u: f32, v: f32) -> f32 {
        let (w, h) = (self.width as i32, self.height as i32);
        let (tx, ix) = frac(u * w as f32 - 0.5);
        let (ty, iy) = frac(v * h as f32 - 0.5);
        let wrap: fn(i32, i32) -> i32 = match extension {
            Extension::Repeat => wrap_periodic,
            Extension::Extend => wrap_clamp,
            Extension::Mirror => wrap_mirror,
            Extension::Clip => {
                if ix < -2 || ix > w || iy < -2 || iy > h {
                    return 0.0;
                }
                |x, _| x
            }
        };
        // Cycles wraps ix first for Repeat (the neighbours wrap the wrapped index) and last for
        // Extend and Mirror; periodic wrapping gives the same indices either way.
        let xs = [-1, 0, 1, 2].map(|d| wrap(ix.wrapping_add(d), w));
        let ys = [-1, 0, 1, 2].map(|d| wrap(iy.wrapping_add(d), h));
        let uw = spline_weights(tx);
        let vw = spline_weights(ty);
        let term = |col: usize| {
            vw[col]
                * (uw[0] * self.read_clip(xs[0], ys[col])
                    + uw[1] * self.read_clip(xs[1], ys[col])
                    + uw[2] * self.read_clip(xs[2], ys[col])
                    + uw[3] * self.read_clip(xs[3], ys[col]))
        };
        term(0) + term(1) + term(2) + term(3)
    }
}

/// Cycles' `SET_CUBIC_SPLINE_WEIGHTS`.
#[inline(always)]
fn spline_weights(t: f32) -> [f32; 4] {
    [
        (((-1.0 / 6.0) * t + 0.5) * t - 0.5) * t + (1.0 / 6.0),
        ((0.5 * t - 1.0) * t) * t + (2.0 / 3.0),
        ((-0.5 * t + 0.5) * t + 0.5) * t + (1.0 / 6.0),
        (1.0 / 6.0) * t * t * t,
    ]
}

/// Cycles' `frac`: the fraction and the floor, via truncation minus one below 0 (so -2.0 gives
/// floor -3 and fraction 1.0, as in Cycles). Cycles' `float_to_int` is C's truncating cast,
/// undefined past i32; Rust's saturates there.
#[inline(always)]
fn frac(x: f32) -> (f32, i32) {
    let i = (x as i32).wrapping_sub((x < 0.0) as i32);
    (x - i as f32, i)
}

/// Cycles' `wrap_periodic`.
#[inline(always)]
fn wrap_periodic(x: i32, width: i32) -> i32 {
    let x = x % width;
    if x < 0 {
        x + width
    } else {
        x
    }
}

/// Cycles' `wrap_clamp`.
#[inline(always)]
fn wrap_clamp(x: i32, width: i32) -> i32 {
    x.clamp(0, width - 1)
}

/// Cycles' `wrap_mirror`.
#[inline(always)]
fn wrap_mirror(x: i32, width: i32) -> i32 {
    let m = (x + (x < 0) as i32).unsigned_abs() % (2 * width as u32);
    let m = m as i32;
    if m >= width {
        2 * width - m - 1
    } else {
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn content_hash_is_xxh3_of_the_size_and_texels_le() {
        let image = AlphaImage {
            width: 3,
            height: 2,
            texels: (0..6).map(|i| i as f32 * 0.25).collect(),
        };
        let mut bytes = Vec::new();
        bytes.extend(3u32.to_le_bytes());
        bytes.extend(2u32.to_le_bytes());
        for t in &image.texels {
            bytes.extend(t.to_le_bytes());
        }
        assert_eq!(image.content_hash(), xxhash_rust::xxh3::xxh3_64(&bytes));
        // The size is hashed: the same texels as 2x3 are another image.
        let transposed = AlphaImage {
            width: 2,
            height: 3,
            ..image.clone()
        };
        assert_ne!(image.content_hash(), transposed.content_hash());
    }
}
