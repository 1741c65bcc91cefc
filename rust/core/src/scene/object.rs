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
}

impl Object {
    pub fn new(name: impl Into<String>, mesh: usize, world_from_object: DMat4) -> Self {
        Object {
            name: name.into(),
            mesh,
            world_from_object,
            visible_to_camera: true,
            casts_shadow: true,
        }
    }
}
