//! antumbra core: the scene model, robust ray/box and ray/triangle tests, BVH builders,
//! traversal orders, traversal with exact work counters, and the passes that turn a scene into
//! shadow masks, heat maps and statistics; plus the one schema of the render settings.
//!
//! The data flow of one frame (see `ARCHITECTURE.md`):
//! [`scene::Scene`] → [`scene::FrameGeometry`] (triangles in a normalised render space)
//! → [`build`] ([`bvh::Bvh`], collapsed to [`bvh::WideBvh`] when needed) → a light's tree and
//! [`order`] ([`render::light_tracing`]) → [`trace`] → [`render::Renderer::render`] (primary pass,
//! shadow passes, combine) → [`render::FrameResult`] (images + [`stats::StatsRow`] per pass)
//! → [`output::write_frame_files`]. [`settings::SCHEMA`] describes every [`render::RenderSettings`] field.

pub mod alpha;
#[cfg(feature = "files")]
pub mod atomic_file;
pub mod build;
pub mod bvh;
pub mod cancel;
pub mod compare;
pub mod error;
pub mod geometry;
pub mod image;
pub mod order;
#[cfg(feature = "files")]
pub mod output;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod settings;
pub mod srdh;
pub mod stats;
pub mod trace;
pub mod trade;
pub mod two_level;

pub use error::{Error, Result};
