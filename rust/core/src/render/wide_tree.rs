//! A wide BVH of the width chosen at run time, and its queries with an any-hit order.

use glam::Vec3;

use crate::build::CollapseSettings;
use crate::bvh::{Bvh, BvhWidth, WideBvh};
use crate::geometry::Ray;
use crate::order::static_orders::{self, StopEstimate};
use crate::order::{
    sort_from_stoppers, LightOrder, OrderView, PreparedOrder, ShadowOrder, SortSettings, SortTables,
};
use crate::trace::wide::{BoxKernel, WideQueries};
use crate::trace::NoStats;
use crate::trace::{forward_alpha_query, forward_ray_query};
use crate::trace::{OrderedWide, RayMode};

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

    /// Refits the tree to `triangles` in its leaf order (its binary tree's after that refit):
    /// the same nodes with new boxes, cheaper than a new collapse and the same boxes it would give.
    pub fn refit(&mut self, triangles: &[[Vec3; 3]]) {
        with_tree!(self, t => t.refit(triangles))
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

    /// The RTSAH order and the root's estimate, which the top level's RTSAH reads of each
    /// mesh tree.
    pub fn rtsah_estimated(&self) -> (PreparedOrder, StopEstimate) {
        let (perms, root) = with_tree!(self, t => static_orders::rtsah_estimated(t));
        (PreparedOrder::Static(perms), root)
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

    /// The first triangle slot of the leaf that stops `ray` traced in `order` (the sorted
    /// order's logging pass, [`crate::order::sort_for_light`]).
    pub fn occluder_leaf(&self, ray: &Ray, order: OrderView) -> Option<u32> {
        with_tree!(self, t => t.occluder_leaf(ray, order, BoxKernel::Auto, &mut NoStats))
    }

    /// Sorts the children for a light from the leaves that stopped its representative rays
    /// ([`sort_from_stoppers`]).
    pub fn sort_from_stoppers(
        &self,
        tables: &SortTables,
        stoppers: &[u32],
        settings: &SortSettings,
    ) -> LightOrder {
        with_tree!(self, t => sort_from_stoppers(t, tables, stoppers, settings))
    }

    /// This tree with a prepared any-hit order, the box kernel chosen at run time, batches
    /// traced one ray at a time ([`OrderedWideTree::with_rays`] for packets).
    pub fn ordered<'a>(&'a self, order: OrderView<'a>) -> OrderedWideTree<'a> {
        OrderedWideTree {
            tree: self,
            order,
            kernel: BoxKernel::Auto,
            rays: RayMode::Single,
        }
    }
}

/// A wide tree alone: any hit front to back, the box kernel chosen at run time.
macro_rules! with_front_to_back {
    ($tree:expr, $q:ident => $f:expr) => {{
        let $q = $tree.ordered(OrderView::FrontToBack);
        $f
    }};
}
forward_ray_query!(WideTree, with_front_to_back);

/// A wide tree of a run-time width with a prepared any-hit order and a box kernel; a batch reads
/// the width once.
#[derive(Clone, Copy)]
pub struct OrderedWideTree<'a> {
    pub tree: &'a WideTree,
    pub order: OrderView<'a>,
    pub kernel: BoxKernel,
    pub rays: RayMode,
}

impl<'a> OrderedWideTree<'a> {
    /// The same query with batches traced as `rays`.
    pub fn with_rays(self, rays: RayMode) -> Self {
        OrderedWideTree { rays, ..self }
    }
}

/// Calls `$f` with the [`OrderedWide`] of whatever width `$q`'s tree holds.
macro_rules! with_ordered {
    ($q:expr, $o:ident => $f:expr) => {{
        let (order, kernel, rays) = ($q.order, $q.kernel, $q.rays);
        with_tree!($q.tree, bvh => {
            let $o = OrderedWide { bvh, order, kernel, rays };
            $f
        })
    }};
}

forward_ray_query!(OrderedWideTree<'_>, with_ordered);
forward_alpha_query!(OrderedWideTree<'_>, with_ordered);
