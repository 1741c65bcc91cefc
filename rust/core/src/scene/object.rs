use glam::DMat4;
use serde::{Deserialize, Serialize};

/// An instance of a mesh in the world: Blender's object with its evaluated world matrix and the
/// ray-visibility flags that matter for a shadow pass.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Object {
    pub name: String,
    /// Index into [`crate::scene::Scene::meshes`].
    pub mesh: usize,
    /// Object space to world space (Blender's `matrix_world`), kept in f64 so that scenes far from
    /// the origin lose no precision before they are re-centred (see [`crate::scene::RenderSpace`]).
    pub world_from_object: DMat4,
    /// Seen by camera rays (Blender's `visible_camera`).
    pub visible_to_camera: bool,
    /// Blocks shadow rays (Blender's `visible_shadow`).
    pub casts_shadow: bool,
    /// Per material slot, the index of its material in [`crate::scene::SceneAlpha::materials`],
    /// or `None` for an opaque one; slots past the end are opaque. Empty: all opaque.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub materials: Vec<Option<u32>>,
}

impl Object {
    /// The alpha material of slot `slot`, `None` when it is opaque.
    #[inline]
    pub fn alpha_material(&self, slot: u32) -> Option<u32> {
        self.materials.get(slot as usize).copied().flatten()
    }

    pub fn new(name: impl Into<String>, mesh: usize, world_from_object: DMat4) -> Self {
        Object {
            name: name.into(),
            mesh,
            world_from_object,
            visible_to_camera: true,
            casts_shadow: true,
            materials: Vec::new(),
        }
    }
}
