//! SBVH, ABVH, OSAH and VSAH trees: spatial splits never lose a triangle, every complete build
//! answers exactly as brute force (closest-hit ids and occlusion), OSAH and ABVH fall back to the
//! SAH tree with no visible triangles and to the SBVH tree with all of them, and OSAH moves
//! work away from rays that hit visible triangles.

use antumbra_core::build::{
    build, build_with_visibility, check_references, BuildMethod, BuildSettings, SpatialAxes,
    SpatialSettings,
};
use antumbra_core::bvh::Bvh;
use antumbra_core::geometry::Ray;
use antumbra_core::order::AnyHitOrder;
use antumbra_core::sampling::{hash_u32, unit_float};
use antumbra_core::trace::{
    brute_closest_hit, brute_occluded, NoStats, OrderedBinary, RayQuery, TraversalStats,
};
use glam::Vec3;

fn r(seed: u32) -> f32 {
    unit_float(hash_u32(seed))
}

fn rand3(seed: u32) -> Vec3 {
    Vec3::new(r(seed), r(seed ^ 0x5555_5555), r(seed ^ 0x3333_3333))
}

/// Small triangles plus long diagonal slivers, which spatial splits exist for.
fn soup(n: u32, seed: u32) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|i| {
            let c = rand3(seed + 3 * i) * 10.0 - 5.0;
            let s = if i % 10 == 0 {
                8.0
            } else {
                0.1 + r(seed + 3 * i + 1)
            };
            [
                c + (rand3(seed + 7 * i + 11) - 0.5) * s,
                c + (rand3(seed + 7 * i + 12) - 0.5) * s,
                c + (rand3(seed + 7 * i + 13) - 0.5) * s,
            ]
        })
        .collect()
}

fn rays(n: u32, seed: u32) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let o = rand3(seed + 2 * i) * 14.0 - 7.0;
            let mut d = rand3(seed + 2 * i + 1) * 2.0 - 1.0;
            if i % 7 == 0 {
                d = Vec3::new(d.x, 0.0, -0.0);
            }
            let t_max = if i % 3 == 0 { 4.0 } else { f32::INFINITY };
            Ray::new(o, d, 0.0, t_max)
        })
        .filter(|r| r.direction != Vec3::ZERO)
        .collect()
}

fn every_third(n: usize) -> Vec<bool> {
    (0..n).map(|i| i % 3 == 0).collect()
}

/// Spatial splits tried in every node, so small tests exercise them.
fn eager_splits() -> BuildSettings {
    BuildSettings {
        spatial: SpatialSettings {
            alpha: 0.0,
            node_overlap: 0.0,
            ..SpatialSettings::default()
        },
        ..BuildSettings::default()
    }
}

fn assert_same_answers(tris: &[[Vec3; 3]], bvh: &Bvh, rays: &[Ray], what: &str) {
    let mut hits = 0;
    for (i, ray) in rays.iter().enumerate() {
        let b = brute_closest_hit(tris, ray);
        let h = bvh.closest_hit(ray, &mut NoStats);
        assert_eq!(
            h.map(|h| (h.triangle, h.t)),
            b.map(|b| (b.triangle, b.t)),
            "{what} ray {i}: {ray:?}"
        );
        hits += h.is_some() as usize;
        let occ = brute_occluded(tris, ray);
        for order in [AnyHitOrder::Stored, AnyHitOrder::NearFirst] {
            assert_eq!(
                OrderedBinary { bvh, order }.occluded(ray, &mut NoStats),
                occ,
                "{what} ray {i}"
            );
        }
    }
    assert!(hits > rays.len() / 20, "{what}: too few hits ({hits})");
}

