use glam::Vec3;

use crate::geometry::Aabb;

/// Deepest tree any builder may produce; traversal stacks are this deep. The builders switch to
/// object-median splits past `MAX_DEPTH - 32` levels, which then end within 32 more (u32 counts).
pub const MAX_DEPTH: usize = 96;

/// A binary BVH node in 32 bytes (half a cache line): bounds, and either the index of the first
/// of two adjacent children (`count == 0`) or a range of triangles in leaf order.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub struct BvhNode {
    pub min: [f32; 3],
    /// Interior: index of the left child (the right child follows it). Leaf: first triangle slot.
    pub first: u32,
    pub max: [f32; 3],
    /// 0 for interior nodes, else the number of triangles in the leaf.
    pub count: u32,
}

impl BvhNode {
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
    #[inline(always)]
    pub fn min(&self) -> Vec3 {
        Vec3::from_array(self.min)
    }
    #[inline(always)]
    pub fn max(&self) -> Vec3 {
        Vec3::from_array(self.max)
    }
    /// The node as eight floats `[min.x, min.y, min.z, first, max.x, max.y, max.z, count]`,
    /// the layout [`crate::geometry::RayBoxPrecomp::hit_packed`] reads with two vector loads.
    #[inline(always)]
    pub fn packed(&self) -> &[f32; 8] {
        // SAFETY: `BvhNode` is `repr(C)` with eight 4-byte fields and no padding, and every bit
        // pattern is a valid f32 (the two u32 lanes are never used as numbers).
        unsafe { &*(self as *const BvhNode as *const [f32; 8]) }
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.min(), self.max())
    }
    pub(crate) fn set_bounds(&mut self, b: &Aabb) {
        self.min = b.min.to_array();
        self.max = b.max.to_array();
    }
}

const _: () = assert!(std::mem::size_of::<BvhNode>() == 32);

/// Two sibling nodes in one 64-byte cache line.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
struct NodePair([BvhNode; 2]);

/// The node array of a BVH, allocated so that every sibling pair (indices 2k, 2k+1) shares one
/// cache line: a traversal step reads both children with one line fill. Index 0 is the root,
/// index 1 an unused pad node (never referenced), children pairs start at index 2.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeArray {
    pairs: Vec<NodePair>,
    len: usize,
}

impl NodeArray {
    /// Takes nodes laid out as described above (sibling pairs at even indices).
    pub fn from_nodes(nodes: &[BvhNode]) -> Self {
        let pairs = nodes
            .chunks(2)
            .map(|c| NodePair([c[0], c.get(1).copied().unwrap_or_default()]))
            .collect();
        NodeArray {
            pairs,
            len: nodes.len(),
        }
    }

    /// `len` default nodes from zeroed memory, for builders that write every node in place (in
    /// parallel: the pages fault in on the threads that write them).
    pub(crate) fn zeroed(len: usize) -> Self {
        // SAFETY: every field of a `NodePair` is an f32 or u32, for which all-zero bits are the
        // value 0, i.e. `NodePair::default()`.
        let pairs = unsafe { zeroed_vec::<NodePair>(len.div_ceil(2)) };
        NodeArray { pairs, len }
    }

    /// The nodes, to write in place.
    pub(crate) fn as_mut_slice(&mut self) -> &mut [BvhNode] {
        // SAFETY: as in `Deref`, with the unique borrow of the pairs.
        unsafe { std::slice::from_raw_parts_mut(self.pairs.as_mut_ptr() as *mut BvhNode, self.len) }
    }
}

/// `count` values from zeroed memory: the allocator hands out untouched pages, so they are
/// faulted in by the (parallel) builders that write them instead of filled on one thread.
///
/// # Safety
/// All-zero bits must be a valid `T`.
pub(crate) unsafe fn zeroed_vec<T>(count: usize) -> Vec<T> {
    let layout = std::alloc::Layout::array::<T>(count).expect("array size");
    if layout.size() == 0 {
        return Vec::new();
    }
    // SAFETY: the layout is non-empty and is the one `Vec<T>` frees with (same element type and
    // capacity); the caller vouches for the zeroed values.
    unsafe {
        let ptr = std::alloc::alloc_zeroed(layout) as *mut T;
        if ptr.is_null() {
            std::alloc::handle_alloc_error(layout);
        }
        Vec::from_raw_parts(ptr, count, count)
    }
}

