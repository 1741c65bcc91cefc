//! Two-level scenes: one tree per unique mesh, in the mesh's own space ([`MeshTree`]), shared by
//! every object that places the mesh, under a top-level tree over the objects' render-space
//! boxes ([`TopLevel`]: 8-wide, its child boxes tested at once by the wide trees' SIMD kernels;
//! a ray counts a top-level node as it counts a wide mesh tree's, one interior node and a box
//! test per used slot, and a leaf per leaf slot entered). A ray crosses the top level in render
//! space and enters a mesh tree through its instance's inverse transform
//! ([`Instance::ray_to_mesh`]), whose parameter `t` is the render-space ray's; hits carry the
//! object ([`crate::trace::Hit::instance`]). A batch crosses the top level in runs of 16 rays and
//! reaches each mesh tree as one batch (`runs`), so a wide mesh tree traces packets.
//!
//! Answers are exact against [`brute`], which tests every triangle of every instance through
//! the same ray transform: the closest hit is the least (t, object, triangle). Through alpha,
//! each instance reads its own scene ([`InstanceAlpha`]); a filter hears which instance it is
//! in ([`crate::trace::HitFilter::enter_instance`]). A deforming mesh's tree is refit rather
//! than rebuilt while it keeps its quality ([`REFIT_LIMIT`]). A light's SRDH tree over the
//! instances ([`SrdhTop`]) takes the top level's place for its shadow rays. Shadow rays walk the
//! top level in its own order ([`TopOrdered`]; the per-tree and sorted orders of [`TopOrders`]),
//! closest hits near child first.

mod alpha;
pub mod brute;
mod instance;
mod mesh_tree;
mod refit;
mod run_boxes;
mod run_walk;
mod runs;
mod srdh_top;
mod top_level;
mod top_ordered;
mod top_orders;

pub use alpha::InstanceAlpha;
pub use instance::{instance_box, render_from_mesh, Instance};
pub use mesh_tree::MeshTree;
pub use refit::REFIT_LIMIT;
pub use srdh_top::{SrdhTop, SrdhTwoLevel};
pub use top_level::{TopLevel, TwoLevel};
pub use top_ordered::TopOrdered;
pub use top_orders::TopOrders;

/// The object an instance of a group tree names ([`MeshTree::of_set`]): each of the group's
/// triangles names its own ([`MeshTree::objects`]), and hits in it carry this.
pub const GROUP: u32 = u32::MAX;
