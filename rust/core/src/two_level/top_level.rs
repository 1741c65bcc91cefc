use crate::build::{
    build_over_boxes, BuildSettings, CollapseCost, CollapseMethod, CollapseSettings,
};
use crate::bvh::WideBvh;
use crate::geometry::{Aabb, Ray};
use crate::order::OrderView;
use crate::trace::wide::{walk_near_first, BoxKernel};
use crate::trace::{AlphaQuery, Counters, Hit, HitFilter, RayQuery};

use super::Instance;

/// Children of a top-level node: one SIMD box test reads all eight.
pub(super) const TOP_WIDTH: usize = 8;

/// What entering an instance costs the top level's SAH build, in triangle tests: a ray
/// transform and its mesh tree's root, against a cheap slot of a wide node's SIMD test. At 2
/// the build makes mostly one-instance leaves: two-level trace about 10% faster on the
/// instanced forest than at 1 (the mesh trees' cost, leaves of two instances on average), at
/// 99.5 bytes an instance over a million instances (79.3 at 1, 103.2 at 4).
pub(super) const INSTANCE_COST: f32 = 2.0;

/// The top level's build settings from the mesh trees': an instance costs [`INSTANCE_COST`]
/// triangle tests.
pub(super) fn top_settings(settings: &BuildSettings) -> BuildSettings {
    BuildSettings {
        intersection_cost: INSTANCE_COST * settings.intersection_cost,
        ..*settings
    }
}

/// The top level's collapse: the binary build's leaves stay leaves (it already weighed an
/// instance's cost against a node's), the SAH collapse only picks which nodes fill the slots.
const TOP_COLLAPSE: CollapseSettings = CollapseSettings {
    method: CollapseMethod::Sah,
    cost: CollapseCost {
        node: 1.0,
        triangle: 1.0,
        lanes: 1,
        max_leaf: 1,
    },
};

/// The top-level tree: the binary SAH tree over the instances' render-space boxes collapsed
/// 8-wide, with the instances stored in its leaf order (a leaf slot's instances are adjacent
/// in memory; a leaf slot's range indexes `instances`).
#[derive(Clone, Debug, Default)]
pub struct TopLevel {
    /// The wide nodes; it holds no triangles (`triangles` and the ids are empty).
    pub bvh: WideBvh<TOP_WIDTH>,
    /// In leaf order: a leaf's range indexes this array.
    pub instances: Vec<Instance>,
}

impl TopLevel {
    /// `boxes[i]` is the render-space box of `instances[i]` ([`super::instance_box`]). Both are
    /// taken by value: the boxes are dropped once the binary tree is built, and the instances
    /// put in leaf order in place (a million instances hold 56 MB; a reordered copy would be
    /// another 56 MB at the build's peak).
    pub fn build(mut instances: Vec<Instance>, boxes: Vec<Aabb>, settings: &BuildSettings) -> Self {
        debug_assert_eq!(instances.len(), boxes.len());
        let binary = build_over_boxes(&boxes, &top_settings(settings));
        drop(boxes);
        leaf_order(&mut instances, &binary.triangle_ids);
        let mut bvh = WideBvh::collapse_with(&binary, &TOP_COLLAPSE);
        // The instances are in leaf order and name their object: the ids would be 4 bytes an
        // instance of nothing, and only per-light sorting reads the parent and depth tables.
        bvh.triangle_ids = Vec::new();
        bvh.parent = Vec::new();
        bvh.depth = Vec::new();
        TopLevel { bvh, instances }
    }

    pub fn len(&self) -> usize {
        self.instances.len()
    }

    pub fn is_empty(&self) -> bool {
        self.instances.is_empty()
    }

    /// Bytes held: the nodes and the instances.
    pub fn bytes(&self) -> usize {
        self.bvh.bytes() + self.instances.len() * std::mem::size_of::<Instance>()
    }
}

