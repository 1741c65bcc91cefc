//! The wide collapse: a binary BVH becomes an N-wide one (N = 2, 4, 8) that keeps the binary
//! tree's leaves (and so its leaf-ordered triangles) and only removes interior levels.
//!
//! Which binary nodes become the slots of each wide node: `Greedy` starts from a binary node's
//! two children and opens the largest-area interior slot until the node is full (Wald, Benthin,
//! Boulos 2008; Dammertz, Hanika, Keller 2008); `Sah` takes the choice that minimises the SAH
//! cost of the whole wide tree, by the dynamic programme of Ylitie, Karras & Laine 2017
//! (section 4): per binary node n and slot count i = 1..N, the cheapest way to represent n's
//! subtree in at most i slots, each a leaf or a wide node. For N = 2 the result is the binary
//! tree itself in the wide layout, whatever the method.
//!
//! A leaf is always a whole binary subtree, whose triangles are contiguous in leaf order, so
//! neither method re-orders triangles.

use std::collections::VecDeque;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::bvh::{Bvh, TriangleRows, WideBvh, WideNode};

/// How the binary BVH is collapsed into wide nodes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum CollapseMethod {
    /// Open the largest-area interior child until N slots are filled; binary subtrees of at
    /// most [`MERGE_LIMIT`] triangles become one leaf.
    Greedy,
    /// The slots and leaves that minimise [`CollapseCost`] over the whole tree. The default:
    /// fuller nodes, hence fewer node visits and fewer instructions per ray than `Greedy`.
    #[default]
    Sah,
}

impl CollapseMethod {
    pub const ALL: [CollapseMethod; 2] = [CollapseMethod::Greedy, CollapseMethod::Sah];

    pub fn name(self) -> &'static str {
        match self {
            CollapseMethod::Greedy => "greedy",
            CollapseMethod::Sah => "sah",
        }
    }
}

impl std::str::FromStr for CollapseMethod {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<Self> {
        CollapseMethod::ALL
            .into_iter()
            .find(|m| m.name() == s.trim())
            .ok_or_else(|| {
                crate::Error::invalid(
                    "collapse",
                    format!("unknown collapse method '{s}' (known: greedy, sah)"),
                )
            })
    }
}

impl std::fmt::Display for CollapseMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The SAH cost model of the collapse: a subtree is entered with probability proportional to
/// its box's area; entering a wide node costs `node`, a leaf of n triangles `triangle` per
/// triangle, counted in whole groups of `lanes` (the SIMD leaf test takes that many at once).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CollapseCost {
    pub node: f64,
    pub triangle: f64,
    /// Triangles tested at once by the leaf test (1: a leaf costs per triangle).
    pub lanes: u32,
    /// Largest leaf made by merging binary leaves (a binary leaf larger than this stays one).
    pub max_leaf: u32,
}

impl Default for CollapseCost {
    fn default() -> Self {
        // An 8-wide node test costs about one four-triangle SIMD leaf test.
        CollapseCost {
            node: 1.0,
            triangle: 0.25,
            lanes: 4,
            max_leaf: 8,
        }
    }
}

impl CollapseCost {
    /// Cost of testing a leaf of `count` triangles, per unit area.
    pub fn leaf(&self, count: u32) -> f64 {
        let lanes = self.lanes.max(1);
        self.triangle * (count.div_ceil(lanes) * lanes) as f64
    }
}

/// The collapse to perform: the method and, for `Sah`, its cost model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CollapseSettings {
    pub method: CollapseMethod,
    #[serde(default)]
    pub cost: CollapseCost,
}

impl CollapseSettings {
    pub fn new(method: CollapseMethod) -> Self {
        CollapseSettings {
            method,
            ..CollapseSettings::default()
        }
    }
}

impl<const N: usize> WideBvh<N> {
    /// Collapses `bvh` into N-wide nodes with the default settings.
    pub fn collapse(bvh: &Bvh) -> Self {
        Self::collapse_with(bvh, &CollapseSettings::default())
    }

