use glam::{DMat4, DVec3};
use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// Shape of an area light, as Blender's `shape`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum AreaShape {
    Square,
    Rectangle,
    Disk,
    Ellipse,
}

/// The kinds of Blender light and the parameters that decide where shadows fall.
/// Angles are radians, sizes are world units; all lights emit along their local -Z axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum LightKind {
    /// `shadow_soft_size` is the radius; 0 gives a hard shadow.
    Point { radius: f64 },
    /// `angle` is the full angular diameter of the sun disk; 0 gives a hard shadow.
    Sun { angle: f64 },
    /// A point light restricted to a cone: `spot_size` is the full cone angle. `spot_blend` only
    /// shapes intensity, not visibility, and is kept for completeness of the export.
    Spot {
        radius: f64,
        spot_size: f64,
        spot_blend: f64,
    },
    /// `size_x` (and `size_y` for rectangle and ellipse) are full extents in the light's XY plane;
    /// square and disk use `size_x` for both.
    Area {
        shape: AreaShape,
        size_x: f64,
        size_y: f64,
    },
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    pub name: String,
    pub world_from_light: DMat4,
    pub kind: LightKind,
    /// Blender's `use_shadow`: a light that casts no shadow needs no shadow rays.
    pub casts_shadow: bool,
}

impl Light {
    pub fn new(name: impl Into<String>, world_from_light: DMat4, kind: LightKind) -> Self {
        Light {
            name: name.into(),
            world_from_light,
            kind,
            casts_shadow: true,
        }
    }

    pub fn position(&self) -> DVec3 {
        self.world_from_light.w_axis.truncate()
    }

    /// The direction the light points to (its local -Z axis in world space, normalised).
    pub fn direction(&self) -> DVec3 {
        (-self.world_from_light.z_axis.truncate()).normalize()
    }

    /// True when a single shadow ray gives the exact answer (a point-like or direction-like light).
    pub fn is_hard(&self) -> bool {
        match self.kind {
            LightKind::Point { radius } | LightKind::Spot { radius, .. } => radius == 0.0,
            LightKind::Sun { angle } => angle == 0.0,
            LightKind::Area { .. } => false,
        }
    }

    pub fn validate(&self) -> Result<()> {
        let name = &self.name;
        let nonneg = |field: &str, v: f64| -> Result<()> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(Error::invalid(
                    format!("light '{name}'.{field}"),
                    format!("must be a finite number >= 0, got {v}"),
                ))
            }
        };
        match self.kind {
            LightKind::Point { radius } => nonneg("radius", radius)?,
            LightKind::Sun { angle } => {
                nonneg("angle", angle)?;
                if angle > std::f64::consts::PI {
                    return Err(Error::invalid(
                        format!("light '{name}'.angle"),
                        format!("must be at most pi, got {angle}"),
                    ));
                }
            }
            LightKind::Spot {
                radius,
                spot_size,
                spot_blend,
            } => {
                nonneg("radius", radius)?;
                nonneg("spot_blend", spot_blend)?;
                if !(spot_size > 0.0 && spot_size <= std::f64::consts::PI) {
                    return Err(Error::invalid(
                        format!("light '{name}'.spot_size"),
                        format!("must be in (0, pi], got {spot_size}"),
                    ));
                }
            }
            LightKind::Area { size_x, size_y, .. } => {
                nonneg("size_x", size_x)?;
                nonneg("size_y", size_y)?;
            }
        }
        if let Some(i) = self
            .world_from_light
            .to_cols_array()
            .iter()
            .position(|v| !v.is_finite())
        {
            return Err(Error::NonFinite {
                owner: format!("light '{name}'"),
                what: "world matrix",
                index: i,
                value: self.world_from_light.to_cols_array()[i],
            });
        }
        Ok(())
    }
}
