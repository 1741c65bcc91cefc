//! antumbra's ray queries for a caller's own triangles and rays: a benchmark harness tracing
//! Embree's ray files, a mesh tool, the Python package's `antumbra.rays`.
//!
//! ```
//! use antumbra_rays::{BuildOptions, Ray, Scene, TraceOptions};
//!
//! let vertices = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
//! let scene = Scene::build(&vertices, &[[0, 1, 2]], &BuildOptions::default())?;
//! let rays = [Ray::new([0.25, 0.25, 1.0], [0.0, 0.0, -1.0])];
//! let hits = scene.intersect(&rays, &TraceOptions::default())?;
//! let hit = hits[0].expect("the ray crosses the triangle");
//! assert_eq!((hit.t, hit.triangle, hit.u, hit.v), (1.0, 0, 0.25, 0.25));
//! assert_eq!(scene.occluded(&rays, &TraceOptions::default())?, [true]);
//! # Ok::<(), antumbra_core::Error>(())
//! ```
//!
//! - **Build** ([`Scene::build`], [`BuildOptions`]): any of antumbra's builders (SAH, SBVH, ABVH,
//!   OSAH, VSAH) at width 2, 4 or 8, over f32 or f64 vertices, on a pool of `threads`.
//! - **Trace** ([`Scene::intersect`], [`Scene::occluded`], [`TraceOptions`]): a batch of rays in,
//!   one answer per ray out, on a pool of `threads`; the `_counted` forms also give each ray's
//!   [`TraversalStats`] (N_B, N_L, N_T, N_box as the renderer counts them). Any-hit queries take
//!   a child order, the sorted order prepared from a sample of the batch; wide trees take a box
//!   kernel. Answers never depend on the order, the kernel or the thread count.
//! - **Normalisation, inside**: the vertices are re-centred on their bounds and scaled by a power
//!   of two in f64 before rounding to f32, as the renderer's `FrameGeometry` does, so a mesh
//!   1e6 units from the origin or a millimetre wide traces as well as one around the origin; the
//!   traversals' margins assume this space. Rays move in by the same map, the direction scaled
//!   by the same power of two (exact), so t needs no map back: a hit's t is the parameter along
//!   the caller's own direction.
//! - **The t interval**: `(t_near, t_far]` by default ([`Interval::OpenClosed`], the renderer's);
//!   [`Interval::Closed`] is Embree's `[t_near, t_far]`.
//! - **Ties**: closest hits equally far go to the smaller triangle index; a ray through an edge
//!   or vertex shared by triangles hits at least one of them (the watertight test).
//! - **Errors, not panics**: non-finite vertices or rays, zero directions, indices out of range,
//!   options out of range come back as an [`antumbra_core::Error`] naming the item.
//!
//! This crate takes antumbra-core without its `files` feature: no image, EXR or CSV crate.

mod batch;
mod options;
mod ray;
mod scene;
mod space;

pub use antumbra_core::build::{BuildMethod, BuildSettings, CollapseMethod, CollapseSettings};
pub use antumbra_core::bvh::BvhWidth;
pub use antumbra_core::order::ShadowOrder;
pub use antumbra_core::trace::wide::BoxKernel;
pub use antumbra_core::trace::TraversalStats;
pub use antumbra_core::{Error, Result};
pub use options::{BuildOptions, TraceOptions, MAX_THREADS};
pub use ray::{Hit, Interval, Ray};
pub use scene::Scene;
pub use space::Point;
