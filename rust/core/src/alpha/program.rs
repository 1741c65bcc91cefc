//! A material's alpha as a short program: a source, then Math-node operations in order, in f32
//! (Cycles' `svm_math` for each operation: `intern/cycles/kernel/svm/math_util.h`).

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::{AlphaImage, Extension, Interpolation};
use crate::{Error, Result};

/// Where a material's alpha starts.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum AlphaSource {
    /// The same alpha everywhere (a Principled BSDF's Alpha value, a mix factor).
    Constant(f32),
    /// An image's alpha (or the channel the material reads) through a triangle's corner UVs.
    Image {
        /// Index into the scene's images.
        image: u32,
        /// Which of the triangle set's UV sets the UV map names.
        uv_set: u32,
        interpolation: Interpolation,
        extension: Extension,
    },
}

/// One Math node, the other input a constant.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum AlphaOp {
    Multiply(f32),
    Add(f32),
    Subtract(f32),
    /// Cycles' `safe_powf`: 0 for a negative base and a non-integer exponent.
    Power(f32),
    /// 1 if the value is greater than the constant, else 0.
    GreaterThan(f32),
    /// 1 if the value is less than the constant, else 0.
    LessThan(f32),
    /// 1 - value (a Subtract node with the value second, or an Invert).
    OneMinus,
    /// The Math node's Clamp option: to [0, 1].
    Clamp,
}

impl AlphaOp {
    #[inline]
    fn apply(self, a: f32) -> f32 {
        match self {
            AlphaOp::Multiply(c) => a * c,
            AlphaOp::Add(c) => a + c,
            AlphaOp::Subtract(c) => a - c,
            AlphaOp::Power(c) => safe_powf(a, c),
            AlphaOp::GreaterThan(c) => (a > c) as u32 as f32,
            AlphaOp::LessThan(c) => (a < c) as u32 as f32,
            AlphaOp::OneMinus => 1.0 - a,
            AlphaOp::Clamp => saturate(a),
        }
    }

    fn constant(self) -> Option<f32> {
        match self {
            AlphaOp::Multiply(c)
            | AlphaOp::Add(c)
            | AlphaOp::Subtract(c)
            | AlphaOp::Power(c)
            | AlphaOp::GreaterThan(c)
            | AlphaOp::LessThan(c) => Some(c),
            AlphaOp::OneMinus | AlphaOp::Clamp => None,
        }
    }
}

/// Cycles' `safe_powf` (its `float_to_int` truncates; the CPU's `compatible_powf` is `powf`).
#[inline]
fn safe_powf(a: f32, b: f32) -> f32 {
    if a < 0.0 && b != (b as i32) as f32 {
        return 0.0;
    }
    a.powf(b)
}

/// Cycles' `saturatef`, with NaN taken as opaque (1): an alpha program that divides by zero
/// through Power must not make a triangle vanish.
#[inline(always)]
fn saturate(a: f32) -> f32 {
    if a.is_nan() {
        1.0
    } else {
        a.clamp(0.0, 1.0)
    }
}

/// One material's alpha: 1 opaque, 0 fully transparent.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlphaProgram {
    pub source: AlphaSource,
    pub ops: Vec<AlphaOp>,
}

impl AlphaProgram {
    /// An opaque-everywhere or uniformly translucent material (a glass box of alpha 0.5).
    pub fn constant(alpha: f32) -> Self {
        AlphaProgram {
            source: AlphaSource::Constant(alpha),
            ops: Vec::new(),
        }
    }

    /// An image's alpha through `uv_set`, no operations.
    pub fn image(
        image: u32,
        uv_set: u32,
        interpolation: Interpolation,
        extension: Extension,
    ) -> Self {
        AlphaProgram {
            source: AlphaSource::Image {
                image,
                uv_set,
                interpolation,
                extension,
            },
            ops: Vec::new(),
        }
    }

    /// The alpha at texture coordinate `uv` (ignored by a constant source), clamped to [0, 1]
    /// (NaN counts as 1). `images` must hold the source's image (see [`AlphaProgram::validate`]).
    #[inline]
    pub fn eval(&self, images: &[AlphaImage], uv: [f32; 2]) -> f32 {
        self.eval_with(|i| &images[i], uv)
    }

    /// [`AlphaProgram::eval`] over images shared with the scene (a frame's
    /// [`crate::scene::SceneAlpha`]), so a frame's alpha copies no texels.
    #[inline]
    pub fn eval_shared(&self, images: &[Arc<AlphaImage>], uv: [f32; 2]) -> f32 {
        self.eval_with(|i| &images[i], uv)
    }

    #[inline(always)]
    fn eval_with<'a>(&self, image_at: impl Fn(usize) -> &'a AlphaImage, uv: [f32; 2]) -> f32 {
        let mut a = match self.source {
            AlphaSource::Constant(c) => c,
            AlphaSource::Image {
                image,
                interpolation,
                extension,
                ..
            } => image_at(image as usize).sample(interpolation, extension, uv[0], uv[1]),
        };
        for op in &self.ops {
            a = op.apply(a);
        }
        saturate(a)
    }

    /// Whether it reads an image (and so needs UVs).
    pub fn uv_set(&self) -> Option<u32> {
        match self.source {
            AlphaSource::Constant(_) => None,
            AlphaSource::Image { uv_set, .. } => Some(uv_set),
        }
    }

    /// Checks the image and UV set exist and every constant is finite; `name` names the material.
    pub fn validate(&self, name: &str, images: usize, uv_sets: usize) -> Result<()> {
        match self.source {
            AlphaSource::Constant(c) if !c.is_finite() => {
                return Err(Error::invalid(
                    format!("{name}.source"),
                    format!("constant alpha {c} is not finite"),
                ));
            }
            AlphaSource::Constant(_) => {}
            AlphaSource::Image { image, uv_set, .. } => {
                if image as usize >= images {
                    return Err(Error::invalid(
                        format!("{name}.source.image"),
                        format!("image {image}, but the scene has {images} alpha images"),
                    ));
                }
                if uv_set as usize >= uv_sets {
                    return Err(Error::invalid(
                        format!("{name}.source.uv_set"),
                        format!("UV set {uv_set}, but the triangles have {uv_sets} UV sets"),
                    ));
                }
            }
        }
        for (i, op) in self.ops.iter().enumerate() {
            if let Some(c) = op.constant().filter(|c| !c.is_finite()) {
                return Err(Error::invalid(
                    format!("{name}.ops[{i}]"),
                    format!("{op:?}: constant {c} is not finite"),
                ));
            }
        }
        Ok(())
    }
}
