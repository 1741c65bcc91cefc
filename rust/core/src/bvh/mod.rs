//! Bounding volume hierarchies as data: the flat binary node layout every traverser reads, the
//! N-wide layout of the SIMD traversal, the SIMD rows of their triangles, and their refit over
//! moved triangles. The builders that make them are in [`crate::build`]; nothing here depends
//! on building, tracing or rendering.

mod node;
mod refit;
mod triangle_rows;
mod wide;

pub(crate) use node::zeroed_vec;
pub use node::{Bvh, BvhNode, NodeArray, MAX_DEPTH};
pub use triangle_rows::TriangleRows;
pub use wide::{BvhWidth, WideBvh, WideNode, EMPTY_CHILD};