#[test]
fn spatial_splits_duplicate_references_but_lose_no_triangle() {
    for (seed, leaf) in [(1u32, 1usize), (2, 4), (3, 8)] {
        let tris = soup(1500, seed * 100_000);
        let settings = BuildSettings {
            max_leaf_size: leaf,
            ..eager_splits()
        };
        let vis = every_third(tris.len());
        for method in [BuildMethod::Sbvh, BuildMethod::Abvh, BuildMethod::Osah] {
            let bvh = build_with_visibility(method, &tris, Some(&vis), &settings);
            check_references(&bvh, &tris, 1e-5).unwrap_or_else(|e| panic!("{method:?}: {e}"));
            assert!(
                bvh.triangles.len() > tris.len(),
                "{method:?} made no spatial split ({} references)",
                bvh.triangles.len()
            );
            let bound = tris.len() as f32 * (1.0 + settings.spatial.max_growth);
            assert!(
                bvh.triangles.len() as f32 <= bound,
                "{method:?} grew past the bound"
            );
        }
    }
}

#[test]
fn spatial_split_gates_trade_references_for_nothing_else() {
    // `min_refs` above the triangle count keeps spatial splits out of every node, so SBVH is the
    // SAH tree; `node_overlap` 1 admits almost no node, and growth falls monotonically with it.
    // Every gated tree keeps every triangle and answers as brute force.
    let tris = soup(4000, 7_000);
    let rays = rays(1500, 77);
    let vis = every_third(tris.len());
    let eager = eager_splits();
    let sah = build(BuildMethod::Sah, &tris, &eager);
    let mut none = eager;
    none.spatial.min_refs = tris.len() + 1;
    assert!(same_tree(&build(BuildMethod::Sbvh, &tris, &none), &sah));
    let mut some = eager;
    some.spatial.min_refs = 64;
    let refs = |s: &BuildSettings, method| {
        let bvh = build_with_visibility(method, &tris, Some(&vis), s);
        check_references(&bvh, &tris, 1e-5).unwrap_or_else(|e| panic!("{method:?}: {e}"));
        assert_same_answers(&tris, &bvh, &rays, &format!("{method:?} gated"));
        bvh.triangles.len()
    };
    for method in [BuildMethod::Sbvh, BuildMethod::Osah] {
        let all = refs(&eager, method);
        assert!(all > tris.len(), "{method:?} made no spatial split");
        let big_nodes = refs(&some, method);
        assert!(
            big_nodes < all,
            "{method:?}: min_refs 64 kept {big_nodes} of {all}"
        );
        let mut grown = Vec::new();
        for node_overlap in [0.0, 0.05, 0.3, 1.0] {
            let mut s = eager;
            s.spatial.node_overlap = node_overlap;
            grown.push(refs(&s, method) - tris.len());
        }
        assert!(
            grown.windows(2).all(|w| w[1] <= w[0]) && grown[3] < grown[0],
            "{method:?}: references grown by node_overlap 0, 0.05, 0.3, 1: {grown:?}"
        );
    }
    let mut bad = eager;
    bad.spatial.node_overlap = 1.5;
    let err = with_build(bad).validate().unwrap_err().to_string();
    assert!(err.contains("split_node_overlap"), "{err}");
}

#[test]
fn every_build_answers_as_brute_force() {
    let tris = soup(2000, 7_000);
    let rays = rays(3000, 9_000_000);
    let vis = every_third(tris.len());
    let paper_viability = BuildSettings {
        osah_strict_viability: false,
        ..eager_splits()
    };
    let mut all_axes = eager_splits();
    all_axes.spatial.axes = SpatialAxes::All;
    for settings in [
        BuildSettings::default(),
        eager_splits(),
        paper_viability,
        all_axes,
    ] {
        for method in [
            BuildMethod::Sah,
            BuildMethod::Sbvh,
            BuildMethod::Abvh,
            BuildMethod::Osah,
        ] {
            let bvh = build_with_visibility(method, &tris, Some(&vis), &settings);
            assert_same_answers(&tris, &bvh, &rays, method.name());
        }
    }
    // The viability rule is a real switch: on this soup the two rules build different trees.
    let strict = build_with_visibility(BuildMethod::Osah, &tris, Some(&vis), &eager_splits());
    let paper = build_with_visibility(BuildMethod::Osah, &tris, Some(&vis), &paper_viability);
    assert!(!same_tree(&strict, &paper));
    // So is the axis restriction of spatial binning.
    let all = build_with_visibility(BuildMethod::Sbvh, &tris, Some(&vis), &all_axes);
    let object = build_with_visibility(BuildMethod::Sbvh, &tris, Some(&vis), &eager_splits());
    assert!(!same_tree(&all, &object));
}

