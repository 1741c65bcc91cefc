//! The BVH queries give exactly the brute-force answers: closest-hit ids (ties by id) and
//! occlusion, for random, grazing, axis-parallel and inside-out rays on random triangle soups
//! and closed meshes. (Built-in scenes are checked the same way in the CLI crate's tests.)

mod common;

use antumbra_core::build::{build_binned_sah, BuildSettings};
use antumbra_core::geometry::Ray;
use antumbra_core::order::AnyHitOrder;
use antumbra_core::sampling::{hash_u32, unit_float};
use antumbra_core::trace::{brute_closest_hit, brute_occluded, NoStats, OrderedBinary, RayQuery};
use glam::Vec3;

fn r(seed: u32) -> f32 {
    unit_float(hash_u32(seed))
}

fn rand3(seed: u32) -> Vec3 {
    Vec3::new(r(seed), r(seed ^ 0x5555_5555), r(seed ^ 0x3333_3333))
}

fn soup(n: u32, seed: u32) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|i| {
            let c = rand3(seed + 3 * i) * 10.0 - 5.0;
            let s = 0.05 + r(seed + 3 * i + 1) * 1.5;
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
            match i % 8 {
                // Axis-parallel, with both signs of zero.
                0 => d = Vec3::new(d.x, 0.0, -0.0),
                1 => d = Vec3::new(-0.0, d.y, 0.0),
                // Grazing: nearly in a coordinate plane.
                2 => d = Vec3::new(d.x, 1e-7, d.z),
                _ => {}
            }
            let t_max = if i % 3 == 0 { 4.0 } else { f32::INFINITY };
            Ray::new(o, d, 0.0, t_max)
        })
        .filter(|r| r.direction != Vec3::ZERO)
        .collect()
}

fn check(tris: &[[Vec3; 3]], rays: &[Ray], settings: &BuildSettings) {
    let bvh = build_binned_sah(tris, settings);
    bvh.validate().unwrap();
    let mut hits = 0;
    for (i, ray) in rays.iter().enumerate() {
        let b = brute_closest_hit(tris, ray);
        let h = bvh.closest_hit(ray, &mut NoStats);
        assert_eq!(
            h.map(|h| (h.triangle, h.t)),
            b.map(|b| (b.triangle, b.t)),
            "ray {i}: {ray:?}"
        );
        hits += h.is_some() as u32;
        let occ = brute_occluded(tris, ray);
        for order in [AnyHitOrder::Stored, AnyHitOrder::NearFirst] {
            assert_eq!(
                OrderedBinary { bvh: &bvh, order }.occluded(ray, &mut NoStats),
                occ,
                "ray {i}"
            );
        }
    }
    assert!(
        hits > rays.len() as u32 / 20,
        "too few hits ({hits}) to mean anything"
    );
}

#[test]
fn random_soups_match_brute_force() {
    for (seed, leaf) in [(1u32, 1usize), (2, 4), (3, 8), (4, 16)] {
        let tris = soup(3000, seed * 100_000);
        let settings = BuildSettings {
            max_leaf_size: leaf,
            ..BuildSettings::default()
        };
        check(&tris, &rays(4000, seed * 7_000_000), &settings);
    }
}

#[test]
fn rays_from_inside_closed_meshes_match_brute_force() {
    let sphere = common::sphere("s", 40, 80);
    let tris: Vec<[Vec3; 3]> = sphere
        .triangles
        .iter()
        .map(|t| t.map(|i| sphere.positions[i as usize] * 3.0))
        .collect();
    check(&tris, &rays(4000, 99), &BuildSettings::default());
}

#[test]
fn exact_ties_are_broken_by_id() {
    // Two copies of the same triangle: every hit is a tie; the smaller id must win everywhere.
    let mut tris = soup(500, 5);
    let dup = tris.clone();
    tris.extend(dup);
    let bvh = build_binned_sah(&tris, &BuildSettings::default());
    let mut ties = 0;
    for ray in rays(4000, 77) {
        let h = bvh.closest_hit(&ray, &mut NoStats);
        assert_eq!(
            h.map(|h| h.triangle),
            brute_closest_hit(&tris, &ray).map(|h| h.triangle)
        );
        if let Some(h) = h {
            assert!(h.triangle < 500);
            ties += 1;
        }
    }
    assert!(ties > 100);
}