    /// Collapses `bvh` into N-wide nodes.
    pub fn collapse_with(bvh: &Bvh, settings: &CollapseSettings) -> Self {
        assert!(
            matches!(N, 2 | 4 | 8),
            "wide BVHs are 2, 4 or 8 wide, not {N}"
        );
        let start = Instant::now();
        let mut out = WideBvh {
            triangles: bvh.triangles.clone(),
            triangle_rows: TriangleRows::new(&bvh.triangles),
            triangle_ids: bvh.triangle_ids.clone(),
            ..WideBvh::default()
        };
        let Some(root) = bvh.nodes.first() else {
            return out;
        };
        out.root_bounds = root.bounds();
        let ranges = triangle_ranges(bvh);
        // N = 2 stays the binary tree, whatever the method.
        let plan = (N > 2 && settings.method == CollapseMethod::Sah)
            .then(|| SahPlan::<N>::new(bvh, &ranges, &settings.cost));
        // Greedy: a binary subtree this small becomes one leaf (its triangles are contiguous in
        // leaf order): wide nodes then do not end in nodes of two or three tiny leaves.
        let merge_limit = if N == 2 { 0 } else { MERGE_LIMIT };
        let as_leaf = |c: usize| {
            let n = &bvh.nodes[c];
            if n.is_leaf() {
                return Some((n.first, n.count));
            }
            let merge = match &plan {
                Some(p) => p.is_leaf(c),
                None => ranges[c].is_some_and(|(_, count)| count <= merge_limit),
            };
            ranges[c].filter(|_| merge)
        };
        // A wide node per queued binary node; its binary children fill the slots.
        let mut queue = VecDeque::from([(0usize, u32::MAX, 0u8, 0u16)]);
        while let Some((binary, parent, slot, depth)) = queue.pop_front() {
            let index = out.nodes.len() as u32;
            out.parent.push((parent, slot));
            out.depth.push(depth);
            let mut node = WideNode::<N>::default();
            let children = match &plan {
                Some(p) => p.children(bvh, binary),
                None => open_children::<N>(bvh, binary, &|c| as_leaf(c).is_some()),
            };
            for (s, &c) in children.iter().enumerate() {
                node.set_child_bounds(s, &bvh.nodes[c].bounds());
                if let Some((first, count)) = as_leaf(c) {
                    node.child[s] = first;
                    node.count[s] = u8::try_from(count).expect("leaves hold at most 64");
                } else {
                    // Nodes are numbered in queue order: this child's index is known now.
                    node.child[s] = index + 1 + queue.len() as u32;
                    queue.push_back((c, index, s as u8, depth + 1));
                }
            }
            out.nodes.push(node);
        }
        out.collapse_ms = start.elapsed().as_secs_f64() * 1e3;
        out
    }
}

/// The binary nodes that become the slots of the wide node made from binary node `index`:
/// its two children, then greedily the children of the largest-area interior slot until N
/// slots are filled. A slot opened in place keeps the builder's left-to-right order. A binary
/// root that is a leaf becomes a one-slot wide root.
fn open_children<const N: usize>(
    bvh: &Bvh,
    index: usize,
    is_leaf: &dyn Fn(usize) -> bool,
) -> Vec<usize> {
    let node = &bvh.nodes[index];
    if is_leaf(index) {
        return vec![index];
    }
    let first = node.first as usize;
    let mut slots = vec![first, first + 1];
    while slots.len() < N {
        let widest = slots
            .iter()
            .enumerate()
            .filter(|(_, &c)| !is_leaf(c))
            .max_by(|(_, &a), (_, &b)| {
                let (a, b) = (&bvh.nodes[a], &bvh.nodes[b]);
                a.bounds().half_area().total_cmp(&b.bounds().half_area())
            })
            .map(|(i, _)| i);
        let Some(i) = widest else { break };
        let c = bvh.nodes[slots[i]].first as usize;
        slots.splice(i..=i, [c, c + 1]);
    }
    slots
}

/// Largest binary subtree (in triangles) the collapse turns into a single leaf.
pub const MERGE_LIMIT: u32 = 4;

