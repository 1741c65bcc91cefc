//! A two-level frame's mesh trees, one [`MeshEntry`] per mesh (or the static group): the
//! binary tree, its wide collapse with the per-tree order and the sorting tables, kept across
//! frames while the mesh and the [`TreeSettings`] hold, refit for a deformed mesh; and a light's
//! sorted orders over them ([`TwoLevelSorted`]).

use std::sync::{Arc, OnceLock};
use std::time::Instant;

use super::two_level_query::MeshQuery;
use super::wide_tree::WideTree;
use super::RenderSettings;
use crate::build::{BuildSettings, CollapseSettings};
use crate::bvh::BvhWidth;
use crate::order::static_orders::StopEstimate;
use crate::order::{
    AnyHitOrder, LightOrder, LoggingOrder, OrderView, PreparedOrder, ShadowOrder, SortTables,
};
use crate::scene::{Mesh, TriangleSet};
use crate::trace::{OrderedBinary, RayMode};
use crate::two_level::MeshTree;

/// What a mesh tree is made with: it is kept while these hold.
#[derive(Clone, PartialEq)]
pub(super) struct TreeSettings {
    pub(super) build: BuildSettings,
    /// The collapse's width and settings, when passes read a wide tree.
    pub(super) wide: Option<(BvhWidth, CollapseSettings)>,
    /// A per-tree order (SATO, RTSAH, random) prepared on the wide tree.
    pub(super) per_tree: Option<ShadowOrder>,
}

impl TreeSettings {
    pub(super) fn of(settings: &RenderSettings) -> Self {
        let per_tree = settings
            .shadow_order
            .fixed()
            .filter(|o| o.is_per_tree())
            .copied();
        // Per-light sorting permutes a wide tree's children (at width 2 too, as on a flat frame).
        let sorted = matches!(settings.shadow_order.fixed(), Some(ShadowOrder::Sorted(_)));
        let wide = (settings.width != BvhWidth::Two || per_tree.is_some() || sorted)
            .then_some((settings.width, settings.collapse));
        TreeSettings {
            build: settings.build_settings,
            wide,
            per_tree,
        }
    }
}

/// One mesh's trees, or the static group's.
pub(super) struct MeshEntry {
    /// Keeps the mesh alive, so its address (the cache's key) is not reused; `None` for the
    /// group.
    pub(super) mesh: Option<Arc<Mesh>>,
    /// The group's members and their state (hashed), for the group.
    pub(super) group_key: Option<u128>,
    pub(super) settings: TreeSettings,
    pub(super) tree: MeshTree,
    /// The collapse, when passes read a wide tree.
    pub(super) wide: Option<WideTree>,
    /// The per-tree order prepared on `wide`.
    pub(super) per_tree: Option<PreparedOrder>,
    /// With RTSAH, its estimate of the whole tree, which the top level's RTSAH reads.
    pub(super) rtsah_root: Option<StopEstimate>,
    /// What per-light sorting reads of `wide`, made by the first sorted light that needs it
    /// and kept with the tree.
    pub(super) sort_tables: OnceLock<SortTables>,
    /// Build, collapse and order preparation, ms.
    pub(super) build_ms: f64,
}

impl MeshEntry {
    pub(super) fn build(mesh: &Arc<Mesh>, settings: &TreeSettings) -> Self {
        let start = Instant::now();
        let tree = MeshTree::build(mesh, &settings.build);
        MeshEntry {
            mesh: Some(mesh.clone()),
            ..Self::of_tree(tree, settings, start)
        }
    }

    /// The static group's tree over `set` (render space).
    pub(super) fn group(set: TriangleSet, key: u128, settings: &TreeSettings) -> Self {
        let start = Instant::now();
        let tree = MeshTree::of_set(set, &settings.build);
        MeshEntry {
            group_key: Some(key),
            ..Self::of_tree(tree, settings, start)
        }
    }

