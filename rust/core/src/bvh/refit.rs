//! Refit: a tree keeps its topology and takes new triangle positions, every box recomputed
//! bottom-up as the union of its triangles' or children's boxes, the builders' own construction
//! (exact min/max, no rounding), so a refit tree is as conservative as a built one.

use glam::Vec3;

use super::{Bvh, TriangleRows, WideBvh, WideNode};
use crate::geometry::Aabb;

impl Bvh {
    /// Takes `triangles` (by the ids the tree was built over, the same set) into its leaf order
    /// and recomputes every node's box.
    pub fn refit(&mut self, triangles: &[[Vec3; 3]]) {
        for (slot, &id) in self.triangles.iter_mut().zip(&self.triangle_ids) {
            *slot = triangles[id as usize];
        }
        if self.nodes.is_empty() {
            return;
        }
        // Pre-order from the root (the pad node is never reached), then children before parents.
        let mut order = Vec::with_capacity(self.nodes.len());
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            order.push(i);
            let n = &self.nodes[i];
            if !n.is_leaf() {
                stack.extend([n.first as usize, n.first as usize + 1]);
            }
        }
        let leaf_triangles = &self.triangles;
        let nodes = self.nodes.as_mut_slice();
        for &i in order.iter().rev() {
            let n = nodes[i];
            let b = if n.is_leaf() {
                triangles_box(&leaf_triangles[n.first as usize..(n.first + n.count) as usize])
            } else {
                let c = n.first as usize;
                nodes[c].bounds().union(&nodes[c + 1].bounds())
            };
            nodes[i].set_bounds(&b);
        }
    }
}

impl<const N: usize> WideBvh<N> {
    /// Takes `triangles` in the tree's leaf order (the refit binary tree's) and recomputes every
    /// child box; children are numbered after their parents, so one reverse sweep does it.
    pub fn refit(&mut self, triangles: &[[Vec3; 3]]) {
        self.triangles.copy_from_slice(triangles);
        self.triangle_rows = TriangleRows::new(triangles);
        for i in (0..self.nodes.len()).rev() {
            for s in 0..N {
                let node = &self.nodes[i];
                if node.is_empty_slot(s) {
                    continue;
                }
                let first = node.child[s] as usize;
                let b = if node.is_leaf_slot(s) {
                    triangles_box(&self.triangles[first..first + node.count[s] as usize])
                } else {
                    node_box(&self.nodes[first])
                };
                self.nodes[i].set_child_bounds(s, &b);
            }
        }
        if let Some(root) = self.nodes.first() {
            self.root_bounds = node_box(root);
        }
    }
}

fn triangles_box(triangles: &[[Vec3; 3]]) -> Aabb {
    triangles
        .iter()
        .fold(Aabb::EMPTY, |b, t| b.union(&Aabb::of_triangle(t)))
}

/// The box of a wide node: the union of its used slots.
fn node_box<const N: usize>(node: &WideNode<N>) -> Aabb {
    (0..N)
        .filter(|&s| !node.is_empty_slot(s))
        .fold(Aabb::EMPTY, |b, s| b.union(&node.child_bounds(s)))
}
