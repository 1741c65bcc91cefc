//! A [`ShadowOrder`] made concrete for one tree and one light: the permutations the traversal
//! reads, computed from the tree (SATO, RTSAH, random) or from the light's representative rays
//! (sorted).

use super::child_sort::{sort_for_light, LightOrder, SortTables};
use super::{static_orders, OrderView, Permutation, ShadowOrder};
use crate::bvh::WideBvh;
use crate::geometry::Ray;

#[derive(Clone, Debug)]
pub enum PreparedOrder {
    Stored,
    FrontToBack,
    /// A permutation per node, the same for every light.
    Static(Vec<Permutation>),
    /// Sorted for one light, with what the sorting cost.
    Sorted(LightOrder),
}

impl PreparedOrder {
    /// Prepares `order` on `bvh`. `representative` are the light's representative shadow rays
    /// (only read by the sorted order, whose logging pass traces them with `occluder`, see
    /// [`sort_for_light`]); `tables` is made on demand when not given.
    pub fn with_occluder<const N: usize>(
        bvh: &WideBvh<N>,
        order: &ShadowOrder,
        tables: Option<&SortTables>,
        representative: &[Ray],
        occluder: impl Fn(&Ray, OrderView) -> Option<u32> + Sync,
    ) -> Self {
        match order {
            ShadowOrder::Stored => PreparedOrder::Stored,
            ShadowOrder::Fbto => PreparedOrder::FrontToBack,
            // SRDH trees are binary (see `crate::srdh`); on a wide tree the order is front to back.
            ShadowOrder::Srdh(_) => PreparedOrder::FrontToBack,
            ShadowOrder::Sato => PreparedOrder::Static(static_orders::sato(bvh)),
            ShadowOrder::Rtsah => PreparedOrder::Static(static_orders::rtsah(bvh)),
            ShadowOrder::Random { seed } => {
                PreparedOrder::Static(static_orders::random(bvh, *seed))
            }
            ShadowOrder::Sorted(settings) => {
                let owned;
                let tables = match tables {
                    Some(t) => t,
                    None => {
                        owned = SortTables::new(bvh);
                        &owned
                    }
                };
                PreparedOrder::Sorted(sort_for_light(
                    bvh,
                    tables,
                    representative,
                    settings,
                    occluder,
                ))
            }
        }
    }

    pub fn view(&self) -> OrderView<'_> {
        match self {
            PreparedOrder::Stored => OrderView::Stored,
            PreparedOrder::FrontToBack => OrderView::FrontToBack,
            PreparedOrder::Static(perms) => OrderView::Permuted {
                perms,
                fallback_fbto: false,
            },
            PreparedOrder::Sorted(o) => o.view(),
        }
    }

    /// Logging + sorting time in ms (0 for orders that need no rays).
    pub fn prepare_ms(&self) -> f64 {
        match self {
            PreparedOrder::Sorted(o) => o.logging_ms + o.sorting_ms,
            _ => 0.0,
        }
    }
}