    /// This entry refit to `mesh`, its mesh with new positions, under the same settings (see
    /// [`MeshTree::refit`]); `None` when the mesh takes a build, as when refits have worn the
    /// tree past [`crate::two_level::REFIT_LIMIT`].
    pub(super) fn refit(&self, mesh: &Arc<Mesh>, settings: &TreeSettings) -> Option<Self> {
        if self.settings != *settings {
            return None;
        }
        let start = Instant::now();
        let tree = self.tree.refit(self.mesh.as_deref()?, mesh)?;
        if tree.is_worn(&settings.build) {
            return None;
        }
        let wide = self.wide.as_ref().map(|w| {
            let mut w = w.clone();
            w.refit(&tree.bvh.triangles);
            w
        });
        Some(MeshEntry {
            mesh: Some(mesh.clone()),
            ..Self::of_trees(tree, wide, settings, start)
        })
    }

    /// `tree` with its collapse and per-tree order; `start` is when its build began.
    fn of_tree(tree: MeshTree, settings: &TreeSettings, start: Instant) -> Self {
        let wide = settings
            .wide
            .map(|(width, collapse)| WideTree::collapse(&tree.bvh, width, &collapse));
        Self::of_trees(tree, wide, settings, start)
    }

    /// `tree` and its collapse with the per-tree order prepared on it (on a refit tree too:
    /// SATO and RTSAH weigh children by their boxes, so the order follows the new ones).
    fn of_trees(
        tree: MeshTree,
        wide: Option<WideTree>,
        settings: &TreeSettings,
        start: Instant,
    ) -> Self {
        let (per_tree, rtsah_root) = match (settings.per_tree, wide.as_ref()) {
            (Some(ShadowOrder::Rtsah), Some(w)) => {
                let (order, root) = w.rtsah_estimated();
                (Some(order), Some(root))
            }
            (Some(order), Some(w)) => (Some(w.prepare(&order, None, &[])), None),
            _ => (None, None),
        };
        MeshEntry {
            mesh: None,
            group_key: None,
            settings: settings.clone(),
            tree,
            wide,
            per_tree,
            rtsah_root,
            sort_tables: OnceLock::new(),
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        }
    }

    /// Nodes and bytes of the tree passes trace (the collapse where there is one).
    pub(super) fn nodes_and_bytes(&self) -> (u64, u64) {
        match &self.wide {
            Some(w) => (w.node_count() as u64, w.bytes() as u64),
            None => (
                self.tree.bvh.nodes.len() as u64,
                self.tree.bvh.bytes() as u64,
            ),
        }
    }

    /// The collapse with its sorting tables (made on first use), if the entry has a collapse.
    pub(super) fn sortable(&self) -> Option<(&WideTree, &SortTables)> {
        let wide = self.wide.as_ref()?;
        Some((wide, self.sort_tables.get_or_init(|| wide.sort_tables())))
    }

    /// The mesh tree as a pass traces it: the collapse with the prepared per-tree order (or
    /// front to back) and its batches as `rays`, else the binary tree with its own order for
    /// `order` (one ray at a time).
    pub(super) fn query(&self, order: &ShadowOrder, rays: RayMode) -> MeshQuery<'_> {
        match &self.wide {
            Some(w) => MeshQuery::Wide(
                w.ordered(match &self.per_tree {
                    Some(p) if Some(*order) == self.settings.per_tree => p.view(),
                    _ if *order == ShadowOrder::Stored => OrderView::Stored,
                    // `auto`'s SATO: the sorting tables' (the per-tree order's where fixed).
                    _ if *order == ShadowOrder::Sato => match self.sortable() {
                        Some((_, tables)) => tables.logging_view(LoggingOrder::Sato),
                        None => OrderView::FrontToBack,
                    },
                    _ => OrderView::FrontToBack,
                })
                .with_rays(rays),
            ),
            None => MeshQuery::Binary(OrderedBinary {
                bvh: &self.tree.bvh,
                order: order.binary().unwrap_or(AnyHitOrder::NearFirst),
            }),
        }
    }
}

/// One light's per-light sorting on two levels ([`TwoLevelTrees::sort_for_light`]).
pub struct TwoLevelSorted {
    /// The shadow top level's children sorted for the light, where its representative rays
    /// were stopped at all, else `None` (the top level walked in the logging order).
    pub(super) top: Option<LightOrder>,
    /// By mesh tree: its sorted order where the light's representative rays stopped in it,
    /// else `None` (the tree is traced in the logging order, as a flat tree's unreached nodes).
    pub(super) per_mesh: Vec<Option<LightOrder>>,
    pub(super) logging: LoggingOrder,
}
