//! [`TopOrdered`]: the two levels with the top level's children in an order for any-hit rays
//! (a static permutation of its wide nodes, or one sorted for a light), as a flat wide tree's
//! occlusion follows its order. Closest hits keep front to back: a near-first walk lowers
//! `t_max` early and culls, which no occlusion order can.

use crate::geometry::Ray;
use crate::order::OrderView;
use crate::trace::wide::{walk_in_order, BoxKernel};
use crate::trace::{AlphaQuery, Counters, Hit, HitFilter, NoStats, RayQuery};

use super::{Instance, TwoLevel};

/// The two levels whose any-hit walks enter each top-level node's children in `order`
/// (`OrderView::FrontToBack`: the near-first walk itself, with its counts).
#[derive(Clone, Copy)]
pub struct TopOrdered<'a, Q> {
    pub levels: TwoLevel<'a, Q>,
    pub order: OrderView<'a>,
}

impl<Q> TopOrdered<'_, Q> {
    /// Walks the top level for an any-hit query in the order, handing each instance of an
    /// entered leaf to `visit` with its index in the top level's instances and its mesh query;
    /// `visit` returns true to stop (the ray answered).
    #[inline]
    fn walk_any<C: Counters>(
        &self,
        ray: &Ray,
        stats: &mut C,
        mut visit: impl FnMut(usize, &Instance, &Q, &mut C) -> bool,
    ) {
        let TwoLevel { top, meshes } = self.levels;
        let mut leaf = |first: usize, count: usize, stats: &mut C| {
            let range = first..first + count;
            (range.clone().zip(&top.instances[range]))
                .any(|(i, instance)| visit(i, instance, &meshes[instance.mesh as usize], stats))
        };
        match self.order {
            // Today's walk (and counts) for front to back.
            OrderView::FrontToBack => self.levels.walk(ray, stats, |first, count, t_max, stats| {
                (!leaf(first, count, stats)).then_some(t_max)
            }),
            order => walk_in_order(&top.bvh, ray, BoxKernel::Auto, &order, stats, leaf),
        }
    }

    /// The first instance, in the order, whose mesh-space ray `stops` answers: its index in
    /// the top level's instances, its mesh index and the answer. The logging pass of per-light
    /// sorting through both levels: the instance sorts the top level, the answer (traced in the
    /// mesh tree's logging order) the mesh tree.
    pub fn first_stopper<T>(
        &self,
        ray: &Ray,
        mut stops: impl FnMut(&Q, &Ray) -> Option<T>,
    ) -> Option<(u32, u32, T)> {
        let mut found = None;
        self.walk_any(ray, &mut NoStats, |index, instance, mesh, _| {
            found = stops(mesh, &instance.ray_to_mesh(ray))
                .map(|answer| (index as u32, instance.mesh, answer));
            found.is_some()
        });
        found
    }
}

impl<Q: RayQuery> RayQuery for TopOrdered<'_, Q> {
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        let mut hit = false;
        self.walk_any(ray, stats, |_, instance, mesh, stats| {
            hit = mesh.occluded(&instance.ray_to_mesh(ray), stats);
            hit
        });
        hit
    }

    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        self.levels.closest_hit(ray, stats)
    }

    /// In runs of 16 rays (see `runs`), each run's walk in the order.
    #[inline]
    fn occluded_batch<C: Counters>(&self, rays: &[Ray], out: &mut [bool], counters: &mut [C]) {
        super::runs::occluded_runs(&self.levels, self.order, rays, out, counters);
    }

    #[inline]
    fn closest_hit_batch<C: Counters>(
        &self,
        rays: &[Ray],
        out: &mut [Option<Hit>],
        counters: &mut [C],
    ) {
        self.levels.closest_hit_batch(rays, out, counters);
    }
}

/// Through alpha: transmission follows the order too (its value multiplies the hits in
/// (t, instance, triangle) order, whatever order found them); closest hits front to back.
impl<Q: AlphaQuery> AlphaQuery for TopOrdered<'_, Q> {
    #[inline]
    fn stopped<C: Counters, F: HitFilter>(&self, ray: &Ray, filter: &mut F, stats: &mut C) -> bool {
        let mut stopped = false;
        self.walk_any(ray, stats, |_, instance, mesh, stats| {
            filter.enter_instance(instance.object);
            stopped = mesh.stopped(&instance.ray_to_mesh(ray), filter, stats);
            stopped
        });
        stopped
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
