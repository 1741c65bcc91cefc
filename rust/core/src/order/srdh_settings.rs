//! Settings of the SRDH order (`srdh[:rays=WxH|all|F][:bins=B][:leaf=K][:kernels=..][:min_occluded=F]`):
//! where a light's representative rays come from and how its SRDH tree is built.

use serde::{Deserialize, Serialize};

use super::kernel::KernelSet;
use crate::scene::{ImageSize, ImageSizeError};
use crate::{Error, Result};

/// Where a light's representative rays come from.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum RaySetSource {
    /// The pixels of a `width` x `height` grid over the frame (a low-resolution prepass), all
    /// light samples of each.
    Prepass { width: u32, height: u32 },
    /// A hashed share of the frame's pixels, in (0, 1].
    Budget(f32),
    /// Every shadow ray of the frame (the paper's best case).
    All,
}

/// Settings of the SRDH order (`srdh[:rays=16x16|all|F][:bins=B][:leaf=K][:kernels=..][:min_occluded=F]`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SrdhSettings {
    pub rays: RaySetSource,
    /// Centroid bins per axis: `bins - 1` candidate planes (the paper: 31).
    pub bins: u32,
    /// Nodes with at most this many triangles become leaves (the paper: 1).
    pub leaf: u32,
    pub kernels: KernelSet,
    /// A light gets its own tree only when at least this share of its representative rays is
    /// occluded; others trace the SAH tree front to back.
    pub min_occluded: f32,
}

impl Default for SrdhSettings {
    fn default() -> Self {
        SrdhSettings {
            rays: RaySetSource::Prepass {
                width: 16,
                height: 16,
            },
            bins: 32,
            leaf: 1,
            kernels: KernelSet::All,
            min_occluded: DEFAULT_MIN_OCCLUDED,
        }
    }
}

/// The default of [`SrdhSettings::min_occluded`].
pub const DEFAULT_MIN_OCCLUDED: f32 = 0.5;

fn invalid(msg: String) -> Error {
    Error::invalid("order", msg)
}

impl SrdhSettings {
    pub fn validate(&self) -> Result<()> {
        if !(2..=256).contains(&self.bins) {
            return Err(invalid(format!(
                "srdh: bins must be in 2..=256, got {}",
                self.bins
            )));
        }
        if !(1..=64).contains(&self.leaf) {
            return Err(invalid(format!(
                "srdh: leaf must be in 1..=64, got {}",
                self.leaf
            )));
        }
        if !(0.0..=1.0).contains(&self.min_occluded) {
            return Err(invalid(format!(
                "srdh: min_occluded must be in [0, 1], got {}",
                self.min_occluded
            )));
        }
        match self.rays {
            RaySetSource::Prepass { width, height } => ImageSize::new(width, height)
                .check(ImageSize::MAX_PREPASS_SIDE)
                .map(|_| ())
                .map_err(|e| invalid(format!("srdh: prepass {e}"))),
            RaySetSource::Budget(f) if !(f > 0.0 && f <= 1.0) => Err(invalid(format!(
                "srdh: rays share must be in (0, 1], got {f}"
            ))),
            _ => Ok(()),
        }
    }

    /// Reads the options after `srdh` (`key=value` pairs).
    pub fn parse_options(options: &[(&str, &str)]) -> Result<Self> {
        let mut s = SrdhSettings::default();
        let int = |k: &str, v: &str| {
            v.parse::<u32>()
                .map_err(|_| invalid(format!("srdh: {k} must be an integer, got '{v}'")))
        };
        for &(k, v) in options {
            match k {
                "rays" => s.rays = parse_rays(v)?,
                "bins" => s.bins = int(k, v)?,
                "leaf" => s.leaf = int(k, v)?,
                "kernels" => {
                    s.kernels = match v {
                        "all" => KernelSet::All,
                        "constant" => KernelSet::Constant,
                        "directional" => KernelSet::Directional,
                        _ => {
                            return Err(invalid(format!(
                                "srdh: kernels must be all|constant|directional, got '{v}'"
                            )))
                        }
                    }
                }
                "min_occluded" => {
                    s.min_occluded = v.parse().map_err(|_| {
                        invalid(format!("srdh: min_occluded must be a number, got '{v}'"))
                    })?
                }
                _ => {
                    return Err(invalid(format!(
                        "srdh: unknown option '{k}' (known: rays=WxH|all|F, bins, leaf, \
                         kernels=all|constant|directional, min_occluded)"
                    )))
                }
            }
        }
        s.validate()?;
        Ok(s)
    }
}

fn parse_rays(v: &str) -> Result<RaySetSource> {
    if v == "all" {
        return Ok(RaySetSource::All);
    }
    match v.parse::<ImageSize>() {
        Ok(size) => {
            return Ok(RaySetSource::Prepass {
                width: size.width,
                height: size.height,
            })
        }
        // Not `WxH` at all: a share.
        Err(ImageSizeError::NotWxH(_)) => {}
        Err(_) => {
            return Err(invalid(format!(
                "srdh: rays must be WxH, all or a share, got '{v}'"
            )))
        }
    }
    let f = match v.strip_suffix('%') {
        Some(p) => p.parse::<f32>().map(|p| p / 100.0),
        None => v.parse::<f32>(),
    }
    .map_err(|_| invalid(format!("srdh: rays must be WxH, all or a share, got '{v}'")))?;
    Ok(RaySetSource::Budget(f))
}

impl std::fmt::Display for SrdhSettings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.rays {
            RaySetSource::Prepass { width, height } => {
                write!(f, "srdh:rays={}", ImageSize::new(width, height))?
            }
            RaySetSource::Budget(b) => write!(f, "srdh:rays={b}")?,
            RaySetSource::All => write!(f, "srdh:rays=all")?,
        }
        write!(
            f,
            ":bins={}:leaf={}:kernels={}:min_occluded={}",
            self.bins,
            self.leaf,
            self.kernels.name(),
            self.min_occluded
        )
    }
}
