//! The structural check of trees whose leaves may reference a triangle several times (spatial
//! splits): a leaf's box need only hold the triangle's clipped part, so [`Bvh::validate`] does
//! not apply; instead every triangle must be covered by the boxes of the leaves that hold it.

use glam::Vec3;

use super::clip::clipped_box;
use super::primref::Box4;
use crate::bvh::{Bvh, MAX_DEPTH};

/// Checks that every slot is in exactly one leaf and holds its triangle, children nest in their
/// parents, each leaf box holds a part of each of its triangles, and every triangle is covered:
/// sample points on it (vertices, edge points, interior points) each lie in the box of a leaf
/// that references it, within `tolerance`.
pub fn check_references(
    bvh: &Bvh,
    triangles: &[[Vec3; 3]],
    tolerance: f32,
) -> std::result::Result<(), String> {
    let mut leaf_boxes: Vec<Vec<(Vec3, Vec3)>> = vec![Vec::new(); triangles.len()];
    let mut seen = vec![false; bvh.triangles.len()];
    let mut stack = vec![(0usize, 0usize)];
    while let Some((i, depth)) = stack.pop().filter(|_| !bvh.nodes.is_empty()) {
        if depth > MAX_DEPTH {
            return Err(format!("node {i} deeper than {MAX_DEPTH}"));
        }
        let n = bvh.nodes.get(i).ok_or(format!("node {i} out of range"))?;
        if n.is_leaf() {
            for slot in n.first as usize..(n.first + n.count) as usize {
                if std::mem::replace(seen.get_mut(slot).ok_or("slot out of range")?, true) {
                    return Err(format!("slot {slot} in two leaves"));
                }
                let id = bvh.triangle_ids[slot] as usize;
                let tri = triangles.get(id).ok_or(format!("id {id} out of range"))?;
                if bvh.triangles[slot] != *tri {
                    return Err(format!("slot {slot} does not hold triangle {id}"));
                }
                if !holds_part(n.min(), n.max(), tri) {
                    return Err(format!("leaf {i} holds no part of triangle {id}"));
                }
                leaf_boxes[id].push((n.min(), n.max()));
            }
        } else {
            for c in [n.first as usize, n.first as usize + 1] {
                let child = bvh.nodes.get(c).ok_or(format!("child {c} out of range"))?;
                if !n.bounds().contains(&child.bounds()) {
                    return Err(format!("child {c} outside parent {i}"));
                }
                stack.push((c, depth + 1));
            }
        }
    }
    if let Some(s) = seen.iter().position(|s| !s) {
        return Err(format!("slot {s} in no leaf"));
    }
    const STEPS: u32 = 6;
    for (id, tri) in triangles.iter().enumerate() {
        for i in 0..=STEPS {
            for j in 0..=STEPS - i {
                let (a, b) = (i as f32 / STEPS as f32, j as f32 / STEPS as f32);
                let p = tri[0] * (1.0 - a - b) + tri[1] * a + tri[2] * b;
                let inside = leaf_boxes[id].iter().any(|(lo, hi)| {
                    (p - *lo).min_element() >= -tolerance && (*hi - p).min_element() >= -tolerance
                });
                if !inside {
                    return Err(format!(
                        "point {p} of triangle {id} in no leaf that holds it"
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Whether some part of `tri` lies in the box (the triangle clipped to its three slabs).
fn holds_part(lo: Vec3, hi: Vec3, tri: &[Vec3; 3]) -> bool {
    let mut within = Box4 {
        lo: lo.extend(0.0),
        hi: hi.extend(0.0),
    };
    for axis in 0..3 {
        within = clipped_box(tri, axis, lo[axis], hi[axis], &within);
        if within.lo.x > within.hi.x {
            return false;
        }
    }
    true
}
