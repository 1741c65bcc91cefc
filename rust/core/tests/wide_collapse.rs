//! The SAH collapse: valid trees, never costlier than the greedy collapse under its own cost
//! model, the exact optimum of an exhaustive enumeration on tiny trees, and N = 2 stays binary.
//! (Answers against brute force for both methods: `wide_bvh.rs` and the CLI's built-in scenes.)

use std::collections::HashMap;

use antumbra_core::build::{
    build_binned_sah, BuildSettings, CollapseCost, CollapseMethod, CollapseSettings,
};
use antumbra_core::bvh::{Bvh, WideBvh};
use antumbra_core::sampling::{hash_u32, unit_float};
use glam::Vec3;

fn r(seed: u32) -> f32 {
    unit_float(hash_u32(seed))
}

fn scene(n: u32, seed: u32) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|i| {
            let c = Vec3::new(r(seed + 5 * i), r(seed + 5 * i + 1), r(seed + 5 * i + 2)) * 10.0;
            let s = 0.05 + r(seed + 5 * i + 3) * 2.0;
            let d = |k: u32| {
                Vec3::new(
                    r(seed ^ (k * 7 + i * 31)),
                    r(seed ^ (k * 7 + i * 31 + 1)),
                    r(seed ^ (k * 7 + i * 31 + 2)),
                ) - 0.5
            };
            [c + d(1) * s, c + d(2) * s, c + d(3) * s]
        })
        .collect()
}

fn bvh(tris: &[[Vec3; 3]], leaf: usize) -> Bvh {
    build_binned_sah(
        tris,
        &BuildSettings {
            max_leaf_size: leaf,
            ..BuildSettings::default()
        },
    )
}

fn models() -> Vec<CollapseCost> {
    let d = CollapseCost::default();
    vec![
        d,
        CollapseCost { lanes: 1, ..d },
        CollapseCost {
            max_leaf: 4,
            lanes: 1,
            node: 1.0,
            triangle: 1.0,
        },
        CollapseCost {
            max_leaf: 16,
            node: 3.0,
            ..d
        },
    ]
}

fn greedy<const N: usize>(bvh: &Bvh) -> WideBvh<N> {
    WideBvh::<N>::collapse_with(bvh, &CollapseSettings::new(CollapseMethod::Greedy))
}

fn sah<const N: usize>(bvh: &Bvh, cost: CollapseCost) -> WideBvh<N> {
    WideBvh::<N>::collapse_with(
        bvh,
        &CollapseSettings {
            method: CollapseMethod::Sah,
            cost,
        },
    )
}

fn check_not_costlier<const N: usize>(bvh: &Bvh) {
    let greedy = greedy::<N>(bvh);
    greedy.validate().unwrap();
    for model in models() {
        let tree = sah::<N>(bvh, model);
        tree.validate().unwrap();
        assert_eq!(
            tree.triangles, bvh.triangles,
            "the collapse re-ordered triangles"
        );
        // Greedy leaves merge at most MERGE_LIMIT (4) triangles: within every model's choices.
        let (s, g) = (tree.sah_cost(&model), greedy.sah_cost(&model));
        assert!(
            s <= g * (1.0 + 1e-9),
            "N={N} {model:?}: sah {s} > greedy {g}"
        );
    }
}

#[test]
fn sah_collapse_is_valid_and_never_costlier_than_greedy() {
    for (seed, leaf) in [(1u32, 1usize), (2, 2), (3, 4), (4, 8)] {
        let b = bvh(&scene(3000, seed * 10_000), leaf);
        check_not_costlier::<4>(&b);
        check_not_costlier::<8>(&b);
    }
    for n in [0, 1, 2, 3, 5, 9] {
        let b = bvh(&scene(n, 77), 1);
        check_not_costlier::<4>(&b);
        check_not_costlier::<8>(&b);
        assert_eq!(sah::<8>(&b, CollapseCost::default()).is_empty(), n == 0);
    }
}

#[test]
fn sah_collapse_fills_nodes_better_than_greedy() {
    let b = bvh(&scene(20_000, 9), 8);
    let greedy = greedy::<8>(&b);
    let tree = sah::<8>(&b, CollapseCost::default());
    assert!(
        tree.nodes.len() < greedy.nodes.len(),
        "{} nodes, greedy {}",
        tree.nodes.len(),
        greedy.nodes.len()
    );
    assert!(tree.children_per_node() > greedy.children_per_node());
}