/// Per binary node, the triangle slots of its subtree as (first, count) when they are
/// contiguous (the builders lay leaves out depth first, so they are), else `None`.
fn triangle_ranges(bvh: &Bvh) -> Vec<Option<(u32, u32)>> {
    fn visit(bvh: &Bvh, i: usize, out: &mut [Option<(u32, u32)>]) -> Option<(u32, u32)> {
        let n = &bvh.nodes[i];
        let r = if n.is_leaf() {
            Some((n.first, n.count))
        } else {
            let l = n.first as usize;
            match (visit(bvh, l, out), visit(bvh, l + 1, out)) {
                (Some(a), Some(b)) if a.0 + a.1 == b.0 => Some((a.0, a.1 + b.1)),
                (Some(a), Some(b)) if b.0 + b.1 == a.0 => Some((b.0, a.1 + b.1)),
                _ => None,
            }
        };
        out[i] = r;
        r
    }
    let mut out = vec![None; bvh.nodes.len()];
    if !bvh.nodes.is_empty() {
        visit(bvh, 0, &mut out);
    }
    out
}

/// How one binary node is represented in at most i slots: as one slot (itself: a leaf or a
/// wide node), or split into `left` slots for its left child and `total - left` for its right.
#[derive(Clone, Copy, Default)]
struct Choice {
    left: u8,
    total: u8,
}

/// The decisions of the SAH collapse for every binary node reachable from the root.
struct SahPlan<const N: usize> {
    /// Per binary node: a slot holding it is a leaf (else a wide node).
    leaf: Vec<bool>,
    /// Per binary node and slot budget i (index i - 1): the cheapest representation. Only
    /// budgets up to N - 1 are read: a split gives each side at least one slot.
    choice: Vec<[Choice; N]>,
    /// Per interior binary node made a wide node: the slots its left child takes of N.
    wide_left: Vec<u8>,
    /// Model cost of the whole wide tree (areas are half areas).
    pub cost: f64,
}

impl<const N: usize> SahPlan<N> {
    /// Runs the programme bottom-up. `ranges` are the subtrees' contiguous triangle ranges.
    pub fn new(bvh: &Bvh, ranges: &[Option<(u32, u32)>], model: &CollapseCost) -> Self {
        let len = bvh.nodes.len();
        let mut plan = SahPlan {
            leaf: vec![false; len],
            choice: vec![[Choice::default(); N]; len],
            wide_left: vec![0; len],
            cost: 0.0,
        };
        if len == 0 {
            return plan;
        }
        // cost[i - 1]: cheapest representation of a node's subtree in at most i slots. Only a
        // node's parent reads its costs, and the post order finishes a node's left subtree,
        // then its right, then the node: the costs of the nodes whose parent is still to come
        // are a stack (as deep as the tree), not a table over all nodes (64 bytes a node at
        // N = 8: 106 MB for a million-instance top level).
        let mut costs: Vec<[f64; N]> = Vec::new();
        // The root's children's costs, which the root's own choice below reads again.
        let mut root_children = None;
        for n in post_order(bvh) {
            let node = &bvh.nodes[n];
            let area = node.bounds().half_area() as f64;
            let merged = ranges[n].filter(|&(_, c)| c <= model.max_leaf);
            let leaf_cost = match (node.is_leaf(), merged) {
                (true, _) => area * model.leaf(node.count),
                (false, Some((_, c))) => area * model.leaf(c),
                (false, None) => f64::INFINITY,
            };
            if node.is_leaf() {
                plan.leaf[n] = true;
                costs.push([leaf_cost; N]);
                continue;
            }
            let right = costs.pop().expect("the right child precedes its parent");
            let left = costs
                .pop()
                .expect("the left child precedes its right sibling");
            // Best split over at most i slots, for i = 2..=N (non-increasing in i).
            let mut dist = [(f64::INFINITY, 0u8); N];
            for i in 2..=N {
                for k in 1..i {
                    let c = left[k - 1] + right[i - k - 1];
                    if c < dist[i - 1].0 {
                        dist[i - 1] = (c, k as u8);
                    }
                }
            }
            plan.wide_left[n] = dist[N - 1].1;
            let internal = area * model.node + dist[N - 1].0;
            plan.leaf[n] = leaf_cost <= internal;
            let mut cost = [f64::INFINITY; N];
            cost[0] = leaf_cost.min(internal);
            for i in 2..=N {
                let (c, k) = dist[i - 1];
                if c < cost[i - 2] {
                    cost[i - 1] = c;
                    plan.choice[n][i - 1] = Choice {
                        left: k,
                        total: i as u8,
                    };
                } else {
                    cost[i - 1] = cost[i - 2];
                    plan.choice[n][i - 1] = plan.choice[n][i - 2];
                }
            }
            costs.push(cost);
            if n == 0 {
                root_children = Some((left, right));
            }
        }
        // The root is always a wide node; its one slot may hold the whole tree as a leaf.
        let root = &bvh.nodes[0];
        let root_area = root.bounds().half_area() as f64;
        let below = match root_children {
            None => costs[0][0],
            Some((left, right)) => {
                let k = plan.wide_left[0] as usize;
                let split = left[k - 1] + right[N - k - 1];
                let merged = ranges[0].filter(|&(_, c)| c <= model.max_leaf);
                let leaf = merged.map_or(f64::INFINITY, |(_, c)| root_area * model.leaf(c));
                plan.leaf[0] = leaf <= split;
                leaf.min(split)
            }
        };
        plan.cost = root_area * model.node + below;
        plan
    }