#[test]
fn vsah_answers_rays_whose_closest_hit_is_visible() {
    let tris = soup(2000, 11_000);
    let rays = rays(3000, 5_000_000);
    let mut vis = vec![false; tris.len()];
    for ray in &rays {
        if let Some(h) = brute_closest_hit(&tris, ray) {
            vis[h.triangle as usize] = true;
        }
    }
    let bvh = build_with_visibility(BuildMethod::Vsah, &tris, Some(&vis), &eager_splits());
    assert_eq!(bvh.triangles.len(), vis.iter().filter(|v| **v).count());
    for ray in &rays {
        let b = brute_closest_hit(&tris, ray).map(|h| (h.triangle, h.t));
        assert_eq!(
            bvh.closest_hit(ray, &mut NoStats)
                .map(|h| (h.triangle, h.t)),
            b
        );
    }
}

fn same_tree(a: &Bvh, b: &Bvh) -> bool {
    a.nodes[..] == b.nodes[..] && a.triangle_ids == b.triangle_ids
}

#[test]
fn visibility_builds_fall_back_to_sah_and_sbvh() {
    let tris = soup(6000, 3_000);
    let settings = eager_splits();
    let none = vec![false; tris.len()];
    let all = vec![true; tris.len()];
    let sah = build(BuildMethod::Sah, &tris, &settings);
    let sbvh = build(BuildMethod::Sbvh, &tris, &settings);
    assert!(!same_tree(&sah, &sbvh), "SBVH should differ from SAH here");
    for method in [BuildMethod::Osah, BuildMethod::Abvh] {
        let empty = build_with_visibility(method, &tris, Some(&none), &settings);
        assert!(
            same_tree(&empty, &sah),
            "{method:?} with no visible triangle"
        );
        let full = build_with_visibility(method, &tris, Some(&all), &settings);
        assert!(
            same_tree(&full, &sbvh),
            "{method:?} with every triangle visible"
        );
    }
    let osah = build_with_visibility(
        BuildMethod::Osah,
        &tris,
        Some(&every_third(tris.len())),
        &settings,
    );
    assert!(!same_tree(&osah, &sah) && !same_tree(&osah, &sbvh));
}

/// A closed box of large walls around many small triangles, seen from outside: the walls are
/// what the camera sees, the interior is hidden.
fn walled_clutter() -> (Vec<[Vec3; 3]>, Vec<Ray>) {
    let mut tris = Vec::new();
    let c = [
        Vec3::new(-5.0, -5.0, -5.0),
        Vec3::new(5.0, -5.0, -5.0),
        Vec3::new(5.0, 5.0, -5.0),
        Vec3::new(-5.0, 5.0, -5.0),
        Vec3::new(-5.0, -5.0, 5.0),
        Vec3::new(5.0, -5.0, 5.0),
        Vec3::new(5.0, 5.0, 5.0),
        Vec3::new(-5.0, 5.0, 5.0),
    ];
    for [a, b, cc, d] in [
        [0, 1, 2, 3],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 3, 7, 4],
        [1, 2, 6, 5],
    ] {
        tris.push([c[a], c[b], c[cc]]);
        tris.push([c[a], c[cc], c[d]]);
    }
    for i in 0..3000u32 {
        let p = rand3(i * 3) * 9.0 - 4.5;
        tris.push([p, p + rand3(i * 3 + 1) * 0.3, p + rand3(i * 3 + 2) * 0.3]);
    }
    let rays = (0..2000u32)
        .map(|i| {
            let target = rand3(70_000 + i) * 8.0 - 4.0;
            let origin = Vec3::new(20.0, 7.0, 3.0);
            Ray::new(origin, target - origin, 0.0, f32::INFINITY)
        })
        .collect();
    (tris, rays)
}

fn work(bvh: &Bvh, rays: &[Ray]) -> TraversalStats {
    let mut total = TraversalStats::default();
    for ray in rays {
        bvh.closest_hit(ray, &mut total);
    }
    total
}

