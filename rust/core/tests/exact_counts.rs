//! Exact traversal counts on a three-triangle scene whose tree and counts are derived by hand.
//!
//! Triangles A, B, C are unit squares' halves in the planes x = 0, x = 10 and x = 11. With one
//! triangle per leaf the SAH puts A alone on the left (the gap between 0 and 10 makes any other
//! split far more expensive) and B, C under a second interior node:
//!
//! ```text
//!        root
//!       /    \
//!    leaf A   inner
//!            /     \
//!        leaf B   leaf C
//! ```

use antumbra_core::build::{build_binned_sah, BuildSettings};
use antumbra_core::bvh::Bvh;
use antumbra_core::geometry::Ray;
use antumbra_core::order::AnyHitOrder;
use antumbra_core::trace::{OrderedBinary, RayQuery, TraversalStats};
use glam::Vec3;

fn scene() -> Bvh {
    let tri = |x: f32| {
        [
            Vec3::new(x, 0.0, 0.0),
            Vec3::new(x, 1.0, 0.0),
            Vec3::new(x, 0.0, 1.0),
        ]
    };
    let settings = BuildSettings {
        max_leaf_size: 1,
        ..BuildSettings::default()
    };
    build_binned_sah(&[tri(0.0), tri(10.0), tri(11.0)], &settings)
}

fn stats(inner: u64, leaves: u64, triangles: u64, boxes: u64) -> TraversalStats {
    TraversalStats {
        inner,
        leaves,
        triangles,
        boxes,
        ..TraversalStats::default()
    }
}

#[test]
fn tree_has_the_derived_shape() {
    let bvh = scene();
    // Root, the pad node that keeps sibling pairs in one cache line, and four nodes.
    assert_eq!(bvh.nodes.len(), 6);
    let root = bvh.nodes[0];
    assert!(!root.is_leaf());
    let (l, r) = (
        bvh.nodes[root.first as usize],
        bvh.nodes[root.first as usize + 1],
    );
    assert!(l.is_leaf() && l.count == 1);
    assert_eq!(
        bvh.triangle_ids[l.first as usize], 0,
        "A is alone on the left"
    );
    assert!(!r.is_leaf());
    let (b, c) = (bvh.nodes[r.first as usize], bvh.nodes[r.first as usize + 1]);
    assert_eq!(bvh.triangle_ids[b.first as usize], 1);
    assert_eq!(bvh.triangle_ids[c.first as usize], 2);
}

#[test]
fn closest_hit_from_the_left() {
    // Root box (1 test); root: both children (2 tests), A nearer. Leaf A: 1 triangle, hit at
    // t = 1. The B/C subtree (entry t = 11) is culled when it comes off the stack.
    let bvh = scene();
    let ray = Ray::new(Vec3::new(-1.0, 0.25, 0.25), Vec3::X, 0.0, f32::INFINITY);
    let mut s = TraversalStats::default();
    let hit = bvh.closest_hit(&ray, &mut s).unwrap();
    assert_eq!((hit.triangle, hit.t), (0, 1.0));
    assert_eq!(s, stats(1, 1, 1, 3));
}

#[test]
fn closest_hit_from_the_right() {
    // Root box; root: 2 tests, B/C nearer (entry 9 < 20); inner: 2 tests, C nearer (9 < 10);
    // leaf C hit at t = 9; B (10) and A (20) are culled.
    let bvh = scene();
    let ray = Ray::new(Vec3::new(20.0, 0.25, 0.25), Vec3::NEG_X, 0.0, f32::INFINITY);
    let mut s = TraversalStats::default();
    let hit = bvh.closest_hit(&ray, &mut s).unwrap();
    assert_eq!((hit.triangle, hit.t), (2, 9.0));
    assert_eq!(s, stats(2, 1, 1, 5));
}

#[test]
fn a_miss_costs_one_box_test() {
    let bvh = scene();
    let ray = Ray::new(Vec3::new(-1.0, 5.0, 0.25), Vec3::X, 0.0, f32::INFINITY);
    let mut s = TraversalStats::default();
    assert!(bvh.closest_hit(&ray, &mut s).is_none());
    assert!(!bvh.occluded(&ray, &mut s));
    assert_eq!(s, stats(0, 0, 0, 2));
}

#[test]
fn short_shadow_segment_skips_the_far_subtree() {
    // Segment x in (-1, 4): the B/C box (entry t = 11) fails the box test against t_max = 5.
    let bvh = scene();
    let ray = Ray::new(Vec3::new(-1.0, 0.25, 0.25), Vec3::X, 0.0, 5.0);
    let mut s = TraversalStats::default();
    assert!(bvh.occluded(&ray, &mut s));
    assert_eq!(s, stats(1, 1, 1, 3));
}

#[test]
fn order_changes_work_not_answers() {
    let bvh = scene();
    let ray = Ray::new(Vec3::new(20.0, 0.25, 0.25), Vec3::NEG_X, 0.0, f32::INFINITY);
    // Stored order: A (left) first, occluded at once.
    let mut stored = TraversalStats::default();
    assert!(OrderedBinary {
        bvh: &bvh,
        order: AnyHitOrder::Stored
    }
    .occluded(&ray, &mut stored));
    assert_eq!(stored, stats(1, 1, 1, 3));
    // Near first: B/C subtree, then C.
    let mut near = TraversalStats::default();
    assert!(bvh.occluded(&ray, &mut near));
    assert_eq!(near, stats(2, 1, 1, 5));
}
