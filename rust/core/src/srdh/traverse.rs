//! Kernel-guided any-hit traversal (the paper's `anyhit_traverse`): a child's box is tested only
//! when the traversal enters it, so a ray stopped in the first child never tests the second's
//! box. The node's kernel decides which child is entered first. The same traversal with other
//! kernel sources gives the baselines (random, front to back, back to front, RTSAH).

use glam::Vec3;

use super::kernel::{Kernel, PackedKernels};
use crate::bvh::{Bvh, BvhNode, MAX_DEPTH};
use crate::geometry::{intersect_triangle, Ray, RayBoxPrecomp, WatertightRay};
use crate::sampling::{hash_combine, hash_u32};
use crate::trace::Counters;

/// Chooses, per interior node and ray, whether the left child is entered first.
pub trait KernelSource: Sync {
    /// Whether `left_first` reads the ray key (only then is it computed).
    const NEEDS_KEY: bool = false;
    fn left_first(&self, node: usize, ray_key: u32, origin: Vec3, l: &BvhNode, r: &BvhNode)
        -> bool;
}

impl KernelSource for PackedKernels {
    #[inline(always)]
    fn left_first(&self, node: usize, _: u32, origin: Vec3, l: &BvhNode, r: &BvhNode) -> bool {
        self.get(node).left_first_nodes(origin, l, r)
    }
}

/// The same kernel at every node.
#[derive(Clone, Copy, Debug)]
pub struct Uniform(pub Kernel);

impl KernelSource for Uniform {
    #[inline(always)]
    fn left_first(&self, _: usize, _: u32, origin: Vec3, l: &BvhNode, r: &BvhNode) -> bool {
        self.0.left_first_nodes(origin, l, r)
    }
}

/// A fair coin per node and ray (the paper's random order, κ = 0.5), seeded and repeatable.
#[derive(Clone, Copy, Debug)]
pub struct RandomKernel {
    pub seed: u32,
}

impl KernelSource for RandomKernel {
    const NEEDS_KEY: bool = true;
    #[inline(always)]
    fn left_first(&self, node: usize, ray_key: u32, _: Vec3, _: &BvhNode, _: &BvhNode) -> bool {
        hash_combine(hash_combine(self.seed, ray_key), node as u32) & 1 == 0
    }
}

/// A key that identifies a ray for [`RandomKernel`] (its bits hashed).
pub fn ray_key(ray: &Ray) -> u32 {
    let mut h = hash_u32(ray.t_max.to_bits());
    for v in [ray.origin, ray.direction] {
        for c in v.to_array() {
            h = hash_combine(h, c.to_bits());
        }
    }
    h
}

/// True if any triangle intersects the ray in (t_min, t_max].
#[inline]
pub fn occluded_with<K: KernelSource, C: Counters>(
    bvh: &Bvh,
    kernels: &K,
    ray: &Ray,
    stats: &mut C,
) -> bool {
    occluding_leaf(bvh, kernels, ray, stats).is_some()
}

/// The leaf (node index) whose triangle stopped the ray, `None` if nothing did.
#[inline]
pub fn occluding_leaf<K: KernelSource, C: Counters>(
    bvh: &Bvh,
    kernels: &K,
    ray: &Ray,
    stats: &mut C,
) -> Option<usize> {
    let nodes = &bvh.nodes;
    if nodes.is_empty() {
        return None;
    }
    let pre = RayBoxPrecomp::new(ray);
    let wt = WatertightRay::new(ray);
    let t_min = ray.t_min;
    // Box tests reach a margin past the segment's end; triangle tests do not.
    let t_box = ray.t_max + pre.t_margin;
    let key = if K::NEEDS_KEY { ray_key(ray) } else { 0 };
    // Each interior node pushes two and pops one: depth + 2 entries suffice.
    let mut stack = [0u32; MAX_DEPTH + 2];
    let mut sp = 1usize;
    while sp > 0 {
        sp -= 1;
        let i = stack[sp] as usize;
        let node = &nodes[i];
        stats.boxes(1);
        if pre.hit_packed(node.packed(), t_min, t_box).is_none() {
            continue;
        }
        if node.is_leaf() {
            stats.leaf();
            let first = node.first as usize;
            for slot in first..first + node.count as usize {
                stats.triangles(1);
                if intersect_triangle(&wt, &bvh.triangles[slot], t_min, ray.t_max).is_some() {
                    return Some(i);
                }
            }
        } else {
            stats.inner();
            let l = node.first;
            let lf = kernels.left_first(
                i,
                key,
                ray.origin,
                &nodes[l as usize],
                &nodes[l as usize + 1],
            );
            let (first, second) = if lf { (l, l + 1) } else { (l + 1, l) };
            stack[sp] = second;
            stack[sp + 1] = first;
            sp += 2;
        }
    }
    None
}
