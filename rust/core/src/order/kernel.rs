//! Traversal-order kernels of binary trees: per interior node, which child a shadow ray visits
//! first. The SRDH builder picks one of these per node; the baselines assign one to every node
//! of a tree (one kernel everywhere, a coin per node and ray, or RTSAH's constants).

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::child_order::{ChildOrder, Children, OrderRay};
use crate::bvh::BvhNode;
use crate::sampling::hash_combine;

/// The four {0,1}-valued kernels of the paper's section 3.4 (2 bits each).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Kernel {
    LeftFirst = 0,
    RightFirst = 1,
    /// The child whose box centre is nearer the ray origin first (ties: left).
    FrontToBack = 2,
    /// The child whose box centre is farther from the ray origin first (ties: right).
    BackToFront = 3,
}

impl Kernel {
    pub const ALL: [Kernel; 4] = [
        Kernel::LeftFirst,
        Kernel::RightFirst,
        Kernel::FrontToBack,
        Kernel::BackToFront,
    ];

    #[inline(always)]
    fn from_bits(b: u8) -> Kernel {
        match b & 3 {
            0 => Kernel::LeftFirst,
            1 => Kernel::RightFirst,
            2 => Kernel::FrontToBack,
            _ => Kernel::BackToFront,
        }
    }

    /// Whether a ray from `origin` visits the child with centre `left` before the one with
    /// centre `right`. Builder and traversal both call this, so their decisions agree.
    #[inline(always)]
    pub fn left_first(self, origin: Vec3, left: Vec3, right: Vec3) -> bool {
        match self {
            Kernel::LeftFirst => true,
            Kernel::RightFirst => false,
            Kernel::FrontToBack => origin.distance_squared(left) <= origin.distance_squared(right),
            Kernel::BackToFront => origin.distance_squared(left) > origin.distance_squared(right),
        }
    }

    /// [`Kernel::left_first`] for two sibling nodes.
    #[inline(always)]
    pub fn left_first_nodes(self, origin: Vec3, left: &BvhNode, right: &BvhNode) -> bool {
        match self {
            Kernel::LeftFirst => true,
            Kernel::RightFirst => false,
            _ => self.left_first(origin, centre(left), centre(right)),
        }
    }

    /// [`Kernel::left_first`] for the children in slots `a` (left) and `b` (right); the
    /// centres are only read by the directional kernels.
    #[inline(always)]
    fn left_first_children<K: Children>(self, origin: Vec3, a: usize, b: usize, c: &K) -> bool {
        match self {
            Kernel::LeftFirst => true,
            Kernel::RightFirst => false,
            _ => self.left_first(origin, c.centre(a), c.centre(b)),
        }
    }
}

/// A node's box centre, computed as the builder computes it from the same f32 bounds.
#[inline(always)]
pub fn centre(n: &BvhNode) -> Vec3 {
    (n.min() + n.max()) * 0.5
}

/// Which kernels the builder may choose (the paper's Figure 5 compares these).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum KernelSet {
    /// Left-first, right-first, front-to-back, back-to-front.
    #[default]
    All,
    /// Left-first and right-first only.
    Constant,
    /// Front-to-back and back-to-front only.
    Directional,
}

impl KernelSet {
    pub fn kernels(self) -> &'static [Kernel] {
        match self {
            KernelSet::All => &Kernel::ALL,
            KernelSet::Constant => &[Kernel::LeftFirst, Kernel::RightFirst],
            KernelSet::Directional => &[Kernel::FrontToBack, Kernel::BackToFront],
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            KernelSet::All => "all",
            KernelSet::Constant => "constant",
            KernelSet::Directional => "directional",
        }
    }
}

/// One kernel per node, 2 bits each (four per byte).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PackedKernels {
    bits: Vec<u8>,
}

impl PackedKernels {
    pub fn from_kernels(kernels: &[Kernel]) -> Self {
        let mut bits = vec![0u8; kernels.len().div_ceil(4)];
        for (i, k) in kernels.iter().enumerate() {
            bits[i / 4] |= (*k as u8) << (2 * (i % 4));
        }
        PackedKernels { bits }
    }
    /// The kernel of node `i`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> Kernel {
        Kernel::from_bits(self.bits[i / 4] >> (2 * (i % 4)))
    }
    pub fn bytes(&self) -> usize {
        self.bits.len()
    }
}

/// The SRDH tree's kernels, one per node.
impl ChildOrder for PackedKernels {
    const TEST_ON_ENTRY: bool = true;
    #[inline(always)]
    fn second_first<K: Children>(
        &self,
        node: usize,
        a: usize,
        b: usize,
        ray: &OrderRay,
        children: &K,
    ) -> bool {
        !self
            .get(node)
            .left_first_children(ray.origin, a, b, children)
    }
}

/// The same kernel at every node.
#[derive(Clone, Copy, Debug)]
pub struct Uniform(pub Kernel);

impl ChildOrder for Uniform {
    const TEST_ON_ENTRY: bool = true;
    #[inline(always)]
    fn second_first<K: Children>(
        &self,
        _: usize,
        a: usize,
        b: usize,
        ray: &OrderRay,
        children: &K,
    ) -> bool {
        !self.0.left_first_children(ray.origin, a, b, children)
    }
}

/// A fair coin per node and ray (the SRDH paper's random order, κ = 0.5), seeded and
/// repeatable.
#[derive(Clone, Copy, Debug)]
pub struct RandomKernel {
    pub seed: u32,
}

impl ChildOrder for RandomKernel {
    const TEST_ON_ENTRY: bool = true;
    const NEEDS_KEY: bool = true;
    #[inline(always)]
    fn second_first<K: Children>(
        &self,
        node: usize,
        _: usize,
        _: usize,
        ray: &OrderRay,
        _: &K,
    ) -> bool {
        hash_combine(hash_combine(self.seed, ray.key), node as u32) & 1 != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packing_round_trips() {
        let ks: Vec<Kernel> = (0..11).map(|i| Kernel::ALL[(i * 7 + 3) % 4]).collect();
        let p = PackedKernels::from_kernels(&ks);
        assert_eq!(p.bytes(), 3);
        for (i, k) in ks.iter().enumerate() {
            assert_eq!(p.get(i), *k);
        }
    }
}
