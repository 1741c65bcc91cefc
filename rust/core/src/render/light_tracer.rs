//! The choice of a light's tree and child order, in one function ([`light_tracing`]): the
//! binary traversal where the order is one it has, a light's SRDH tree, else the wide tree with
//! the light's prepared order. [`ShadowTracer`] is what the shadow pass then traces.

use std::borrow::Cow;
use std::time::Instant;

use glam::Vec3;

use super::mesh_entry::TwoLevelSorted;
use super::shadow::{representative_rays, SamplePlan};
use super::srdh_light::{srdh_for_light, srdh_rays};
use super::two_level_query::TwoLevelQuery;
use super::two_level_trees::TwoLevelTrees;
use super::wide_tree::{OrderedWideTree, WideTree};
use super::{LightSampler, PrimaryPass};
use crate::build::BuildSettings;
use crate::bvh::{Bvh, BvhWidth};
use crate::geometry::Ray;
use crate::order::{AnyHitOrder, PreparedOrder, ShadowOrder, SortTables};
use crate::scene::Object;
use crate::srdh::SrdhBvh;
use crate::trace::forward_ray_query;
use crate::trace::{OrderedBinary, RayMode};
use crate::two_level::SrdhTop;

/// The tree and order one light's shadow pass traces; a batch reads which once.
pub enum ShadowTracer<'a> {
    Binary(OrderedBinary<'a>),
    Wide(OrderedWideTree<'a>),
    /// A light's SRDH tree with its kernels.
    Srdh(&'a SrdhBvh),
    /// A top level over instances of mesh trees.
    TwoLevel(TwoLevelQuery<'a>),
}

/// Calls `$f` with the query `$tracer` holds.
macro_rules! with_query {
    ($tracer:expr, $q:ident => $f:expr) => {
        match $tracer {
            ShadowTracer::Binary($q) => $f,
            ShadowTracer::Wide($q) => $f,
            ShadowTracer::Srdh($q) => $f,
            ShadowTracer::TwoLevel($q) => $f,
        }
    };
}

forward_ray_query!(ShadowTracer<'_>, with_query);

/// The binary traversal's order when `order` at `width` is one the binary traversal has.
pub fn binary_order(width: BvhWidth, order: &ShadowOrder) -> Option<AnyHitOrder> {
    (width == BvhWidth::Two).then(|| order.binary()).flatten()
}

/// The trees a frame's shadow rays may trace, and the orders made once per tree.
#[derive(Clone, Copy)]
pub struct ShadowTrees<'a> {
    pub bvh: &'a Bvh,
    /// The triangles `bvh` was built over (SRDH trees are built over them too).
    pub triangles: &'a [[Vec3; 3]],
    /// The collapsed tree, where the frame has one.
    pub wide: Option<&'a WideTree>,
    pub sort_tables: Option<&'a SortTables>,
    /// A per-tree order (SATO, RTSAH, random) already prepared on `wide`, and its preparation
    /// time when this frame prepared it.
    pub per_tree: Option<(&'a ShadowOrder, &'a PreparedOrder, Option<f64>)>,
}

/// One light's tree and order, owning what it made for the light.
pub struct LightTracing<'a> {
    route: Route<'a>,
    /// Preparation time for this light's statistics row, ms: sorting or SRDH selection and
    /// build; a per-tree order's on the first light's row only.
    pub prepare_ms: f64,
}

/// What a light's tracing owns (its prepared order, its SRDH tree), where [`ShadowTracer`] is
/// the borrowed view a pass traces: one value cannot hold a view beside what it borrows, so the
/// owner and the view are two types, and [`LightTracing::tracer`] is the only way between them.
enum Route<'a> {
    Binary(OrderedBinary<'a>),
    Wide {
        tree: &'a WideTree,
        order: Cow<'a, PreparedOrder>,
    },
    Srdh(SrdhBvh),
    /// The two-level trees and the order on every mesh tree: the query is made by
    /// [`LightTracing::tracer`], which knows the ray mode.
    TwoLevel(&'a TwoLevelTrees, ShadowOrder),
    /// The two-level trees with every mesh tree sorted for the light.
    TwoLevelSorted(&'a TwoLevelTrees, TwoLevelSorted),
    /// The two-level trees with the light's SRDH tree over the instances.
    TwoLevelSrdh(&'a TwoLevelTrees, SrdhTop),
}

impl<'a> LightTracing<'a> {
    /// A two-level frame's tracing for the light with `order`: the sorted order sorts every
    /// mesh tree for the light ([`TwoLevelTrees::sort_for_light`]); SRDH builds the light's
    /// tree over the instances ([`TwoLevelTrees::srdh_for_light`]; the top level, front to
    /// back, when too few of its rays are occluded); the others are the trees' own, prepared
    /// with them.
    pub fn two_level(trees: &'a TwoLevelTrees, order: &ShadowOrder, light: &LightRays) -> Self {
        if let ShadowOrder::Srdh(s) = order {
            let start = Instant::now();
            let rays = srdh_rays(light.primary, light.sampler, light.plan, s.rays);
            let route = match trees.srdh_for_light(light.objects, rays, s, light.sah) {
                Some(t) => Route::TwoLevelSrdh(trees, t),
                None => Route::TwoLevel(trees, ShadowOrder::Fbto),
            };
            return LightTracing {
                route,
                // Choosing the rays, their hit lists through both levels and the build.
                prepare_ms: start.elapsed().as_secs_f64() * 1e3,
            };
        }
        if let ShadowOrder::Sorted(s) = order {
            let start = Instant::now();
            let representative =
                representative_rays(light.primary, light.sampler, light.plan, s.budget);
            if let Some(sorted) = trees.sort_for_light(&representative, s) {
                return LightTracing {
                    route: Route::TwoLevelSorted(trees, sorted),
                    // The whole preparation, as on a flat tree: choosing the representative
                    // rays, the sorting tables a mesh tree lacked, logging and sorting.
                    prepare_ms: start.elapsed().as_secs_f64() * 1e3,
                };
            }
        }
        // `auto`'s SATO reads the sorting tables, made by the first light that needs them.
        let start = Instant::now();
        let made = *order == ShadowOrder::Sato && trees.prepare_sato();
        LightTracing {
            route: Route::TwoLevel(trees, *order),
            prepare_ms: if made {
                start.elapsed().as_secs_f64() * 1e3
            } else {
                0.0
            },
        }
    }

    /// What the light's pass traces, its batches as `rays` on a wide tree and on two levels
    /// (the binary and SRDH trees trace single rays).
    pub fn tracer(&self, rays: RayMode) -> ShadowTracer<'_> {
        match &self.route {
            Route::Binary(b) => ShadowTracer::Binary(*b),
            Route::Wide { tree, order } => {
                ShadowTracer::Wide(tree.ordered(order.view()).with_rays(rays))
            }
            Route::Srdh(t) => ShadowTracer::Srdh(t),
            Route::TwoLevel(trees, order) => {
                ShadowTracer::TwoLevel(trees.shadow_query(order, rays))
            }
            Route::TwoLevelSorted(trees, sorted) => {
                ShadowTracer::TwoLevel(trees.sorted_shadow_query(sorted, rays))
            }
            Route::TwoLevelSrdh(trees, srdh) => {
                ShadowTracer::TwoLevel(trees.srdh_shadow_query(srdh))
            }
        }
    }

    /// The wide tree traced, if any.
    pub fn wide_tree(&self) -> Option<&'a WideTree> {
        match &self.route {
            Route::Wide { tree, .. } => Some(tree),
            _ => None,
        }
    }

    /// The light's own tree (SRDH; on two levels over the instances), if it has one.
    pub fn own_tree(&self) -> Option<&SrdhBvh> {
        match &self.route {
            Route::Srdh(t) => Some(t),
            Route::TwoLevelSrdh(_, t) => Some(&t.tree),
            _ => None,
        }
    }
}

/// What one light's order reads: the frame's primary hits and the light's samples.
#[derive(Clone, Copy)]
pub struct LightRays<'a> {
    pub primary: &'a PrimaryPass,
    pub sampler: &'a LightSampler,
    pub plan: SamplePlan,
    /// Settings of the SAH subtrees an SRDH build grafts.
    pub sah: &'a BuildSettings,
    /// The frame's objects: a two-level SRDH tree is built over their instances' boxes (flat
    /// trees read none).
    pub objects: &'a [Object],
    /// The first shadow-casting light of the frame (its row reports a per-tree order's time).
    pub first: bool,
}

/// Chooses and prepares one light's tree and order: an SRDH tree for the light (or the binary
/// tree front to back when too few of its rays are occluded), the binary traversal for the
/// orders it has at width 2, else the wide tree with the order prepared for this light.
pub fn light_tracing<'a>(
    trees: &ShadowTrees<'a>,
    order: &ShadowOrder,
    width: BvhWidth,
    light: &LightRays,
) -> LightTracing<'a> {
    let binary = |order| {
        Route::Binary(OrderedBinary {
            bvh: trees.bvh,
            order,
        })
    };
    if let ShadowOrder::Srdh(s) = order {
        let l = srdh_for_light(
            light.primary,
            light.sampler,
            light.plan,
            s,
            trees.bvh,
            trees.triangles,
            light.sah,
        );
        let route = match l.tree {
            Some(t) => Route::Srdh(t),
            // Too few occluded rays for a tree of its own: the SAH tree, front to back.
            None => binary(AnyHitOrder::NearFirst),
        };
        return LightTracing {
            route,
            prepare_ms: l.ms,
        };
    }
    let per_tree_ms = |ms: f64| {
        if order.is_per_tree() && light.first {
            trees.per_tree.and_then(|p| p.2).unwrap_or(0.0)
        } else {
            ms
        }
    };
    let (route, ms) = match (binary_order(width, order), trees.wide) {
        (Some(o), _) => (binary(o), 0.0),
        (None, None) => unreachable!("an order the binary traversal lacks comes with a wide tree"),
        (None, Some(tree)) => {
            let (prepared, ms) = match trees.per_tree.filter(|p| p.0 == order) {
                Some((_, p, _)) => (Cow::Borrowed(p), 0.0),
                None => {
                    let start = Instant::now();
                    let representative: Vec<Ray> = match order {
                        ShadowOrder::Sorted(s) => {
                            representative_rays(light.primary, light.sampler, light.plan, s.budget)
                        }
                        _ => Vec::new(),
                    };
                    let prepared = tree.prepare(order, trees.sort_tables, &representative);
                    // The whole preparation, choosing the representative rays included (some
                    // 3 ms a light at 640x360, beside logging and sorting).
                    let ms = match prepared {
                        PreparedOrder::Stored | PreparedOrder::FrontToBack => 0.0,
                        _ => start.elapsed().as_secs_f64() * 1e3,
                    };
                    (Cow::Owned(prepared), ms)
                }
            };
            (
                Route::Wide {
                    tree,
                    order: prepared,
                },
                ms,
            )
        }
    };
    LightTracing {
        route,
        prepare_ms: per_tree_ms(ms),
    }
}
