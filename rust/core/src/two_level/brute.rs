//! The two-level reference: every triangle of every instance, through the same ray transform
//! the traversal uses; the closest hit is the least (t, object, triangle).

use super::top_level::closer;
use super::{Instance, MeshTree};
use crate::geometry::{intersect_triangle, Ray, WatertightRay};
use crate::trace::Hit;

pub fn brute_closest_hit(instances: &[Instance], meshes: &[MeshTree], ray: &Ray) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for instance in instances {
        let local = instance.ray_to_mesh(ray);
        let wt = WatertightRay::new(&local);
        let mesh = &meshes[instance.mesh as usize];
        for (id, tri) in mesh.triangles.iter().enumerate() {
            let t_max = best.map_or(ray.t_max, |b| b.t);
            if let Some(h) = intersect_triangle(&wt, tri, ray.t_min, t_max) {
                let hit = Hit {
                    t: h.t,
                    triangle: id as u32,
                    instance: instance.object,
                    b0: h.b0,
                    b1: h.b1,
                    b2: h.b2,
                };
                if closer(&hit, &best) {
                    best = Some(hit);
                }
            }
        }
    }
    best
}

pub fn brute_occluded(instances: &[Instance], meshes: &[MeshTree], ray: &Ray) -> bool {
    instances.iter().any(|instance| {
        let local = instance.ray_to_mesh(ray);
        let wt = WatertightRay::new(&local);
        meshes[instance.mesh as usize]
            .triangles
            .iter()
            .any(|t| intersect_triangle(&wt, t, ray.t_min, ray.t_max).is_some())
    })
}