#[test]
fn two_wide_sah_collapse_is_the_binary_tree() {
    let b = bvh(&scene(2000, 5), 4);
    let greedy = greedy::<2>(&b);
    let tree = sah::<2>(&b, CollapseCost::default());
    assert_eq!(tree.nodes, greedy.nodes);
    assert_eq!(tree.parent, greedy.parent);
}

/// Exhaustive optimum: every wide node takes any cut of its binary subtree below it with at
/// most N elements, each element a leaf (a binary leaf, or a subtree of at most `max_leaf`
/// triangles) or a wide node optimised the same way.
struct Exhaustive<'a> {
    bvh: &'a Bvh,
    model: CollapseCost,
    n: usize,
    memo: HashMap<usize, f64>,
}

impl Exhaustive<'_> {
    fn area(&self, i: usize) -> f64 {
        self.bvh.nodes[i].bounds().half_area() as f64
    }

    fn triangles(&self, i: usize) -> u32 {
        let node = &self.bvh.nodes[i];
        if node.is_leaf() {
            node.count
        } else {
            self.triangles(node.first as usize) + self.triangles(node.first as usize + 1)
        }
    }

    fn leaf(&self, i: usize) -> f64 {
        let count = self.triangles(i);
        if self.bvh.nodes[i].is_leaf() || count <= self.model.max_leaf {
            self.area(i) * self.model.leaf(count)
        } else {
            f64::INFINITY
        }
    }

    /// Every cut of i's subtree with at most `max` elements.
    fn cuts(&self, i: usize, max: usize) -> Vec<Vec<usize>> {
        let mut out = vec![vec![i]];
        let node = &self.bvh.nodes[i];
        if !node.is_leaf() && max >= 2 {
            let l = node.first as usize;
            for a in self.cuts(l, max - 1) {
                for b in self.cuts(l + 1, max - a.len()) {
                    out.push([a.clone(), b].concat());
                }
            }
        }
        out
    }

    fn slot(&mut self, i: usize) -> f64 {
        let leaf = self.leaf(i);
        if self.bvh.nodes[i].is_leaf() {
            leaf
        } else {
            leaf.min(self.node(i))
        }
    }

    /// Cost of interior i as a wide node.
    fn node(&mut self, i: usize) -> f64 {
        if let Some(&c) = self.memo.get(&i) {
            return c;
        }
        let l = self.bvh.nodes[i].first as usize;
        let mut best = f64::INFINITY;
        for a in self.cuts(l, self.n - 1) {
            for b in self.cuts(l + 1, self.n - a.len()) {
                let c: f64 = a.iter().chain(&b).map(|&s| self.slot(s)).sum();
                best = best.min(c);
            }
        }
        let c = self.area(i) * self.model.node + best;
        self.memo.insert(i, c);
        c
    }

    /// Cost of the whole wide tree: the root is a wide node, whose one slot may be a leaf.
    fn root(&mut self) -> f64 {
        let leaf = self.area(0) * self.model.node + self.leaf(0);
        if self.bvh.nodes[0].is_leaf() {
            leaf
        } else {
            leaf.min(self.node(0))
        }
    }
}

fn check_exhaustive<const N: usize>(b: &Bvh, model: CollapseCost) {
    let tree = sah::<N>(b, model);
    tree.validate().unwrap();
    let best = Exhaustive {
        bvh: b,
        model,
        n: N,
        memo: HashMap::new(),
    }
    .root();
    let got = tree.sah_cost(&model);
    assert!(
        (got - best).abs() <= 1e-9 * best,
        "N={N} {model:?}: dp {got}, exhaustive {best}"
    );
}

#[test]
fn sah_collapse_matches_exhaustive_enumeration_on_tiny_trees() {
    for seed in 0..12u32 {
        for (tris, leaf) in [(6u32, 1usize), (14, 1), (24, 2), (30, 3)] {
            let b = bvh(&scene(tris, seed * 1000 + tris), leaf);
            for model in models() {
                check_exhaustive::<4>(&b, model);
                check_exhaustive::<8>(&b, model);
            }
        }
    }
}
