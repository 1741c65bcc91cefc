//! SRDH on two levels: one light's SRDH tree over a top level's instances ([`SrdhTop`]). Its
//! primitives are the instances' render-space boxes; a representative ray's hit list is every
//! instance in whose mesh tree the ray has a hit ([`TwoLevel::occluding_instances`]); a child
//! costs its count of instances (each a ray transform and a mesh tree's traversal, whatever
//! the tree). The light's shadow rays follow the tree's kernels to the instances and trace each
//! instance's mesh tree as the frame's mesh trees are traced (front to back); the mesh trees
//! are not rebuilt per light. A ray counts the SRDH tree's nodes as a binary tree's (one
//! interior node per node entered, the box tests made, a leaf per leaf entered), then what its
//! mesh trees count.

use rayon::prelude::*;

use super::top_level::TwoLevel;
use crate::build::BuildSettings;
use crate::geometry::{Aabb, Ray};
use crate::order::SrdhSettings;
use crate::srdh::{build_srdh_over_boxes, RaySet, SrdhBvh};
use crate::trace::{any_hit_walk, AlphaQuery, Counters, Hit, HitFilter, NoStats, RayQuery};

/// One light's SRDH tree over the instances of the top level it was built from: its leaves'
/// ranges index `tree.bvh.triangle_ids`, which hold indices into that top level's instances.
#[derive(Clone, Debug, Default)]
pub struct SrdhTop {
    pub tree: SrdhBvh,
}

impl SrdhTop {
    /// The tree over `boxes` (`boxes[i]` bounds instance `i` of the top level in render space)
    /// for `set`, whose hit lists name instances ([`TwoLevel::occluding_instances`]).
    /// Its SAH subtrees (where no representative ray reaches) weigh an instance as the top
    /// level's build does.
    pub fn build(
        boxes: Vec<Aabb>,
        set: &RaySet,
        settings: &SrdhSettings,
        sah: &BuildSettings,
    ) -> Self {
        SrdhTop {
            tree: build_srdh_over_boxes(boxes, set, settings, &super::top_level::top_settings(sah)),
        }
    }
}

impl<Q: RayQuery + Sync> TwoLevel<'_, Q> {
    /// The ray's hit list over instances: the index (in the top level's instances) of every
    /// instance whose mesh tree the ray hits in (t_min, t_max], in the walk's order
    /// ([`RaySet::from_lists`] sorts them).
    pub fn occluding_instances(&self, ray: &Ray, out: &mut Vec<u32>) {
        let base = self.top.instances.as_ptr() as usize;
        self.walk_instances(ray, &mut NoStats, |instance, mesh, t_max, stats| {
            if mesh.occluded(&instance.ray_to_mesh(ray), stats) {
                let index = (instance as *const _ as usize - base) / size_of_val(instance);
                out.push(index as u32);
            }
            Some(t_max)
        });
    }

    /// The hit lists of `rays` over instances, in parallel: the ray set an [`SrdhTop`] is
    /// built from.
    pub fn instance_ray_set(&self, rays: Vec<Ray>) -> RaySet {
        let start = std::time::Instant::now();
        let lists: Vec<Vec<u32>> = rays
            .par_iter()
            .with_min_len(64)
            .map(|r| {
                let mut out = Vec::new();
                self.occluding_instances(r, &mut out);
                out
            })
            .collect();
        let mut set = RaySet::from_lists(rays, lists);
        set.trace_ms = start.elapsed().as_secs_f64() * 1e3;
        set
    }
}

/// The two levels with a light's SRDH tree in place of the top level for any-hit queries:
/// what a light's shadow rays trace with `srdh` on two levels. Closest hits (which no kernel
/// serves) walk the top level as [`TwoLevel`] does; the answer is the same.
#[derive(Clone, Copy)]
pub struct SrdhTwoLevel<'a, Q> {
    pub levels: TwoLevel<'a, Q>,
    pub srdh: &'a SrdhTop,
}

impl<Q> SrdhTwoLevel<'_, Q> {
    /// Follows the SRDH tree's kernels; `stops` traces one instance's mesh-space ray.
    #[inline(always)]
    fn any<C: Counters>(
        &self,
        ray: &Ray,
        stats: &mut C,
        mut stops: impl FnMut(&super::Instance, &Q, &Ray, &mut C) -> bool,
    ) -> bool {
        let bvh = &self.srdh.tree.bvh;
        let instances = &self.levels.top.instances;
        any_hit_walk(
            &bvh.nodes,
            &self.srdh.tree.kernels,
            ray,
            stats,
            |leaf, stats| {
                let first = leaf.first as usize;
                bvh.triangle_ids[first..first + leaf.count as usize]
                    .iter()
                    .any(|&i| {
                        let instance = &instances[i as usize];
                        let mesh = &self.levels.meshes[instance.mesh as usize];
                        stops(instance, mesh, &instance.ray_to_mesh(ray), stats)
                    })
            },
        )
        .is_some()
    }
}

/// Any hits follow the kernels, one ray at a time (the trait's default batches), as a flat
/// SRDH tree traces.
impl<Q: RayQuery> RayQuery for SrdhTwoLevel<'_, Q> {
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        self.any(ray, stats, |_, mesh, local, stats| {
            mesh.occluded(local, stats)
        })
    }

    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        self.levels.closest_hit(ray, stats)
    }
}

/// Through alpha: transmission follows the kernels, each instance's hits read its own scene.
impl<Q: AlphaQuery> AlphaQuery for SrdhTwoLevel<'_, Q> {
    #[inline]
    fn stopped<C: Counters, F: HitFilter>(&self, ray: &Ray, filter: &mut F, stats: &mut C) -> bool {
        self.any(ray, stats, |instance, mesh, local, stats| {
            filter.enter_instance(instance.object);
            mesh.stopped(local, filter, stats)
        })
    }

    #[inline]
    fn closest_hit_filtered<C: Counters, F: HitFilter>(
        &self,
        ray: &Ray,
        filter: &mut F,
        stats: &mut C,
    ) -> Option<Hit> {
        self.levels.closest_hit_filtered(ray, filter, stats)
    }
}
