//! The scene model: what Blender exports for one frame, kept close to Blender's own terms.
//!
//! Meshes hold object-space positions (f32, as Blender stores them); objects place meshes with f64
//! world matrices. [`FrameGeometry`] turns one frame into world-space triangles in a normalised
//! render space (see [`RenderSpace`]) that the builders and tracers consume.

mod animation;
mod camera;
mod frame_geometry;
mod image_size;
mod light;
pub mod limits;
mod material;
mod mesh;
mod object;
#[allow(clippy::module_inception)]
mod scene;

pub use animation::{Animation, StaticAnimation};
pub use camera::{Camera, Resolution, SensorFit, ViewPlane};
pub(crate) use frame_geometry::{collect, is_degenerate, scene_bounds};
pub use frame_geometry::{FrameGeometry, RenderSpace, TriangleRef, TriangleSet};
pub use image_size::{ImageSize, ImageSizeError};
pub use light::{AreaShape, Light, LightKind};
pub use material::{AlphaMaterial, SceneAlpha, UvMap};
pub use mesh::Mesh;
pub use object::Object;
pub use scene::Scene;
