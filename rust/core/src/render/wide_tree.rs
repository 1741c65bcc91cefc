//! A wide BVH of the width chosen at run time.

use crate::build::CollapseSettings;
use crate::bvh::{Bvh, BvhWidth, WideBvh};
use crate::geometry::Ray;
use crate::order::{OrderView, PreparedOrder, ShadowOrder, SortTables};
use crate::trace::wide::{BoxKernel, WideQueries};
use crate::trace::{ClosestHitQuery, Counters, Hit};

/// A collapsed BVH of one of the supported widths.
#[derive(Clone, Debug)]
pub enum WideTree {
    Two(WideBvh<2>),
    Four(WideBvh<4>),
    Eight(WideBvh<8>),
}

/// Calls `$f` with the tree of whatever width `$tree` holds.
macro_rules! with_tree {
    ($tree:expr, $t:ident => $f:expr) => {
        match $tree {
            WideTree::Two($t) => $f,
            WideTree::Four($t) => $f,
            WideTree::Eight($t) => $f,
        }
    };
}

impl WideTree {
    pub fn collapse(bvh: &Bvh, width: BvhWidth, settings: &CollapseSettings) -> Self {
        match width {
            BvhWidth::Two => WideTree::Two(WideBvh::collapse_with(bvh, settings)),
            BvhWidth::Four => WideTree::Four(WideBvh::collapse_with(bvh, settings)),
            BvhWidth::Eight => WideTree::Eight(WideBvh::collapse_with(bvh, settings)),
        }
    }

    pub fn width(&self) -> BvhWidth {
        match self {
            WideTree::Two(_) => BvhWidth::Two,
            WideTree::Four(_) => BvhWidth::Four,
            WideTree::Eight(_) => BvhWidth::Eight,
        }
    }

    pub fn node_count(&self) -> usize {
        with_tree!(self, t => t.nodes.len())
    }

    pub fn bytes(&self) -> usize {
        with_tree!(self, t => t.bytes())
    }

    pub fn collapse_ms(&self) -> f64 {
        with_tree!(self, t => t.collapse_ms)
    }

    pub fn sort_tables(&self) -> SortTables {
        with_tree!(self, t => SortTables::new(t))
    }

    /// Prepares `order` for one light (`representative` rays are read by the sorted order).
    pub fn prepare(
        &self,
        order: &ShadowOrder,
        tables: Option<&SortTables>,
        representative: &[Ray],
    ) -> PreparedOrder {
        with_tree!(self, t => PreparedOrder::new(t, order, tables, representative, BoxKernel::Auto))
    }

    #[inline]
    pub fn occluded<C: Counters>(
        &self,
        ray: &Ray,
        order: OrderView,
        kernel: BoxKernel,
        stats: &mut C,
    ) -> bool {
        with_tree!(self, t => t.occluded(ray, order, kernel, stats))
    }
}

impl ClosestHitQuery for WideTree {
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        with_tree!(self, t => WideQueries::closest_hit(t, ray, BoxKernel::Auto, stats))
    }
}
