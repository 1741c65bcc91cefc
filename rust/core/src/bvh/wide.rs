//! N-wide BVH (N = 2, 4, 8) collapsed from a binary BVH, with the node layout SIMD traversal
//! reads: per node the bounds of all N children as six rows of N floats (min x/y/z, max x/y/z),
//! so one vector load per row tests every child at once.
//!
//! The collapse keeps the binary tree's leaves (and so its leaf-ordered triangles) and only
//! removes interior levels: each wide node starts from a binary node's two children and
//! repeatedly opens the interior child with the largest surface area until it has N children or
//! only leaves are left (Wald, Benthin, Boulos 2008; Dammertz, Hanika, Keller 2008), or takes the
//! SAH-optimal slots ([`CollapseMethod::Sah`], see `wide_collapse.rs`). For N = 2 the result is
//! the binary tree itself in this layout, whatever the method.

use std::collections::VecDeque;
use std::time::Instant;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::wide_collapse::{CollapseMethod, CollapseSettings, SahPlan};
use super::Bvh;
use crate::geometry::Aabb;
use crate::trace::wide::TriangleRows;

/// How many children a BVH node has: 2 is the builder's binary tree, 4 and 8 its collapse.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum BvhWidth {
    #[default]
    Two,
    Four,
    Eight,
}

impl BvhWidth {
    pub fn get(self) -> u32 {
        match self {
            BvhWidth::Two => 2,
            BvhWidth::Four => 4,
            BvhWidth::Eight => 8,
        }
    }
}

impl TryFrom<u32> for BvhWidth {
    type Error = crate::Error;
    fn try_from(n: u32) -> crate::Result<Self> {
        match n {
            2 => Ok(BvhWidth::Two),
            4 => Ok(BvhWidth::Four),
            8 => Ok(BvhWidth::Eight),
            _ => Err(crate::Error::invalid(
                "width",
                format!("must be 2, 4 or 8, got {n}"),
            )),
        }
    }
}

impl std::str::FromStr for BvhWidth {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<Self> {
        let n: u32 = s
            .trim()
            .parse()
            .map_err(|_| crate::Error::invalid("width", format!("must be 2, 4 or 8, got '{s}'")))?;
        n.try_into()
    }
}

impl std::fmt::Display for BvhWidth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.get())
    }
}

/// Child reference of an unused slot. Its box is empty (min = +inf, max = -inf), which every
/// box test rejects, so traversal needs no separate validity mask.
pub const EMPTY_CHILD: u32 = u32::MAX;

/// One wide node. `bounds[0..3]` are the children's min x/y/z, `bounds[3..6]` their max x/y/z.
/// Slot `i` is a leaf of `count[i]` triangles starting at slot `child[i]` of the triangle array
/// when `count[i] > 0`, an interior node at index `child[i]` when `count[i] == 0`, and unused
/// when `child[i] == EMPTY_CHILD`. Cache-line aligned: 64 bytes for N = 2, 128 for N = 4,
/// 256 for N = 8 (24 bytes of that are padding).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct WideNode<const N: usize> {
    pub bounds: [[f32; N]; 6],
    pub child: [u32; N],
    pub count: [u8; N],
}

impl<const N: usize> Default for WideNode<N> {
    fn default() -> Self {
        let mut bounds = [[0.0; N]; 6];
        for (axis, row) in bounds.iter_mut().enumerate() {
            *row = [if axis < 3 {
                f32::INFINITY
            } else {
                f32::NEG_INFINITY
            }; N];
        }
        WideNode {
            bounds,
            child: [EMPTY_CHILD; N],
            count: [0; N],
        }
    }
}

