//! Per-light child sorting (Ogaki & Derouet-Jourdan): trace a light's representative shadow
//! rays with a logging order, count per leaf the rays it stopped, add the counts up the tree,
//! and order each node's children by Q_i / C_i decreasing, bottom-up (Algorithm 1 of the paper),
//! with Q_i = R_i / R (share of the node's stopped rays stopped in child i) and
//! C_i = P_i · C_SORT(child). The topology is untouched: the result is one [`Permutation`] per
//! node, so lights share the tree and closest-hit queries never see these orders.

use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::cost::{expected_cost, order_by_ratio};
use super::{OrderView, Permutation};
use crate::bvh::WideBvh;
use crate::geometry::{Aabb, Ray};

/// The order the representative rays are traced with while their occluders are logged.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum LoggingOrder {
    /// Largest child box first (the paper's default).
    #[default]
    Sato,
    /// Front to back; nodes left unsorted stay front to back when tracing.
    Fbto,
}

/// The probability P_i that a ray entering a node enters its child i.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum ChildHitModel {
    /// P_i = 1: every child is assumed hit (the worst case; the paper's choice).
    #[default]
    One,
    /// P_i = A_i / A_node, the surface-area ratio.
    Area,
}

/// Settings of the per-light sorting.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SortSettings {
    pub logging: LoggingOrder,
    pub p: ChildHitModel,
    /// Count and sort only nodes shallower than this (root = depth 0); `None` = every node.
    pub depth: Option<u32>,
    /// Share of the light's shadow rays traced as representative rays, in (0, 1].
    pub budget: f32,
}

impl Default for SortSettings {
    fn default() -> Self {
        SortSettings {
            logging: LoggingOrder::Sato,
            p: ChildHitModel::One,
            depth: None,
            budget: 0.05,
        }
    }
}

/// What the sorting of one light produced.
#[derive(Clone, Debug, Default)]
pub struct LightOrder {
    /// Per node: the sorted permutation, or the logging order's where no ray was stopped
    /// (SATO: its permutation; FBTO: none, so the traversal sorts by distance there).
    pub perms: Vec<Permutation>,
    pub fallback_fbto: bool,
    pub representative_rays: usize,
    pub occluded_rays: usize,
    pub nodes_sorted: usize,
    pub logging_ms: f64,
    pub sorting_ms: f64,
}

impl LightOrder {
    pub fn view(&self) -> OrderView<'_> {
        OrderView::Permuted {
            perms: &self.perms,
            fallback_fbto: self.fallback_fbto,
        }
    }
}

/// What the sorting needs of a tree, whatever the light: made once per tree.
#[derive(Clone, Debug, Default)]
pub struct SortTables {
    /// For each item (triangle slot, or a top level's instance) of a leaf, the leaf's position
    /// `node * N + slot`.
    leaf_position: Vec<u32>,
    /// A tree that keeps no parent and depth tables (the top level of two-level scenes) has
    /// them made here; `None` reads the tree's own.
    shape: Option<Shape>,
    /// C_SORT of one item of a leaf, against a traversal step's 1.
    item_cost: f64,
    /// SATO permutation per node (logging order and tie-break of equal ratios).
    pub sato: Vec<Permutation>,
    /// C_SORT of every subtree with no occlusion information, per [`ChildHitModel`]
    /// (`[One, Area]`): the cost below the depth limit.
    blind_cost: [Vec<f64>; 2],
}

/// Per node: its parent's index and slot, and its depth (as `WideBvh::parent` and `depth`).
#[derive(Clone, Debug, Default)]
struct Shape {
    parent: Vec<(u32, u8)>,
    depth: Vec<u16>,
}

impl Shape {
    /// From the nodes alone: they are numbered breadth first, parents before children.
    fn of<const N: usize>(bvh: &WideBvh<N>) -> Self {
        let mut parent = vec![(u32::MAX, 0u8); bvh.nodes.len()];
        let mut depth = vec![0u16; bvh.nodes.len()];
        for (i, node) in bvh.nodes.iter().enumerate() {
            for s in (0..N).filter(|&s| !node.is_empty_slot(s) && !node.is_leaf_slot(s)) {
                let child = node.child[s] as usize;
                parent[child] = (i as u32, s as u8);
                depth[child] = depth[i] + 1;
            }
        }
        debug_assert!(
            depth.windows(2).all(|w| w[0] <= w[1]),
            "nodes not breadth first"
        );
        Shape { parent, depth }
    }
}

