//! How refits wear a deforming mesh's tree, to choose `two_level::REFIT_LIMIT`: per frame, the
//! refit's `sah_growth`, whether it was kept or the mesh rebuilt, and the tree's SAH cost and
//! exact traversal work per ray (nodes entered plus triangle tests on the 8-wide collapse, any
//! hit and closest hit) over a build's over the same frame, for character-room's character
//! (its gait) and for that gait twisted and bent more every frame (a strong deformation).
//!
//! `refit_wear [TRIANGLES] [FRAMES]` (defaults 350000 and 24).

use antumbra_core::build::{BuildSettings, CollapseSettings};
use antumbra_core::bvh::BvhWidth;
use antumbra_core::geometry::Ray;
use antumbra_core::render::WideTree;
use antumbra_core::scene::Mesh;
use antumbra_core::trace::{RayQuery, TraversalStats};
use antumbra_core::two_level::MeshTree;
use antumbra_scenes::{builtin, SceneParams};
use std::time::Instant;

use glam::{DQuat, Vec3};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let params = SceneParams {
        triangles: args.first().map_or(Ok(350_000), |a| a.parse())?,
        frames: args.get(1).map_or(Ok(24), |a| a.parse())?,
        ..SceneParams::default()
    };
    let anim = builtin("character-room", &params)?;
    let gait: Vec<Mesh> = (1..=params.frames)
        .map(|f| {
            let scene = anim.frame(f);
            let m = scene.meshes.iter().find(|m| m.name == "character");
            (**m.expect("character-room has a character")).clone()
        })
        .collect();
    // The gait twisted about the vertical and bent forward more every frame.
    let bend: Vec<Mesh> = (gait.iter().enumerate())
        .map(|(k, m)| {
            let mut m = m.clone();
            for p in &mut m.positions {
                let q = DQuat::from_rotation_z(0.1 * k as f64 * p.z as f64);
                *p = (q * p.as_dvec3()).as_vec3();
                p.x += 0.03 * k as f32 * p.z * p.z;
            }
            m
        })
        .collect();
    println!("character: {} triangles", gait[0].triangles.len());
    println!(
        "| deformation | frame | sah_growth | tree | SAH / a build's | any hit: work / a build's \
         | closest hit: work / a build's |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (label, frames) in [("gait", &gait), ("gait, twist and bend", &bend)] {
        wear(label, frames);
    }
    collapse_or_refit(&gait);
    Ok(())
}

/// Wall-clock time of the second frame's tree made each way: a build and collapse, a refit of
/// both trees, and a refit of the binary tree with a new collapse of it (best of 20).
fn collapse_or_refit(frames: &[Mesh]) {
    let settings = BuildSettings::default();
    let collapse = CollapseSettings::default();
    let tree = MeshTree::build(&frames[0], &settings);
    let wide = WideTree::collapse(&tree.bvh, BvhWidth::Eight, &collapse);
    let best = |f: &dyn Fn()| {
        (0..20)
            .map(|_| {
                let start = Instant::now();
                f();
                start.elapsed().as_secs_f64() * 1e3
            })
            .fold(f64::INFINITY, f64::min)
    };
    let build = best(&|| {
        let t = MeshTree::build(&frames[1], &settings);
        WideTree::collapse(&t.bvh, BvhWidth::Eight, &collapse);
    });
    let refit = best(&|| {
        let t = tree.refit(&frames[0], &frames[1]).unwrap();
        wide.clone().refit(&t.bvh.triangles);
    });
    let recollapse = best(&|| {
        let t = tree.refit(&frames[0], &frames[1]).unwrap();
        WideTree::collapse(&t.bvh, BvhWidth::Eight, &collapse);
    });
    println!(
        "frame 2, ms: build and collapse {build:.3}, refit both {refit:.3}, \
         refit and collapse again {recollapse:.3}"
    );
}

/// Refits a tree built over the first frame through the rest, rebuilt where the refit is worn
/// past the limit (`Mesh tree` does the same), and prints each frame's row against a build.
fn wear(label: &str, frames: &[Mesh]) {
    let settings = BuildSettings::default();
    let collapse = CollapseSettings::default();
    let sah = |t: &MeshTree| {
        t.bvh
            .sah_cost(settings.traversal_cost, settings.intersection_cost)
    };
    let mut tree = MeshTree::build(&frames[0], &settings);
    let mut wide = WideTree::collapse(&tree.bvh, BvhWidth::Eight, &collapse);
    for (k, mesh) in frames.iter().enumerate().skip(1) {
        let refit = tree.refit(&frames[k - 1], mesh).expect("same topology");
        let growth = refit.sah_growth(&settings);
        let made = if refit.is_worn(&settings) {
            tree = MeshTree::build(mesh, &settings);
            wide = WideTree::collapse(&tree.bvh, BvhWidth::Eight, &collapse);
            "built"
        } else {
            tree = refit;
            wide.refit(&tree.bvh.triangles);
            "refit"
        };
        let built = MeshTree::build(mesh, &settings);
        let built_wide = WideTree::collapse(&built.bvh, BvhWidth::Eight, &collapse);
        // Both trees are in the same mesh space (fitted to the same positions).
        let (shadow, camera) = (shadow_rays(&tree, 20_000), camera_rays(&tree, 20_000));
        println!(
            "| {label} | {} | {growth:.3} | {made} | {:.3} | {:.3} | {:.3} |",
            k + 1,
            sah(&tree) / sah(&built),
            work(&wide, &shadow, false) / work(&built_wide, &shadow, false),
            work(&wide, &camera, true) / work(&built_wide, &camera, true),
        );
    }
}

/// Segments between random points of the mesh's box, grown by half: any-hit rays through it.
fn shadow_rays(tree: &MeshTree, n: u32) -> Vec<Ray> {
    let mut point = points(tree);
    (0..n)
        .map(|_| {
            let (a, b) = (point(), point());
            Ray::new(a, b - a, 0.0, 1.0)
        })
        .collect()
}

/// Unbounded rays from random points of the grown box through random triangles' centroids.
fn camera_rays(tree: &MeshTree, n: u32) -> Vec<Ray> {
    let mut point = points(tree);
    (0..n as usize)
        .map(|i| {
            let v = tree.triangles[i * 7919 % tree.triangles.len()];
            let a = point();
            Ray::new(a, (v[0] + v[1] + v[2]) / 3.0 - a, 0.0, f32::INFINITY)
        })
        .collect()
}

/// Random points of the mesh's box grown by half.
fn points(tree: &MeshTree) -> impl FnMut() -> Vec3 {
    let (lo, hi) = (tree.bounds.min, tree.bounds.max);
    let (c, e) = ((lo + hi) * 0.5, (hi - lo) * 0.75);
    let mut state = 0x9e37_79b9u32;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state as f32 / u32::MAX as f32 * 2.0 - 1.0
    };
    move || c + e * Vec3::new(next(), next(), next())
}

/// Nodes entered plus triangle tests per ray, any hit or closest hit.
fn work(tree: &WideTree, rays: &[Ray], closest: bool) -> f64 {
    let mut stats = TraversalStats::default();
    for r in rays {
        if closest {
            tree.closest_hit(r, &mut stats);
        } else {
            tree.occluded(r, &mut stats);
        }
    }
    (stats.inner + stats.leaves + stats.triangles) as f64 / rays.len() as f64
}
