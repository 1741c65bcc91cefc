//! The two-level reference: every triangle of every instance, through the same ray transform
//! the traversal uses; the closest hit is the least (t, object, triangle).

use super::top_level::closer;
use super::{Instance, MeshTree};
use crate::geometry::{intersect_triangle, Ray, WatertightRay};
use crate::trace::{transmission_of_hits, AlphaScenes, Hit};

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

/// Every hit of every instance in (t_min, t_max] as a [`Hit`], sorted by (t, object, triangle).
fn all_hits(instances: &[Instance], meshes: &[MeshTree], ray: &Ray) -> Vec<Hit> {
    let mut hits = Vec::new();
    for instance in instances {
        let wt = WatertightRay::new(&instance.ray_to_mesh(ray));
        let mesh = &meshes[instance.mesh as usize];
        for (id, tri) in mesh.triangles.iter().enumerate() {
            if let Some(h) = intersect_triangle(&wt, tri, ray.t_min, ray.t_max) {
                hits.push(Hit {
                    t: h.t,
                    triangle: id as u32,
                    instance: instance.object,
                    b0: h.b0,
                    b1: h.b1,
                    b2: h.b2,
                });
            }
        }
    }
    hits.sort_by(|a, b| {
        (a.t.total_cmp(&b.t)).then((a.instance, a.triangle).cmp(&(b.instance, b.triangle)))
    });
    hits
}

/// The alpha at a hit, from its instance's scene (`None`: unflagged).
fn alpha_at(alpha: &impl AlphaScenes, h: &Hit) -> Option<f32> {
    (alpha.for_instance(h.instance)).alpha(h.triangle, [h.b0, h.b1, h.b2])
}

/// The reference transmission through alpha (see [`crate::trace::AlphaQuery::transmission`]):
/// the hits of every instance in (t, object, triangle) order, each read in its instance's
/// scene.
pub fn brute_transmission(
    instances: &[Instance],
    meshes: &[MeshTree],
    ray: &Ray,
    alpha: &impl AlphaScenes,
    max_hits: u32,
) -> f32 {
    let hits = all_hits(instances, meshes, ray);
    transmission_of_hits(hits.iter().map(|h| alpha_at(alpha, h)), max_hits)
}

/// The reference closest hit past transparent hits: the first hit in (t, object, triangle)
/// order that is unflagged or has alpha >= `clip`.
pub fn brute_closest_hit_alpha(
    instances: &[Instance],
    meshes: &[MeshTree],
    ray: &Ray,
    alpha: &impl AlphaScenes,
    clip: f32,
) -> Option<Hit> {
    (all_hits(instances, meshes, ray).into_iter())
        .find(|h| alpha_at(alpha, h).is_none_or(|a| a >= clip))
}