impl SortTables {
    /// The tables of a tree over triangles (a leaf's items are its triangle slots, each a test).
    pub fn new<const N: usize>(bvh: &WideBvh<N>) -> Self {
        Self::with_items(bvh, bvh.triangles.len(), 1.0, None)
    }

    /// The tables of a tree whose leaves index `items` things of their own (the top level's
    /// instances), each costing `item_cost` against a traversal step's 1, and which keeps no
    /// parent or depth tables: those are made here.
    pub fn over_items<const N: usize>(bvh: &WideBvh<N>, items: usize, item_cost: f64) -> Self {
        Self::with_items(bvh, items, item_cost, Some(Shape::of(bvh)))
    }

    fn with_items<const N: usize>(
        bvh: &WideBvh<N>,
        items: usize,
        item_cost: f64,
        shape: Option<Shape>,
    ) -> Self {
        let mut leaf_position = vec![u32::MAX; items];
        for (i, node) in bvh.nodes.iter().enumerate() {
            for s in (0..N).filter(|&s| node.is_leaf_slot(s)) {
                let first = node.child[s] as usize;
                leaf_position[first..first + node.count[s] as usize].fill((i * N + s) as u32);
            }
        }
        let blind = |model| {
            let mut cost = vec![0.0; bvh.nodes.len()];
            for i in (0..bvh.nodes.len()).rev() {
                let (_, c) = child_costs(bvh, i, model, &cost, item_cost);
                cost[i] = c.iter().sum();
            }
            cost
        };
        SortTables {
            leaf_position,
            shape,
            item_cost,
            sato: super::static_orders::sato(bvh),
            blind_cost: [blind(ChildHitModel::One), blind(ChildHitModel::Area)],
        }
    }

    /// The tree's parent and depth tables: these tables' own, else the tree's.
    fn shape<'a, const N: usize>(&'a self, bvh: &'a WideBvh<N>) -> (&'a [(u32, u8)], &'a [u16]) {
        match &self.shape {
            Some(s) => (&s.parent, &s.depth),
            None => (&bvh.parent, &bvh.depth),
        }
    }

    /// The order representative rays are traced in while their occluders are logged, which
    /// nodes no logged ray reached keep.
    pub fn logging_view(&self, logging: LoggingOrder) -> OrderView<'_> {
        match logging {
            LoggingOrder::Sato => OrderView::Permuted {
                perms: &self.sato,
                fallback_fbto: false,
            },
            LoggingOrder::Fbto => OrderView::FrontToBack,
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        let shape = self
            .shape
            .as_ref()
            .map_or(0, |s| s.parent.len() * 8 + s.depth.len() * 2);
        shape
            + self.leaf_position.len() * 4
            + self.sato.len() * std::mem::size_of::<Permutation>()
            + (self.blind_cost[0].len() + self.blind_cost[1].len()) * 8
    }
}

/// C_SORT of a leaf: one traversal step and a test per item (C_t = 1, C_p = `item_cost`: 1 for
/// a triangle).
fn leaf_cost(count: u8, item_cost: f64) -> f64 {
    1.0 + count as f64 * item_cost
}

/// The used slots of node `i` and their C_i = P_i · C_SORT(child), with `cost` holding
/// C_SORT of interior children.
fn child_costs<const N: usize>(
    bvh: &WideBvh<N>,
    i: usize,
    model: ChildHitModel,
    cost: &[f64],
    item_cost: f64,
) -> (Vec<usize>, Vec<f64>) {
    let node = &bvh.nodes[i];
    let slots: Vec<usize> = (0..N).filter(|&s| !node.is_empty_slot(s)).collect();
    let mut union = Aabb::EMPTY;
    for &s in &slots {
        union.grow(&node.child_bounds(s));
    }
    let node_area = (union.half_area() as f64).max(f64::MIN_POSITIVE);
    let c = slots
        .iter()
        .map(|&s| {
            let p = match model {
                ChildHitModel::One => 1.0,
                ChildHitModel::Area => node.child_bounds(s).half_area() as f64 / node_area,
            };
            let sub = if node.is_leaf_slot(s) {
                leaf_cost(node.count[s], item_cost)
            } else {
                cost[node.child[s] as usize]
            };
            p * sub
        })
        .collect();
    (slots, c)
}

