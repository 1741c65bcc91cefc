use glam::Vec3;

use super::Hit;
use crate::geometry::{intersect_triangle, Ray, WatertightRay};

/// The reference: tests every triangle. Same triangle test and tie rule as the BVH queries.
pub fn brute_closest_hit(triangles: &[[Vec3; 3]], ray: &Ray) -> Option<Hit> {
    let wt = WatertightRay::new(ray);
    let mut best: Option<Hit> = None;
    for (id, tri) in triangles.iter().enumerate() {
        let t_max = best.map_or(ray.t_max, |b| b.t);
        if let Some(h) = intersect_triangle(&wt, tri, ray.t_min, t_max) {
            if Hit::closer_than(h.t, id as u32, &best) {
                best = Some(Hit {
                    t: h.t,
                    triangle: id as u32,
                    instance: 0,
                    b0: h.b0,
                    b1: h.b1,
                    b2: h.b2,
                });
            }
        }
    }
    best
}

/// The reference occlusion query.
pub fn brute_occluded(triangles: &[[Vec3; 3]], ray: &Ray) -> bool {
    let wt = WatertightRay::new(ray);
    triangles
        .iter()
        .any(|t| intersect_triangle(&wt, t, ray.t_min, ray.t_max).is_some())
}