impl std::ops::Deref for NodeArray {
    type Target = [BvhNode];
    fn deref(&self) -> &[BvhNode] {
        // SAFETY: `NodePair` is `repr(C)` holding exactly two `BvhNode`s with no padding
        // (2 x 32 bytes = its 64-byte alignment), so the pairs are `2 * pairs.len()` contiguous
        // nodes, and `len <= 2 * pairs.len()`.
        unsafe { std::slice::from_raw_parts(self.pairs.as_ptr() as *const BvhNode, self.len) }
    }
}

const _: () = assert!(std::mem::size_of::<NodePair>() == 64);

/// A binary BVH over a triangle set. Node 0 is the root (see [`NodeArray`] for the layout). Triangles are copied in leaf order so a
/// leaf's triangles are contiguous in memory; `triangle_ids` maps a slot back to the id in the
/// `TriangleSet` the BVH was built from.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub nodes: NodeArray,
    pub triangles: Vec<[Vec3; 3]>,
    pub triangle_ids: Vec<u32>,
    /// Wall-clock build time in milliseconds.
    pub build_ms: f64,
}

impl Bvh {
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Memory of the structure: nodes, leaf-ordered triangles and their ids.
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<BvhNode>()
            + self.triangles.len() * std::mem::size_of::<[Vec3; 3]>()
            + self.triangle_ids.len() * 4
    }

    pub fn leaf_count(&self) -> usize {
        self.nodes.iter().filter(|n| n.is_leaf()).count()
    }

    /// Depth of the deepest leaf (the root is depth 0).
    pub fn depth(&self) -> usize {
        if self.nodes.is_empty() {
            return 0;
        }
        let mut deepest = 0;
        let mut stack = vec![(0usize, 0usize)];
        while let Some((i, d)) = stack.pop() {
            deepest = deepest.max(d);
            let n = &self.nodes[i];
            if !n.is_leaf() {
                stack.push((n.first as usize, d + 1));
                stack.push((n.first as usize + 1, d + 1));
            }
        }
        deepest
    }

    /// SAH cost of the tree with the given unit costs, relative to the root's area.
    pub fn sah_cost(&self, traversal_cost: f32, intersection_cost: f32) -> f32 {
        let Some(root) = self.nodes.first() else {
            return 0.0;
        };
        let root_area = root.bounds().half_area().max(f32::MIN_POSITIVE);
        self.nodes
            .iter()
            .map(|n| {
                let a = n.bounds().half_area() / root_area;
                if n.is_leaf() {
                    a * intersection_cost * n.count as f32
                } else {
                    a * traversal_cost
                }
            })
            .sum()
    }

    /// Checks the structural invariants: every triangle slot in exactly one leaf, children inside
    /// their parents, every triangle inside its leaf's box, depth within `MAX_DEPTH`.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if self.triangles.is_empty() {
            return Ok(());
        }
        let mut seen = vec![false; self.triangles.len()];
        let mut stack = vec![(0usize, 0usize)];
        while let Some((i, depth)) = stack.pop() {
            if depth > MAX_DEPTH {
                return Err(format!("node {i} deeper than {MAX_DEPTH}"));
            }
            let n = self.nodes.get(i).ok_or(format!("node {i} out of range"))?;
            let b = n.bounds();
            if n.is_leaf() {
                for slot in n.first..n.first + n.count {
                    let s = slot as usize;
                    if std::mem::replace(&mut seen[s], true) {
                        return Err(format!("triangle slot {s} in two leaves"));
                    }
                    if !b.contains(&Aabb::of_triangle(&self.triangles[s])) {
                        return Err(format!("triangle slot {s} outside leaf {i}"));
                    }
                }
            } else {
                for c in [n.first as usize, n.first as usize + 1] {
                    let child = self.nodes.get(c).ok_or(format!("child {c} out of range"))?;
                    if !b.contains(&child.bounds()) {
                        return Err(format!("child {c} outside parent {i}"));
                    }
                    stack.push((c, depth + 1));
                }
            }
        }
        match seen.iter().position(|s| !s) {
            Some(s) => Err(format!("triangle slot {s} in no leaf")),
            None => Ok(()),
        }
    }
}