/// Sorts the children of `bvh` for the light whose representative rays are `rays`. `occluder`
/// is the logging pass's traversal of `bvh`: the first triangle slot of the leaf that stopped a
/// ray traced in the given order (the wide any-hit traversal; passed in, as tracing sits above
/// the orders).
pub fn sort_for_light<const N: usize>(
    bvh: &WideBvh<N>,
    tables: &SortTables,
    rays: &[Ray],
    settings: &SortSettings,
    occluder: impl Fn(&Ray, OrderView) -> Option<u32> + Sync,
) -> LightOrder {
    let start = Instant::now();
    let logging_view = tables.logging_view(settings.logging);
    let stoppers: Vec<u32> = rays
        .par_iter()
        .with_min_len(256)
        .filter_map(|r| occluder(r, logging_view))
        .collect();
    let logging_ms = start.elapsed().as_secs_f64() * 1e3;
    LightOrder {
        representative_rays: rays.len(),
        logging_ms,
        ..sort_from_stoppers(bvh, tables, &stoppers, settings)
    }
}

/// Sorts the children of `bvh` from the leaves that stopped a light's representative rays in
/// the logging order (`stoppers`: each stopped ray's leaf, as an item of it: its first triangle
/// slot, or on a top level the instance whose mesh tree stopped the ray): the
/// counting and sorting half of [`sort_for_light`], for a logging pass traced elsewhere (two
/// levels log every mesh tree's stoppers in one pass). Its `representative_rays` and
/// `logging_ms` are left 0 for the caller.
pub fn sort_from_stoppers<const N: usize>(
    bvh: &WideBvh<N>,
    tables: &SortTables,
    stoppers: &[u32],
    settings: &SortSettings,
) -> LightOrder {
    // Nodes are numbered breadth first, so the nodes above the depth limit are a prefix.
    let (parent, depth) = tables.shape(bvh);
    let limit = settings.depth.map_or(u32::MAX, |d| d);
    let counted = depth.partition_point(|&d| (d as u32) < limit);
    let mut counters = vec![0u32; counted * N];
    // With no node above the limit (settings that were not validated) nothing is sorted.
    for &first in stoppers.iter().filter(|_| counted > 0) {
        let mut pos = tables.leaf_position[first as usize] as usize;
        // Attribute rays stopped below the limit to the deepest counted ancestor's slot.
        while pos / N >= counted {
            let (p, s) = parent[pos / N];
            pos = p as usize * N + s as usize;
        }
        counters[pos] += 1;
    }

    let start = Instant::now();
    let model = settings.p;
    let blind = &tables.blind_cost[model as usize];
    let mut cost = blind.clone();
    let fallback_fbto = settings.logging == LoggingOrder::Fbto;
    let mut perms = if fallback_fbto {
        vec![Permutation::NONE; bvh.nodes.len()]
    } else {
        tables.sato.clone()
    };
    let mut nodes_sorted = 0;
    for i in (0..counted).rev() {
        let total: u32 = counters[i * N..(i + 1) * N].iter().sum();
        if total == 0 {
            // No ray stopped anywhere below: every descendant is unsorted too, so the node's
            // cost is its blind cost, and it keeps its logging order.
            continue;
        }
        if i > 0 {
            let (p, s) = parent[i];
            counters[p as usize * N + s as usize] += total;
        }
        let total = total as f64;
        let (slots, c) = child_costs(bvh, i, model, &cost, tables.item_cost);
        let r: Vec<f64> = slots.iter().map(|&s| counters[i * N + s] as f64).collect();
        let q: Vec<f64> = r.iter().map(|ri| ri / total).collect();
        let sato = tables.sato[i].slots(slots.len());
        let rank: Vec<usize> = slots
            .iter()
            .map(|s| sato.iter().position(|x| x == s).unwrap_or(N))
            .collect();
        let order = order_by_ratio(&q, &c, &rank);
        let sq: Vec<f64> = order.iter().map(|&k| q[k]).collect();
        let sc: Vec<f64> = order.iter().map(|&k| c[k]).collect();
        cost[i] = expected_cost(&sq, &sc);
        perms[i] = Permutation::from_slots(&order.iter().map(|&k| slots[k]).collect::<Vec<_>>());
        nodes_sorted += 1;
    }
    LightOrder {
        perms,
        fallback_fbto,
        representative_rays: 0,
        occluded_rays: stoppers.len(),
        nodes_sorted,
        logging_ms: 0.0,
        sorting_ms: start.elapsed().as_secs_f64() * 1e3,
    }
}
