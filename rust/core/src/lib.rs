//! antumbra core: the scene model, robust ray/box and ray/triangle tests, BVH builders,
//! traversal with exact work counters, and the passes that turn a scene into shadow masks,
//! heat maps and statistics.
//!
//! The data flow of one frame (see `ARCHITECTURE.md`):
//! [`scene::Scene`] → [`scene::FrameGeometry`] (world-space triangles in a normalised render space)
//! → [`bvh::Bvh`] → [`render::render_frame`] → [`render::FrameResult`] (images + [`stats::FrameStats`]).

pub mod build;
pub mod bvh;
pub mod error;
pub mod geometry;
pub mod order;
pub mod output;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod settings;
pub mod srdh;
pub mod stats;
pub mod trace;

pub use error::{Error, Result};
