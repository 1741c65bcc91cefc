//! The knobs every built-in scene takes.

use antumbra_core::{Error, Result};

/// The largest triangle budget accepted: beyond it a scene would need gigabytes, which is a typo
/// more often than an intent.
pub const MAX_TRIANGLES: usize = 20_000_000;

/// The most instances [`SceneParams::instances`] accepts: ten million objects already take a
/// couple of gigabytes.
pub const MAX_INSTANCES: usize = 10_000_000;

/// Size and length of a built-in scene.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneParams {
    /// Target triangle count in the world (every object's triangles, instances counted each
    /// time). Scenes land within a factor of about 1.5 of it between 10k and 2M; far below 10k a
    /// scene keeps its minimum detail. With [`SceneParams::instances`] set it is the budget of
    /// unique triangles instead (the instanced meshes together). Either way at most
    /// [`MAX_TRIANGLES`].
    pub triangles: usize,
    /// Frames are numbered `1..=frames`.
    pub frames: i32,
    /// Rotate the whole scene by 45 degrees about the vertical (Z) axis.
    pub rotated: bool,
    /// Exactly this many instances (objects sharing a few meshes), for scenes that instance
    /// (`instanced-forest`); other scenes refuse it. `None` derives the count from `triangles`.
    /// With it set, `triangles` budgets the unique triangles, so a million instances of a
    /// 100k-triangle tree cost the objects only. At most [`MAX_INSTANCES`].
    pub instances: Option<usize>,
}

impl Default for SceneParams {
    fn default() -> Self {
        SceneParams {
            triangles: 100_000,
            frames: 24,
            rotated: false,
            instances: None,
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
        if let Some(n) = self.instances {
            if n == 0 || n > MAX_INSTANCES {
                return Err(Error::invalid(
                    "instances",
                    format!("must be between 1 and {MAX_INSTANCES}, got {n}"),
                ));
            }
        }
        Ok(self.clone())
    }
}
