//! The SRDH cost of one candidate node (section 3.3): per ray that reaches the node, each child
//! costs its triangle count if the ray pierces the child's box and is not stopped first by a hit
//! in the sibling visited before it. Subtrees are approximated as linear in their triangles.
//! Counts are integers, so sums are exact and comparisons between candidates are exact too.

use glam::Vec3;

use super::ray_set::RaySet;
use crate::geometry::{Aabb, Ray, RayBoxPrecomp};
use crate::order::Kernel;

/// One ray's term: `(1 - !κ·H2)·I1·n1 + (1 - κ·H1)·I2·n2`, κ = `left_first`.
#[inline(always)]
pub fn ray_term(left_first: bool, pierce: [bool; 2], hit: [bool; 2], count: [u64; 2]) -> u64 {
    let reach_left = pierce[0] && (left_first || !hit[1]);
    let reach_right = pierce[1] && (!left_first || !hit[0]);
    reach_left as u64 * count[0] + reach_right as u64 * count[1]
}

/// Whether `ray` pierces `b` as the traversal tests it (segment widened by the box margin).
#[inline(always)]
pub fn pierces(pre: &RayBoxPrecomp, ray: &Ray, b: &Aabb) -> bool {
    pre.hit(b.min, b.max, ray.t_min, ray.t_max + pre.t_margin)
        .is_some()
}

/// The reference evaluation from explicit triangle sets, for tests: the SRDH cost of splitting
/// into `left` and `right` with `kernel`, over the rays `reaching` (indices into `set`).
pub fn reference_cost(
    triangles: &[[Vec3; 3]],
    left: &[u32],
    right: &[u32],
    kernel: Kernel,
    set: &RaySet,
    reaching: &[usize],
) -> u64 {
    let bounds = |ids: &[u32]| {
        ids.iter().fold(Aabb::EMPTY, |b, &i| {
            b.union(&Aabb::of_triangle(&triangles[i as usize]))
        })
    };
    let (bl, br) = (bounds(left), bounds(right));
    let count = [left.len() as u64, right.len() as u64];
    reaching
        .iter()
        .map(|&i| {
            let ray = &set.rays[i];
            let pre = RayBoxPrecomp::new(ray);
            let hits = set.hits(i);
            let hit = [
                left.iter().any(|t| hits.contains(t)),
                right.iter().any(|t| hits.contains(t)),
            ];
            let lf = kernel.left_first(ray.origin, bl.center(), br.center());
            ray_term(
                lf,
                [pierces(&pre, ray, &bl), pierces(&pre, ray, &br)],
                hit,
                count,
            )
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn terms_follow_the_heuristic() {
        // Left first and a hit on the left: the right child is never reached.
        assert_eq!(ray_term(true, [true, true], [true, false], [3, 5]), 3);
        // Right first, hit on the right: the left child is skipped.
        assert_eq!(ray_term(false, [true, true], [false, true], [3, 5]), 5);
        // No hit: both pierced children are paid for, whatever the order.
        assert_eq!(ray_term(false, [true, true], [false, false], [3, 5]), 8);
        assert_eq!(ray_term(true, [false, true], [false, false], [3, 5]), 5);
    }
}