impl<const N: usize> WideNode<N> {
    #[inline(always)]
    pub fn is_empty_slot(&self, slot: usize) -> bool {
        self.child[slot] == EMPTY_CHILD
    }
    #[inline(always)]
    pub fn is_leaf_slot(&self, slot: usize) -> bool {
        self.count[slot] > 0
    }
    /// Number of used slots.
    pub fn arity(&self) -> usize {
        (0..N).filter(|&s| !self.is_empty_slot(s)).count()
    }
    pub fn child_bounds(&self, slot: usize) -> Aabb {
        let b = &self.bounds;
        Aabb::new(
            Vec3::new(b[0][slot], b[1][slot], b[2][slot]),
            Vec3::new(b[3][slot], b[4][slot], b[5][slot]),
        )
    }
    fn set_child_bounds(&mut self, slot: usize, a: &Aabb) {
        let (lo, hi) = (a.min.to_array(), a.max.to_array());
        for axis in 0..3 {
            self.bounds[axis][slot] = lo[axis];
            self.bounds[3 + axis][slot] = hi[axis];
        }
    }
}

/// An N-wide BVH. Node 0 is the root; every child index is larger than its parent's, so a
/// reverse sweep over the nodes visits children before parents. Triangles are the binary
/// BVH's, in the same leaf order.
#[derive(Clone, Debug, Default)]
pub struct WideBvh<const N: usize> {
    pub nodes: Vec<WideNode<N>>,
    /// Bounds of the whole tree (the root node's box).
    pub root_bounds: Aabb,
    pub triangles: Vec<[Vec3; 3]>,
    /// The same triangles as rows for the four-lane leaf test.
    pub triangle_rows: TriangleRows,
    pub triangle_ids: Vec<u32>,
    /// Per node: the parent's index and the slot this node occupies in it (root: `u32::MAX`).
    pub parent: Vec<(u32, u8)>,
    /// Per node: its depth (root = 0).
    pub depth: Vec<u16>,
    /// Time of the collapse in milliseconds (the binary build is not included).
    pub collapse_ms: f64,
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

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Memory of the structure: nodes, triangles and their ids (not the parent/depth tables,
    /// which only the per-light sorting reads).
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<WideNode<N>>()
            + self.triangles.len() * std::mem::size_of::<[Vec3; 3]>()
            + self.triangle_rows.bytes()
            + self.triangle_ids.len() * 4
    }

    /// Checks the invariants: every triangle slot in exactly one leaf, children inside their
    /// parent's box, triangles inside their leaf's box, children numbered after parents.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if self.nodes.is_empty() {
            return if self.triangles.is_empty() {
                Ok(())
            } else {
                Err("triangles but no nodes".into())
            };
        }
        let mut seen = vec![false; self.triangles.len()];
        let mut stack = vec![(0usize, self.root_bounds)];
        while let Some((i, outer)) = stack.pop() {
            let node = self.nodes.get(i).ok_or(format!("node {i} out of range"))?;
            if node.arity() == 0 {
                return Err(format!("node {i} has no children"));
            }
            for s in (0..N).filter(|&s| !node.is_empty_slot(s)) {
                let b = node.child_bounds(s);
                if !outer.contains(&b) {
                    return Err(format!("child {s} of node {i} outside its parent"));
                }
                if node.is_leaf_slot(s) {
                    let range =
                        node.child[s] as usize..(node.child[s] + node.count[s] as u32) as usize;
                    let (flags, tris) = (&mut seen[range.clone()], &self.triangles[range.clone()]);
                    for ((t, flag), tri) in range.zip(flags).zip(tris) {
                        if std::mem::replace(flag, true) {
                            return Err(format!("triangle slot {t} in two leaves"));
                        }
                        if !b.contains(&Aabb::of_triangle(tri)) {
                            return Err(format!("triangle slot {t} outside its leaf"));
                        }
                    }
                } else {
                    let c = node.child[s] as usize;
                    if c <= i {
                        return Err(format!("child {c} numbered before its parent {i}"));
                    }
                    if self.parent.get(c) != Some(&(i as u32, s as u8)) {
                        return Err(format!("parent table wrong for node {c}"));
                    }
                    stack.push((c, b));
                }
            }
        }
        match seen.iter().position(|s| !s) {
            Some(t) => Err(format!("triangle slot {t} in no leaf")),
            None => Ok(()),
        }
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
