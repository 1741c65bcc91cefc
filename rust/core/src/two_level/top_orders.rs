//! [`TopOrders`]: the top level's child orders for shadow rays, over its wide nodes as a flat
//! wide tree's: a per-tree order (SATO, RTSAH, random) prepared with the top level, and the
//! sorting tables per-light sorting reads ([`TopOrders::sort_for_light`]: the instances whose mesh
//! trees stopped a light's representative rays are the stoppers, as leaves are in a flat tree).

use std::sync::OnceLock;

use crate::order::static_orders::{self, StopEstimate};
use crate::order::{
    sort_from_stoppers, LightOrder, LoggingOrder, OrderView, Permutation, ShadowOrder,
    SortSettings, SortTables,
};

use super::top_level::INSTANCE_COST;
use super::TopLevel;

/// A mesh tree with no estimate of its own weighs in the top level's RTSAH as a solid box.
const SOLID: StopEstimate = StopEstimate {
    stop: 1.0,
    cost: 1.0,
};

/// The orders over one top level's nodes: kept with it (a new top level prepares its own).
#[derive(Debug, Default)]
pub struct TopOrders {
    /// The fixed per-tree order and its permutation per node.
    per_tree: Option<(ShadowOrder, Vec<Permutation>)>,
    /// Made by the first light that sorts (or `auto`'s first SATO), kept with the top level.
    tables: OnceLock<SortTables>,
}

impl TopOrders {
    /// Prepares `order` over `top`'s nodes when it is a per-tree order (SATO, RTSAH, random;
    /// the others need no table). `meshes` holds each mesh tree's RTSAH root estimate by mesh
    /// index, which only RTSAH reads: an instance leaf stops a ray as its meshes' trees would
    /// and costs a ray transform and their expected traversal each.
    pub fn prepare(
        top: &TopLevel,
        order: Option<&ShadowOrder>,
        meshes: &[Option<StopEstimate>],
    ) -> Self {
        let bvh = &top.bvh;
        let perms = match order {
            Some(ShadowOrder::Sato) => Some(static_orders::sato(bvh)),
            Some(ShadowOrder::Random { seed }) => Some(static_orders::random(bvh, *seed)),
            Some(ShadowOrder::Rtsah) => Some(
                static_orders::rtsah_over(bvh, |first, count, _| {
                    let mut pass = 1.0;
                    let mut cost = 1.0;
                    for instance in &top.instances[first..first + count] {
                        let e = meshes.get(instance.mesh as usize).copied().flatten();
                        let e = e.unwrap_or(SOLID);
                        pass *= 1.0 - e.stop;
                        cost += 1.0 + e.cost;
                    }
                    StopEstimate {
                        stop: 1.0 - pass,
                        cost,
                    }
                })
                .0,
            ),
            _ => None,
        };
        TopOrders {
            per_tree: order.copied().zip(perms),
            tables: OnceLock::new(),
        }
    }

    /// The order shadow rays with `order` walk the top level in: its prepared permutation,
    /// slot order for `stored`, the sorting tables' SATO for `auto`'s SATO (when made), else
    /// front to back.
    pub fn view(&self, order: &ShadowOrder) -> OrderView<'_> {
        match (&self.per_tree, order) {
            (Some((prepared, perms)), _) if prepared == order => OrderView::Permuted {
                perms,
                fallback_fbto: false,
            },
            (_, ShadowOrder::Stored) => OrderView::Stored,
            (_, ShadowOrder::Sato) => match self.tables.get() {
                Some(t) => t.logging_view(LoggingOrder::Sato),
                None => OrderView::FrontToBack,
            },
            _ => OrderView::FrontToBack,
        }
    }

    /// The sorting tables over `top` (this struct's top level), made on first use: an
    /// instance is an item of its leaf, costing what the build charges it.
    pub fn tables(&self, top: &TopLevel) -> &SortTables {
        self.tables
            .get_or_init(|| SortTables::over_items(&top.bvh, top.len(), INSTANCE_COST as f64))
    }

    /// Makes the sorting tables whose SATO `auto`'s SATO walks, unless a fixed SATO is
    /// prepared; whether they were made now.
    pub fn prepare_sato(&self, top: &TopLevel) -> bool {
        let fixed = matches!(self.per_tree, Some((ShadowOrder::Sato, _)));
        let make = !fixed && !self.tables_ready();
        if make {
            self.tables(top);
        }
        make
    }

    /// Whether the sorting tables (and so `auto`'s SATO) are made.
    pub fn tables_ready(&self) -> bool {
        self.tables.get().is_some()
    }

    /// The top level's children sorted for one light from `stoppers`: the index (in `top`'s
    /// instances) of the instance whose mesh tree stopped each of the light's occluded
    /// representative rays, logged walking the top level in the tables' logging order.
    pub fn sort_for_light(
        &self,
        top: &TopLevel,
        stoppers: &[u32],
        settings: &SortSettings,
    ) -> LightOrder {
        sort_from_stoppers(&top.bvh, self.tables(top), stoppers, settings)
    }
}
