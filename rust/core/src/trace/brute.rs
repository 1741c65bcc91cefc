use glam::Vec3;

use super::Hit;
use crate::alpha::AlphaScene;
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

/// Every hit of the ray in (t_min, t_max]: (t, triangle id, barycentrics), sorted by (t, id).
fn brute_all_hits(triangles: &[[Vec3; 3]], ray: &Ray) -> Vec<(f32, u32, [f32; 3])> {
    let wt = WatertightRay::new(ray);
    let mut hits: Vec<_> = triangles
        .iter()
        .enumerate()
        .filter_map(|(id, t)| {
            let h = intersect_triangle(&wt, t, ray.t_min, ray.t_max)?;
            Some((h.t, id as u32, [h.b0, h.b1, h.b2]))
        })
        .collect();
    hits.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    hits
}

/// The reference transmission (see [`super::AlphaQuery::transmission`]), from every hit: 0 when
/// one is opaque (unflagged, or alpha 1) or more than `max_hits` are transparent, else the
/// product of (1 - alpha) in (t, id) order.
pub fn brute_transmission(
    triangles: &[[Vec3; 3]],
    ray: &Ray,
    alpha: &AlphaScene,
    max_hits: u32,
) -> f32 {
    let hits = brute_all_hits(triangles, ray);
    transmission_of_hits(hits.iter().map(|&(_, id, b)| alpha.alpha(id, b)), max_hits)
}

/// The transmission of a ray's hits in order, each given as its alpha (`None`: unflagged):
/// 0 when one is opaque or more than `max_hits` are transparent, else the product of
/// (1 - alpha) in that order.
pub fn transmission_of_hits(alphas: impl IntoIterator<Item = Option<f32>>, max_hits: u32) -> f32 {
    let mut product = 1.0f32;
    let mut transparent = 0u32;
    for alpha in alphas {
        match alpha {
            Some(a) if a < 1.0 => {
                transparent += 1;
                product *= 1.0 - a;
            }
            _ => return 0.0,
        }
    }
    if transparent > max_hits {
        0.0
    } else {
        product
    }
}

/// The reference closest hit past transparent hits (see
/// [`super::AlphaQuery::closest_hit_alpha`]): the first hit in (t, id) order that is unflagged
/// or has alpha >= `clip`.
pub fn brute_closest_hit_alpha(
    triangles: &[[Vec3; 3]],
    ray: &Ray,
    alpha: &AlphaScene,
    clip: f32,
) -> Option<Hit> {
    brute_all_hits(triangles, ray)
        .into_iter()
        .find(|&(_, id, b)| alpha.alpha(id, b).is_none_or(|a| a >= clip))
        .map(|(t, id, b)| Hit {
            t,
            triangle: id,
            instance: 0,
            b0: b[0],
            b1: b[1],
            b2: b[2],
        })
}
