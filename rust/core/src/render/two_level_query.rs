//! What a two-level pass traces: [`TwoLevelQuery`], the top level (or a light's SRDH tree over
//! its instances) with each mesh tree as one order traces it ([`MeshQuery`]), its batches
//! single rays or runs through instances.

use super::wide_tree::OrderedWideTree;
use crate::geometry::Ray;
use crate::order::OrderView;
use crate::trace::{
    closest_hit_each, forward_alpha_query, forward_ray_query, occluded_each, AlphaQuery, Counters,
    Hit, HitFilter, OrderedBinary, RayMode, RayQuery,
};
use crate::two_level::{SrdhTop, SrdhTwoLevel, TopLevel, TopOrdered, TwoLevel};

/// One mesh tree as a pass traces it.
#[derive(Clone, Copy)]
pub enum MeshQuery<'a> {
    Binary(OrderedBinary<'a>),
    Wide(OrderedWideTree<'a>),
}

macro_rules! with_mesh_query {
    ($q:expr, $m:ident => $f:expr) => {
        match $q {
            MeshQuery::Binary($m) => $f,
            MeshQuery::Wide($m) => $f,
        }
    };
}
forward_ray_query!(MeshQuery<'_>, with_mesh_query);
forward_alpha_query!(MeshQuery<'_>, with_mesh_query);

/// A top level in an order (any hits only; closest hits go near child first) with the frame's
/// mesh trees as one order traces them, and how batches are traced: what a two-level pass
/// traces. In packet mode a batch goes through the top level in
/// runs of neighbouring rays and each instance's rays reach its wide mesh tree as packets (see
/// [`TwoLevel`]'s batch methods); in single mode one ray at a time, as before.
pub struct TwoLevelQuery<'a> {
    pub(super) top: &'a TopLevel,
    pub(super) meshes: Vec<MeshQuery<'a>>,
    /// The order shadow rays walk `top` in.
    pub(super) top_order: OrderView<'a>,
    pub(super) rays: RayMode,
    /// A light's SRDH tree over `top`'s instances: any hits follow it, one ray at a time.
    pub(super) srdh: Option<&'a SrdhTop>,
}

impl TwoLevelQuery<'_> {
    #[inline(always)]
    pub(super) fn levels(&self) -> TwoLevel<'_, MeshQuery<'_>> {
        TwoLevel {
            top: self.top,
            meshes: &self.meshes,
        }
    }

    /// The two levels with the top level in its order, as any hits walk it.
    #[inline(always)]
    fn ordered(&self) -> TopOrdered<'_, MeshQuery<'_>> {
        TopOrdered {
            levels: self.levels(),
            order: self.top_order,
        }
    }

    /// The light's SRDH tree in the top level's place, if it has one.
    #[inline(always)]
    fn srdh(&self) -> Option<SrdhTwoLevel<'_, MeshQuery<'_>>> {
        Some(SrdhTwoLevel {
            levels: self.levels(),
            srdh: self.srdh?,
        })
    }
}

impl RayQuery for TwoLevelQuery<'_> {
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        match self.srdh() {
            Some(s) => s.occluded(ray, stats),
            None => self.ordered().occluded(ray, stats),
        }
    }
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        self.levels().closest_hit(ray, stats)
    }
    #[inline]
    fn occluded_batch<C: Counters>(&self, rays: &[Ray], out: &mut [bool], counters: &mut [C]) {
        if let Some(s) = self.srdh() {
            return occluded_each(&s, rays, out, counters);
        }
        let q = self.ordered();
        match self.rays {
            RayMode::Single => occluded_each(&q, rays, out, counters),
            RayMode::Packet => q.occluded_batch(rays, out, counters),
        }
    }
    #[inline]
    fn closest_hit_batch<C: Counters>(
        &self,
        rays: &[Ray],
        out: &mut [Option<Hit>],
        counters: &mut [C],
    ) {
        let q = self.levels();
        match self.rays {
            RayMode::Single => closest_hit_each(&q, rays, out, counters),
            RayMode::Packet => q.closest_hit_batch(rays, out, counters),
        }
    }
}

/// Through alpha, as [`TwoLevel`]'s alpha face: each instance's hits read its own scene. One
/// ray at a time in either ray mode (the trait's default batches).
impl AlphaQuery for TwoLevelQuery<'_> {
    #[inline]
    fn stopped<C: Counters, F: HitFilter>(&self, ray: &Ray, filter: &mut F, stats: &mut C) -> bool {
        match self.srdh() {
            Some(s) => s.stopped(ray, filter, stats),
            None => self.ordered().stopped(ray, filter, stats),
        }
    }
    #[inline]
    fn closest_hit_filtered<C: Counters, F: HitFilter>(
        &self,
        ray: &Ray,
        filter: &mut F,
        stats: &mut C,
    ) -> Option<Hit> {
        self.levels().closest_hit_filtered(ray, filter, stats)
    }
}