    /// Whether a slot holding binary node `n` is a leaf.
    pub fn is_leaf(&self, n: usize) -> bool {
        self.leaf[n]
    }

    /// The binary nodes in the slots of the wide node made from binary node `n`, left to right
    /// (just `n` when it is the root kept as one leaf).
    pub fn children(&self, bvh: &Bvh, n: usize) -> Vec<usize> {
        let mut out = Vec::with_capacity(N);
        if self.leaf[n] {
            out.push(n);
        } else {
            let k = self.wide_left[n] as usize;
            let l = bvh.nodes[n].first as usize;
            self.slots(bvh, l, k, &mut out);
            self.slots(bvh, l + 1, N - k, &mut out);
        }
        out
    }

    /// Appends the slots of `n`'s subtree within a budget of `i` slots.
    fn slots(&self, bvh: &Bvh, n: usize, i: usize, out: &mut Vec<usize>) {
        let c = self.choice[n][i - 1];
        if c.left == 0 || bvh.nodes[n].is_leaf() {
            out.push(n);
        } else {
            let l = bvh.nodes[n].first as usize;
            self.slots(bvh, l, c.left as usize, out);
            self.slots(bvh, l + 1, (c.total - c.left) as usize, out);
        }
    }
}

/// The binary nodes reachable from the root, children before parents.
fn post_order(bvh: &Bvh) -> Vec<usize> {
    let mut order = Vec::with_capacity(bvh.nodes.len());
    let mut stack = vec![0usize];
    while let Some(n) = stack.pop() {
        order.push(n);
        let node = &bvh.nodes[n];
        if !node.is_leaf() {
            stack.extend([node.first as usize, node.first as usize + 1]);
        }
    }
    // Pre-order reversed: every node after all of its descendants.
    order.reverse();
    order
}

impl<const N: usize> WideBvh<N> {
    /// The tree's cost under `model` (half areas): every wide node's box area times
    /// `model.node`, plus every leaf's box area times its triangle cost. The SAH collapse
    /// minimises this over all collapses of the same binary tree.
    pub fn sah_cost(&self, model: &CollapseCost) -> f64 {
        let mut total = 0.0;
        for (i, node) in self.nodes.iter().enumerate() {
            let own = match self.parent[i] {
                (u32::MAX, _) => self.root_bounds,
                (p, s) => self.nodes[p as usize].child_bounds(s as usize),
            };
            total += own.half_area() as f64 * model.node;
            for s in (0..N).filter(|&s| !node.is_empty_slot(s) && node.is_leaf_slot(s)) {
                total += node.child_bounds(s).half_area() as f64 * model.leaf(node.count[s] as u32);
            }
        }
        total
    }

    /// Average used slots per node.
    pub fn children_per_node(&self) -> f64 {
        let used: usize = self.nodes.iter().map(|n| n.arity()).sum();
        used as f64 / self.nodes.len().max(1) as f64
    }
}
