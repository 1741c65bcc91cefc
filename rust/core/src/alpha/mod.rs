//! Alpha-textured materials for shadows and camera rays (issue 38): an alpha image sampled as
//! Cycles' CPU kernel samples 2D image textures, a short per-material program from a source
//! (a constant or an image through a UV set) through Math-node operations, and per-triangle
//! data (which triangles are flagged, their material and corner UVs). Pure data and evaluation:
//! the traversals that use it are in [`crate::trace`] (`HitFilter`, `transmission`).

mod image;
mod program;
mod scene;
mod triangles;

pub use image::{AlphaImage, Extension, Interpolation};
pub use program::{AlphaOp, AlphaProgram, AlphaSource};
pub use scene::AlphaScene;
pub use triangles::{AlphaTriangles, FlaggedTriangle};
