//! Geometry with numerics that hold at the extremes: boxes, rays, the watertight ray/triangle
//! test and the float-error-aware ray-origin offset.

mod aabb;
mod offset;
mod ray;
mod triangle;

pub use aabb::Aabb;
pub use offset::{offset_coordinate, offset_ray_origin};
pub use ray::{Ray, RayBoxPrecomp};
pub use triangle::{intersect_triangle, triangle_normal, TriangleHit, WatertightRay};

/// `gamma(n)` of pbrt (Higham's bound): the relative error of `n` chained f32 operations.
#[inline]
pub const fn gamma(n: i32) -> f32 {
    let eps = f32::EPSILON * 0.5;
    (n as f32 * eps) / (1.0 - n as f32 * eps)
}
