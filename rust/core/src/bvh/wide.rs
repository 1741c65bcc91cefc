//! N-wide BVH (N = 2, 4, 8) with the node layout SIMD traversal reads: per node the bounds of
//! all N children as six rows of N floats (min x/y/z, max x/y/z), so one vector load per row
//! tests every child at once. Made from a binary BVH by the collapse in `build::collapse`.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::TriangleRows;
use crate::geometry::Aabb;

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
    pub(crate) fn set_child_bounds(&mut self, slot: usize, a: &Aabb) {
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
