//! Watertightness after Embree's own test: rays from inside a closed, finely tessellated sphere
//! and rays through the shared edges and vertices of a plane grid must all hit.

mod common;

use antumbra_core::build::{build_binned_sah, BuildSettings, CollapseSettings};
use antumbra_core::bvh::{Bvh, BvhWidth};
use antumbra_core::geometry::Ray;
use antumbra_core::order::OrderView;
use antumbra_core::render::WideTree;
use antumbra_core::sampling::{hash_u32, unit_float};
use antumbra_core::trace::{NoStats, RayMode, RayQuery};
use glam::Vec3;

/// Rays that miss (closest hit) and that nothing occludes (any hit) when traced in packets of 16
/// on the 8-wide collapse of `bvh`, every lane with its own watertight test.
fn packet_misses(bvh: &Bvh, rays: &[Ray]) -> (usize, usize) {
    let tree = WideTree::collapse(bvh, BvhWidth::Eight, &CollapseSettings::default());
    let q = tree
        .ordered(OrderView::FrontToBack)
        .with_rays(RayMode::Packet);
    let mut hits = vec![None; rays.len()];
    q.closest_hit_batch(rays, &mut hits, &mut vec![NoStats; rays.len()]);
    let mut occluded = vec![false; rays.len()];
    q.occluded_batch(rays, &mut occluded, &mut vec![NoStats; rays.len()]);
    (
        hits.iter().filter(|h| h.is_none()).count(),
        occluded.iter().filter(|o| !**o).count(),
    )
}

fn tris(mesh: &antumbra_core::scene::Mesh) -> Vec<[Vec3; 3]> {
    mesh.triangles
        .iter()
        .map(|t| t.map(|i| mesh.positions[i as usize]))
        .collect()
}

fn rand3(seed: u32) -> Vec3 {
    Vec3::new(
        unit_float(hash_u32(seed)),
        unit_float(hash_u32(seed ^ 0x1234_5678)),
        unit_float(hash_u32(seed ^ 0x0bad_cafe)),
    )
}

#[test]
fn rays_from_inside_a_closed_sphere_never_escape() {
    let sphere = common::sphere("sphere", 200, 400); // 159,600 triangles
    let t = tris(&sphere);
    let bvh = build_binned_sah(&t, &BuildSettings::default());
    let mut misses = 0;
    let n = 100_000u32;
    let mut rays = Vec::new();
    for i in 0..n {
        // Origins anywhere inside (radius up to 0.95), directions uniform incl. axis-aligned ones.
        let o = (rand3(2 * i) * 2.0 - 1.0) * 0.95 / 3f32.sqrt();
        let mut d = rand3(2 * i + 1) * 2.0 - 1.0;
        if i % 10 == 0 {
            d = [Vec3::X, Vec3::NEG_Y, Vec3::Z, Vec3::new(-0.0, 0.0, -1.0)][(i / 10 % 4) as usize];
        }
        if d == Vec3::ZERO {
            continue;
        }
        let ray = Ray::new(o, d, 0.0, f32::INFINITY);
        if bvh.closest_hit(&ray, &mut NoStats).is_none() {
            misses += 1;
        }
        rays.push(ray);
    }
    assert_eq!(misses, 0, "rays escaped the closed sphere through cracks");
    assert_eq!(
        packet_misses(&bvh, &rays),
        (0, 0),
        "packets escaped through cracks"
    );
}

#[test]
fn rays_through_shared_edges_and_vertices_of_a_grid_all_hit() {
    let n = 64u32;
    let grid = common::grid("grid", n);
    let t = tris(&grid);
    let bvh = build_binned_sah(&t, &BuildSettings::default());
    let mut misses = 0;
    let mut total = 0;
    let mut rays = Vec::new();
    // Aim exactly at vertices, at edge midpoints and along the diagonals, from many directions.
    for j in 0..=2 * n {
        for i in 0..=2 * n {
            let target = Vec3::new(-1.0 + i as f32 / n as f32, -1.0 + j as f32 / n as f32, 0.0);
            if target.x.abs() >= 1.0 || target.y.abs() >= 1.0 {
                continue;
            }
            for k in 0..4u32 {
                let from = match k {
                    0 => target + Vec3::Z,
                    1 => target + Vec3::new(0.3, -0.7, 1.0),
                    2 => target - Vec3::new(0.01, 0.02, 1.0),
                    _ => target + (rand3(i * 7919 + j * 104_729 + k) - 0.5) + Vec3::Z,
                };
                let ray = Ray::new(from, target - from, 0.0, 2.0);
                total += 1;
                if bvh.closest_hit(&ray, &mut NoStats).is_none() {
                    misses += 1;
                }
                rays.push(ray);
            }
        }
    }
    assert!(total > 60_000);
    assert_eq!(
        misses, 0,
        "{misses} of {total} rays fell through shared edges"
    );
    assert_eq!(
        packet_misses(&bvh, &rays),
        (0, 0),
        "packets fell through shared edges"
    );
}
