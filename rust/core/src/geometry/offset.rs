//! Shadow-ray origins that neither self-intersect nor leak: Wächter & Binder, "A Fast and Robust
//! Method for Avoiding Self-Intersection" (Ray Tracing Gems, chapter 6).
//!
//! The hit point is moved along the geometric normal by a fixed number of float ulps of each
//! coordinate (so the offset grows with the magnitude of the coordinate, as the rounding error of
//! the hit point does), and by a tiny absolute amount near the origin where ulps vanish. The
//! constants are the chapter's. Because antumbra traces in a render space scaled to about [-1, 1]
//! (see `RenderSpace`), the absolute part is relative to the scene's size, not to its units.

use glam::Vec3;

const ORIGIN: f32 = 1.0 / 32.0;
const FLOAT_SCALE: f32 = 1.0 / 65536.0;
const INT_SCALE: f32 = 256.0;

/// Offsets `p` along `n` (a unit normal pointing to the side the new ray leaves on).
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    Vec3::new(
        offset_coordinate(p.x, n.x),
        offset_coordinate(p.y, n.y),
        offset_coordinate(p.z, n.z),
    )
}

/// One coordinate of [`offset_ray_origin`]: written with selects, so a loop over many points
/// vectorises (render/sample_lanes.rs).
#[inline(always)]
pub fn offset_coordinate(p: f32, n: f32) -> f32 {
    let near = p + FLOAT_SCALE * n;
    let of_i = (INT_SCALE * n) as i32;
    let bits = p.to_bits() as i32;
    let moved = if p < 0.0 {
        bits.wrapping_sub(of_i)
    } else {
        bits.wrapping_add(of_i)
    };
    if p.abs() < ORIGIN {
        near
    } else {
        f32::from_bits(moved as u32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moves_to_the_normal_side_at_every_magnitude() {
        for mag in [0.0f32, 1e-3, 0.5, 1.0, 3.0, 1e3] {
            for s in [-1.0f32, 1.0] {
                let p = Vec3::new(0.3, s * mag, -0.7);
                let q = offset_ray_origin(p, Vec3::Y);
                assert!(q.y > p.y, "{mag} {s}: {} -> {}", p.y, q.y);
                let q = offset_ray_origin(p, Vec3::NEG_Y);
                assert!(q.y < p.y, "{mag} {s}");
                assert_eq!(q.x, p.x);
            }
        }
    }
}
