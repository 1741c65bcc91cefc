//! Representative shadow rays with every triangle each one intersects within its segment (the
//! paper's H function), stored sparsely: one list of triangle ids per ray, in one flat array.

use rayon::prelude::*;

use crate::bvh::{Bvh, MAX_DEPTH};
use crate::geometry::{intersect_triangle, Ray, RayBoxPrecomp, WatertightRay};

/// Rays and their full intersection lists (triangle ids of the set the BVH was built from,
/// sorted, without duplicates). An empty list is an unoccluded ray.
#[derive(Clone, Debug, Default)]
pub struct RaySet {
    pub rays: Vec<Ray>,
    /// Ray i's hits are `hits[offsets[i]..offsets[i + 1]]`.
    offsets: Vec<u32>,
    hits: Vec<u32>,
    /// Wall-clock time of tracing the lists, in milliseconds.
    pub trace_ms: f64,
}

impl RaySet {
    /// Traces every ray through `bvh` (any complete tree over the triangles) for all its hits.
    pub fn trace(bvh: &Bvh, rays: Vec<Ray>) -> Self {
        let start = std::time::Instant::now();
        let lists: Vec<Vec<u32>> = rays
            .par_iter()
            .map(|r| {
                let mut out = Vec::new();
                all_hits(bvh, r, &mut out);
                out
            })
            .collect();
        let mut set = Self::from_lists(rays, lists);
        set.trace_ms = start.elapsed().as_secs_f64() * 1e3;
        set
    }

    /// A set from given hit lists (sorted and deduplicated here).
    pub fn from_lists(rays: Vec<Ray>, lists: Vec<Vec<u32>>) -> Self {
        assert_eq!(rays.len(), lists.len(), "one hit list per ray");
        let mut offsets = Vec::with_capacity(rays.len() + 1);
        let mut hits = Vec::new();
        offsets.push(0);
        for mut l in lists {
            l.sort_unstable();
            l.dedup();
            hits.extend_from_slice(&l);
            offsets.push(hits.len() as u32);
        }
        RaySet {
            rays,
            offsets,
            hits,
            trace_ms: 0.0,
        }
    }

    pub fn len(&self) -> usize {
        self.rays.len()
    }
    pub fn is_empty(&self) -> bool {
        self.rays.is_empty()
    }
    /// The triangles ray `i` intersects.
    #[inline]
    pub fn hits(&self, i: usize) -> &[u32] {
        &self.hits[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }
    pub fn hit_count(&self) -> usize {
        self.hits.len()
    }
    pub fn occluded_count(&self) -> usize {
        (0..self.len())
            .filter(|&i| !self.hits(i).is_empty())
            .count()
    }
    /// Share of occluded rays (0 for an empty set).
    pub fn occluded_fraction(&self) -> f64 {
        self.occluded_count() as f64 / self.len().max(1) as f64
    }
    pub fn bytes(&self) -> usize {
        self.rays.len() * std::mem::size_of::<Ray>() + (self.offsets.len() + self.hits.len()) * 4
    }
}

/// Appends the id of every triangle `ray` intersects in (t_min, t_max] (duplicated references
/// may append an id twice).
pub fn all_hits(bvh: &Bvh, ray: &Ray, out: &mut Vec<u32>) {
    let nodes = &bvh.nodes;
    if nodes.is_empty() {
        return;
    }
    let pre = RayBoxPrecomp::new(ray);
    let wt = WatertightRay::new(ray);
    let t_box = ray.t_max + pre.t_margin;
    let mut stack = [0u32; MAX_DEPTH + 2];
    let mut sp = 1usize;
    while sp > 0 {
        sp -= 1;
        let node = &nodes[stack[sp] as usize];
        if pre.hit_packed(node.packed(), ray.t_min, t_box).is_none() {
            continue;
        }
        if node.is_leaf() {
            let first = node.first as usize;
            for slot in first..first + node.count as usize {
                if intersect_triangle(&wt, &bvh.triangles[slot], ray.t_min, ray.t_max).is_some() {
                    out.push(bvh.triangle_ids[slot]);
                }
            }
        } else {
            stack[sp] = node.first;
            stack[sp + 1] = node.first + 1;
            sp += 2;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build::{build_binned_sah, BuildSettings};
    use glam::Vec3;

    #[test]
    fn lists_match_every_triangle_test() {
        // A stack of parallel quads along z: a ray through all of them hits each once.
        let mut tris = Vec::new();
        for k in 0..20 {
            let z = k as f32 * 0.1;
            let (a, b, c, d) = (
                Vec3::new(-1.0, -1.0, z),
                Vec3::new(1.0, -1.0, z),
                Vec3::new(1.0, 1.0, z),
                Vec3::new(-1.0, 1.0, z),
            );
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
        let bvh = build_binned_sah(&tris, &BuildSettings::default());
        let rays = vec![
            Ray::new(Vec3::new(0.3, 0.2, -1.0), Vec3::Z, 0.0, 1.05),
            Ray::new(Vec3::new(0.3, 0.2, -1.0), -Vec3::Z, 0.0, 10.0),
        ];
        let set = RaySet::trace(&bvh, rays.clone());
        for (i, r) in rays.iter().enumerate() {
            let wt = WatertightRay::new(r);
            let expect: Vec<u32> = (0..tris.len() as u32)
                .filter(|&t| intersect_triangle(&wt, &tris[t as usize], r.t_min, r.t_max).is_some())
                .collect();
            assert_eq!(set.hits(i), &expect[..]);
        }
        assert_eq!(set.hits(0).len(), 1);
        assert_eq!(set.occluded_count(), 1);
    }
}