/// Puts `instances` in a build's leaf order in place: `instances[k]` becomes the old
/// `instances[ids[k]]`, each cycle of the permutation followed once. A build over boxes makes
/// one reference per box, so `ids` is a permutation; were it not, the instances are copied.
fn leaf_order(instances: &mut Vec<Instance>, ids: &[u32]) {
    let n = instances.len();
    let mut seen = vec![false; n];
    let permutation = ids.len() == n
        && ids
            .iter()
            .all(|&i| (i as usize) < n && !std::mem::replace(&mut seen[i as usize], true));
    if !permutation {
        *instances = ids.iter().map(|&i| instances[i as usize]).collect();
        return;
    }
    let mut done = seen;
    done.fill(false);
    for start in 0..n {
        if done[start] {
            continue;
        }
        let first = instances[start];
        let mut k = start;
        loop {
            done[k] = true;
            let from = ids[k] as usize;
            if from == start {
                instances[k] = first;
                break;
            }
            instances[k] = instances[from];
            k = from;
        }
    }
}

/// The two levels as one query: the top level, and the mesh trees its instances name, each
/// traced by its own query `Q` (any layout, order and kernel; its batch methods see each
/// instance's rays of a run together). A mesh tree's work counts into the ray's counters as its
/// own traversal counts it; the top level counts as the wide trees do (the root box, then per
/// node entered one interior node and a box test per used slot, per leaf slot entered one
/// leaf), per ray in batches too (see `runs`).
#[derive(Clone, Copy)]
pub struct TwoLevel<'a, Q> {
    pub top: &'a TopLevel,
    /// By mesh index ([`Instance::mesh`]).
    pub meshes: &'a [Q],
}

impl<Q> TwoLevel<'_, Q> {
    /// Walks the top level near child first with the SIMD child-box kernels
    /// ([`walk_near_first`]), handing each entered leaf's range of instances (`first`,
    /// `count`) to `leaf` with the ray's current `t_max`; `leaf` returns the new `t_max`
    /// (lowered by a closest hit), or `None` to stop (an any-hit query answered).
    #[inline]
    pub(super) fn walk<C: Counters>(
        &self,
        ray: &Ray,
        stats: &mut C,
        leaf: impl FnMut(usize, usize, f32, &mut C) -> Option<f32>,
    ) {
        walk_near_first(&self.top.bvh, ray, BoxKernel::Auto, stats, leaf);
    }

    /// [`Self::walk`] handing each instance of an entered leaf to `visit` with its mesh query
    /// and the ray's current `t_max`.
    #[inline]
    pub(super) fn walk_instances<C: Counters>(
        &self,
        ray: &Ray,
        stats: &mut C,
        mut visit: impl FnMut(&Instance, &Q, f32, &mut C) -> Option<f32>,
    ) {
        self.walk(ray, stats, |first, count, mut t_max, stats| {
            for instance in &self.top.instances[first..first + count] {
                t_max = visit(instance, &self.meshes[instance.mesh as usize], t_max, stats)?;
            }
            Some(t_max)
        });
    }
}

/// The closest of two hits by (t, object, triangle): the order the brute-force reference
/// keeps, whatever order the top level visits instances in.
#[inline(always)]
pub(super) fn closer(h: &Hit, best: &Option<Hit>) -> bool {
    match best {
        None => true,
        Some(b) => h.t < b.t || (h.t == b.t && (h.instance, h.triangle) < (b.instance, b.triangle)),
    }
}

