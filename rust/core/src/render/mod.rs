//! The passes of one frame: primary rays (closest hit, the visible set, primary heat maps), then
//! per light the shadow rays (any hit) that give the shadow mask and shadow heat maps, and the
//! statistics of both. [`Renderer`] keeps what carries over between frames.

pub mod auto;
mod camera_rays;
mod facing;
mod frame_alpha;
mod frame_trees;
mod light_tracer;
mod lights;
mod memory;
mod mesh_entry;
mod object_changes;
mod passes;
mod pick;
mod policy;
pub use policy::pass_rays;
mod primary;
mod renderer;
mod sample_lanes;
mod scene_trees;
mod settings;
mod shadow;
mod srdh_light;
pub mod tiles;
mod two_level_query;
mod two_level_trees;
mod visibility;
mod wide_tree;

pub use camera_rays::PrimaryRays;
pub use facing::Facing;
pub use frame_alpha::{alpha_scene, AlphaCamera, AlphaFrameStats, FrameAlpha};
pub use frame_trees::{CameraQuery, CameraTree, FrameTrees};
pub use light_tracer::{
    binary_order, light_tracing, LightRays, LightTracing, ShadowTracer, ShadowTrees,
};
pub use lights::{LightFrom, LightSample, LightSampler};
pub use memory::{
    all_output_planes, estimate_comparison_bytes, estimate_render_bytes, format_bytes, RenderMemory,
};
pub use object_changes::ObjectChanges;
pub use pick::{Pick, AUTO};
pub use primary::{HitGeometry, PrimaryPass, SurfacePoint};
pub use renderer::{FrameResult, HeatMaps, Renderer, WarmUp, OBJECT_PLANE};
pub use scene_trees::SceneTrees;
pub use settings::{RenderSettings, SceneStructure, StatsMode, MAX_SPP, MAX_TRANSPARENT_BOUNCES};
pub use shadow::{
    representative_rays, samples_for, shadow_ray_batches, shadow_rays, PointRays, SamplePlan,
    ShadowPass, ShadowRayOutcome,
};
pub use srdh_light::{srdh_for_light, srdh_rays, LightSrdh};
pub use two_level_query::{MeshQuery, TwoLevelQuery};
pub use two_level_trees::TwoLevelTrees;
pub use visibility::{visibility_flags, VisibilitySource};
pub use wide_tree::{OrderedWideTree, WideTree};
