use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::{Camera, Light, Mesh, Object, Resolution, SceneAlpha};
use crate::{Error, Result};

/// One frame of a scene: meshes (shared between frames through `Arc` when they do not change),
/// the objects that place them, the camera, the lights and the output resolution.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Scene {
    pub frame: i32,
    pub meshes: Vec<Arc<Mesh>>,
    pub objects: Vec<Object>,
    pub camera: Camera,
    pub lights: Vec<Light>,
    pub resolution: Resolution,
    /// Alpha images and materials the objects' slots refer to; empty for an opaque scene.
    #[serde(default)]
    pub alpha: SceneAlpha,
}

impl Scene {
    /// Checks every field a user can get wrong; the error names the object, mesh or light.
    pub fn validate(&self) -> Result<()> {
        let at_frame = |e: Error| match e {
            Error::Invalid { field, message } => Error::Invalid {
                field: format!("frame {}: {field}", self.frame),
                message,
            },
            other => other,
        };
        for mesh in &self.meshes {
            mesh.validate()?;
        }
        self.alpha.validate().map_err(at_frame)?;
        for object in &self.objects {
            if object.mesh >= self.meshes.len() {
                return Err(Error::UnknownMesh {
                    object: object.name.clone(),
                    mesh: object.mesh,
                    mesh_count: self.meshes.len(),
                });
            }
            if let Some(slot) = object
                .materials
                .iter()
                .position(|m| m.is_some_and(|m| m as usize >= self.alpha.materials.len()))
            {
                return Err(at_frame(Error::invalid(
                    format!("object '{}'.materials[{slot}]", object.name),
                    format!(
                        "alpha material {}, but the frame has {}",
                        object.materials[slot].unwrap_or_default(),
                        self.alpha.materials.len()
                    ),
                )));
            }
            let m = object.world_from_object.to_cols_array();
            if let Some(i) = m.iter().position(|v| !v.is_finite()) {
                return Err(Error::NonFinite {
                    owner: format!("object '{}' (frame {})", object.name, self.frame),
                    what: "world matrix",
                    index: i,
                    value: m[i],
                });
            }
        }
        self.camera.validate().map_err(at_frame)?;
        self.resolution.validate().map_err(at_frame)?;
        for light in &self.lights {
            light.validate().map_err(at_frame)?;
        }
        Ok(())
    }

    /// Whether any object gives a slot an alpha material (else every triangle is opaque).
    pub fn has_alpha(&self) -> bool {
        self.objects
            .iter()
            .any(|o| o.materials.iter().any(Option::is_some))
    }

    pub fn triangle_count(&self) -> usize {
        self.objects
            .iter()
            .map(|o| self.meshes.get(o.mesh).map_or(0, |m| m.triangles.len()))
            .sum()
    }
}