impl<Q: RayQuery> RayQuery for TwoLevel<'_, Q> {
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        let mut hit = false;
        self.walk_instances(ray, stats, |instance, mesh, t_max, stats| {
            if mesh.occluded(&instance.ray_to_mesh(ray), stats) {
                hit = true;
                None
            } else {
                Some(t_max)
            }
        });
        hit
    }

    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        self.walk_instances(ray, stats, |instance, mesh, t_max, stats| {
            let local = Ray {
                t_max,
                ..instance.ray_to_mesh(ray)
            };
            if let Some(mut h) = mesh.closest_hit(&local, stats) {
                h.instance = instance.object;
                if closer(&h, &best) {
                    best = Some(h);
                }
            }
            Some(best.map_or(t_max, |b| b.t))
        });
        best
    }

    /// In runs of 16 neighbouring rays through the top level, each instance's rays traced as
    /// one batch of its mesh query (see `runs`): the answers of [`Self::occluded`].
    #[inline]
    fn occluded_batch<C: Counters>(&self, rays: &[Ray], out: &mut [bool], counters: &mut [C]) {
        super::runs::occluded_runs(self, OrderView::FrontToBack, rays, out, counters);
    }

    /// In runs, as [`Self::occluded_batch`]: the answers of [`Self::closest_hit`].
    #[inline]
    fn closest_hit_batch<C: Counters>(
        &self,
        rays: &[Ray],
        out: &mut [Option<Hit>],
        counters: &mut [C],
    ) {
        super::runs::closest_runs(self, rays, out, counters);
    }
}

/// Through alpha: the filter enters each instance before its mesh tree's hits (its scene and
/// its ids), and its hits carry the object as the opaque queries' do. Alpha batches stay one
/// ray at a time (the trait's default `transmission_batch`): a filter follows one ray's hits.
impl<Q: AlphaQuery> AlphaQuery for TwoLevel<'_, Q> {
    #[inline]
    fn stopped<C: Counters, F: HitFilter>(&self, ray: &Ray, filter: &mut F, stats: &mut C) -> bool {
        let mut stopped = false;
        self.walk_instances(ray, stats, |instance, mesh, t_max, stats| {
            filter.enter_instance(instance.object);
            if mesh.stopped(&instance.ray_to_mesh(ray), filter, stats) {
                stopped = true;
                None
            } else {
                Some(t_max)
            }
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
        let mut best: Option<Hit> = None;
        self.walk_instances(ray, stats, |instance, mesh, t_max, stats| {
            let local = Ray {
                t_max,
                ..instance.ray_to_mesh(ray)
            };
            filter.enter_instance(instance.object);
            if let Some(mut h) = mesh.closest_hit_filtered(&local, filter, stats) {
                h.instance = instance.object;
                if closer(&h, &best) {
                    best = Some(h);
                }
            }
            Some(best.map_or(t_max, |b| b.t))
        });
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DAffine3;

    fn instances(n: u32) -> Vec<Instance> {
        (0..n)
            .map(|i| Instance::new(&DAffine3::IDENTITY, i % 3, i).unwrap())
            .collect()
    }

    #[test]
    fn leaf_order_in_place_is_the_copy_through_the_ids() {
        for n in [0u32, 1, 2, 7, 100] {
            // A permutation of several cycles (a stride through 0..n) and the identity.
            let stride = (1..=n.max(1))
                .rev()
                .find(|s| gcd(*s, n.max(1)) == 1)
                .unwrap_or(1);
            for ids in [
                (0..n)
                    .map(|k| (k * stride) % n.max(1))
                    .collect::<Vec<u32>>(),
                (0..n).collect(),
                (0..n).rev().collect(),
            ] {
                let before = instances(n);
                let copied: Vec<u32> = ids.iter().map(|&i| before[i as usize].object).collect();
                let mut placed = before.clone();
                leaf_order(&mut placed, &ids);
                let objects: Vec<u32> = placed.iter().map(|i| i.object).collect();
                assert_eq!(objects, copied, "n = {n}, ids = {ids:?}");
            }
        }
        // Ids that are no permutation are copied through as they are.
        let mut placed = instances(3);
        leaf_order(&mut placed, &[2, 2, 0]);
        let objects: Vec<u32> = placed.iter().map(|i| i.object).collect();
        assert_eq!(objects, [2, 2, 0]);
    }

    fn gcd(a: u32, b: u32) -> u32 {
        if b == 0 {
            a
        } else {
            gcd(b, a % b)
        }
    }
}
