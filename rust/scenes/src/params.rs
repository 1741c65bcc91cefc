//! The knobs every built-in scene takes.

use antumbra_core::{Error, Result};

/// The largest triangle budget accepted: beyond it a scene would need gigabytes, which is a typo
/// more often than an intent.
pub const MAX_TRIANGLES: usize = 20_000_000;

/// Size and length of a built-in scene.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneParams {
    /// Target triangle count. Scenes land within a factor of about 1.5 of it between 10k and 2M;
    /// far below 10k a scene keeps its minimum detail.
    pub triangles: usize,
    /// Frames are numbered `1..=frames`.
    pub frames: i32,
    /// Rotate the whole scene by 45 degrees about the vertical (Z) axis.
    pub rotated: bool,
}

impl Default for SceneParams {
    fn default() -> Self {
        SceneParams {
            triangles: 100_000,
            frames: 24,
            rotated: false,
        }
    }
}

impl SceneParams {
    /// Checks the ranges; returns the parameters so a constructor can take them by value.
    pub(crate) fn validated(&self) -> Result<SceneParams> {
        if self.triangles == 0 || self.triangles > MAX_TRIANGLES {
            return Err(Error::invalid(
                "triangles",
                format!(
                    "must be between 1 and {MAX_TRIANGLES}, got {}",
                    self.triangles
                ),
            ));
        }
        if self.frames < 1 {
            return Err(Error::invalid(
                "frames",
                format!("must be at least 1, got {}", self.frames),
            ));
        }
        Ok(self.clone())
    }
}
