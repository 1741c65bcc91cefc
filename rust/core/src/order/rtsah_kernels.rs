//! Kernels for the SAH tree that the SRDH is compared with: RTSAH (Ize & Hansen 2011) as one
//! constant kernel per node, from geometry alone, with the same estimates as the wide trees'
//! RTSAH order (`static_orders::rtsah`) restricted to two children.

use super::kernel::{Kernel, PackedKernels};
use crate::bvh::Bvh;

/// Per node: left first unless the right child's termination probability over cost is higher.
pub fn rtsah_kernels(bvh: &Bvh) -> PackedKernels {
    let nodes = &bvh.nodes;
    let mut kernels = vec![Kernel::LeftFirst; nodes.len()];
    if nodes.is_empty() {
        return PackedKernels::from_kernels(&kernels);
    }
    // Pre-order, then reversed: children before parents.
    let mut order = Vec::with_capacity(nodes.len());
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        order.push(i);
        if !nodes[i].is_leaf() {
            stack.extend([nodes[i].first as usize, nodes[i].first as usize + 1]);
        }
    }
    // (probability a ray entering the box is stopped inside, expected cost)
    let mut est = vec![(0.0f64, 0.0f64); nodes.len()];
    let area = |i: usize| nodes[i].bounds().half_area().max(f32::MIN_POSITIVE) as f64;
    for &i in order.iter().rev() {
        let n = &nodes[i];
        if n.is_leaf() {
            let first = n.first as usize;
            let tri_area: f64 = bvh.triangles[first..first + n.count as usize]
                .iter()
                .map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length() as f64)
                .sum();
            est[i] = ((tri_area / area(i)).min(1.0), 1.0 + n.count as f64);
            continue;
        }
        let (a, b) = (n.first as usize, n.first as usize + 1);
        let s = area(i);
        let (pa, pb) = (area(a) / s, area(b) / s);
        let (qa, ca) = (pa * est[a].0, pa * est[a].1);
        let (qb, cb) = (pb * est[b].0, pb * est[b].1);
        let a_first = qa * cb >= qb * ca;
        kernels[i] = if a_first {
            Kernel::LeftFirst
        } else {
            Kernel::RightFirst
        };
        let cost = if a_first {
            ca + (1.0 - qa) * cb
        } else {
            cb + (1.0 - qb) * ca
        };
        est[i] = (1.0 - (1.0 - qa) * (1.0 - qb), 1.0 + cost);
    }
    PackedKernels::from_kernels(&kernels)
}