#[test]
fn osah_saves_work_for_rays_that_hit_visible_triangles() {
    let (tris, rays) = walled_clutter();
    let mut vis = vec![false; tris.len()];
    for ray in &rays {
        vis[brute_closest_hit(&tris, ray)
            .expect("walls are hit")
            .triangle as usize] = true;
    }
    assert!(vis[12..].iter().all(|v| !v), "the clutter is hidden");
    let settings = BuildSettings::default();
    let sah = build(BuildMethod::Sah, &tris, &settings);
    let osah = build_with_visibility(BuildMethod::Osah, &tris, Some(&vis), &settings);
    assert_same_answers(&tris, &osah, &rays, "osah");
    let (w_sah, w_osah) = (work(&sah, &rays), work(&osah, &rays));
    let steps = |w: &TraversalStats| w.inner + w.leaves;
    assert!(
        w_osah.triangles < w_sah.triangles && steps(&w_osah) < steps(&w_sah),
        "SAH {w_sah:?} OSAH {w_osah:?}"
    );
}

/// References in the subtree of node `i`.
fn refs_below(bvh: &Bvh, i: usize) -> usize {
    let n = &bvh.nodes[i];
    if n.is_leaf() {
        n.count as usize
    } else {
        refs_below(bvh, n.first as usize) + refs_below(bvh, n.first as usize + 1)
    }
}

#[test]
fn smallest_leaf_stops_splits_and_changes_no_answer() {
    let tris = soup(3000, 21_000);
    let rays = rays(2000, 4_000_000);
    let vis = every_third(tris.len());
    for min in [4usize, 8] {
        let settings = BuildSettings {
            min_leaf_size: min,
            ..eager_splits()
        };
        with_build(settings).validate().unwrap();
        for method in [
            BuildMethod::Sah,
            BuildMethod::Sbvh,
            BuildMethod::Abvh,
            BuildMethod::Osah,
        ] {
            let what = format!("{method:?}, smallest leaf {min}");
            let bvh = build_with_visibility(method, &tris, Some(&vis), &settings);
            check_references(&bvh, &tris, 1e-5).unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_same_answers(&tris, &bvh, &rays, &what);
            for i in (0..bvh.nodes.len()).filter(|&i| i != 1) {
                let n = &bvh.nodes[i];
                if n.is_leaf() {
                    assert!(
                        n.count as usize <= settings.max_leaf_size,
                        "{what}: leaf {i}"
                    );
                } else {
                    let below = refs_below(&bvh, i);
                    assert!(below > min, "{what}: node {i} split {below} references");
                }
            }
            let finest = build_with_visibility(method, &tris, Some(&vis), &eager_splits());
            assert!(
                bvh.nodes.len() < finest.nodes.len(),
                "{what}: {} nodes, {} with the smallest leaf 1",
                bvh.nodes.len(),
                finest.nodes.len()
            );
        }
        // The split builder leaves small nodes as the SAH builder does: OSAH without visible
        // triangles is still the SAH tree, with all of them the SBVH tree.
        let none = vec![false; tris.len()];
        let all = vec![true; tris.len()];
        let osah = |v: &[bool]| build_with_visibility(BuildMethod::Osah, &tris, Some(v), &settings);
        assert!(same_tree(
            &osah(&none),
            &build(BuildMethod::Sah, &tris, &settings)
        ));
        assert!(same_tree(
            &osah(&all),
            &build(BuildMethod::Sbvh, &tris, &settings)
        ));
    }
    for (min, max) in [(0, 8), (9, 8), (5, 4)] {
        let bad = BuildSettings {
            min_leaf_size: min,
            max_leaf_size: max,
            ..BuildSettings::default()
        };
        let err = with_build(bad).validate().unwrap_err().to_string();
        assert!(
            err.contains("min_leaf_size") && err.contains(&format!("{min}")),
            "{err}"
        );
    }
}

/// Render settings with these build settings (where ranges are checked).
fn with_build(build_settings: BuildSettings) -> antumbra_core::render::RenderSettings {
    antumbra_core::render::RenderSettings {
        build_settings,
        ..antumbra_core::render::RenderSettings::baseline()
    }
}
