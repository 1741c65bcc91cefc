//! Every packet and stream call (incoherent context) answers ray for ray as the single-ray calls
//! do, on a small random scene: full and partial packets, empty batches, empty and reversed
//! segments (tfar <= tnear) and rays leaving a surface.

use antumbra_core::geometry::Ray;
use antumbra_embree::{Coherence, EmbreeKernel, EmbreeQuality, EmbreeScene};
use glam::Vec3;

/// SplitMix64: deterministic, no dependencies.
struct Rng(u64);

impl Rng {
    fn f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    fn point(&mut self, r: f32) -> Vec3 {
        Vec3::new(self.range(-r, r), self.range(-r, r), self.range(-r, r))
    }
}

/// 400 random triangles in [-1, 1]^3.
fn scene(rng: &mut Rng) -> (Vec<[Vec3; 3]>, EmbreeScene) {
    let tris: Vec<[Vec3; 3]> = (0..400)
        .map(|_| {
            let c = rng.point(1.0);
            [(); 3].map(|_| c + rng.point(0.25))
        })
        .collect();
    let scene = EmbreeScene::new(&tris, EmbreeQuality::Medium, Some(1)).unwrap();
    (tris, scene)
}

/// Rays of every kind the batch calls must get right, in a shuffled mix: through the scene,
/// segments ending short of it, reversed (tfar < tnear) and empty (tfar = tnear) segments, and
/// rays leaving a triangle 1e-4 above its surface towards the other side.
fn rays(rng: &mut Rng, tris: &[[Vec3; 3]], n: usize) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let origin = rng.point(1.5);
            let direction = rng.point(1.0) + Vec3::splat(1e-3);
            match i % 6 {
                0 | 1 => Ray::new(origin, direction, 0.0, f32::INFINITY),
                2 => Ray::new(origin, direction, 0.1, rng.range(0.2, 2.0)),
                3 => Ray::new(origin, direction, 1.0, rng.range(0.0, 0.999)),
                4 => Ray::new(origin, direction, 0.5, 0.5),
                _ => {
                    let [a, b, c] = tris[i % tris.len()];
                    let normal = (b - a).cross(c - a).normalize();
                    let start = (a + b + c) / 3.0 + 1e-4 * normal;
                    Ray::new(start, rng.point(1.0) - normal, 0.0, 1.0)
                }
            }
        })
        .collect()
}

/// Batch sizes around the packet widths and the stream's 256-ray buffer.
const SIZES: [usize; 12] = [0, 1, 7, 8, 9, 15, 16, 17, 33, 255, 256, 301];

#[test]
fn every_kernel_occludes_as_rtc_occluded1() {
    let mut rng = Rng(7);
    let (tris, scene) = scene(&mut rng);
    let mut occluded = 0;
    for n in SIZES {
        let rays = rays(&mut rng, &tris, n);
        let single: Vec<bool> = rays.iter().map(|r| scene.occluded(r)).collect();
        occluded += single.iter().filter(|o| **o).count();
        for kernel in EmbreeKernel::ALL {
            // Each slot starts with the wrong answer, so an untouched one fails.
            let mut out: Vec<bool> = single.iter().map(|o| !o).collect();
            scene.occluded_with(kernel, Coherence::Incoherent, &rays, &mut out);
            assert_eq!(out, single, "{} on {n} rays", kernel.occluded_name());
        }
    }
    let total: usize = SIZES.iter().sum();
    assert!(
        occluded > total / 5 && occluded < total * 4 / 5,
        "{occluded} of {total} occluded"
    );
}

#[test]
fn every_kernel_intersects_as_rtc_intersect1() {
    let mut rng = Rng(11);
    let (tris, scene) = scene(&mut rng);
    let mut hits = 0;
    for n in SIZES {
        let rays = rays(&mut rng, &tris, n);
        let single: Vec<Option<(f32, u32)>> = rays.iter().map(|r| scene.intersect(r)).collect();
        hits += single.iter().filter(|h| h.is_some()).count();
        for kernel in EmbreeKernel::ALL {
            let mut out = vec![Some((-1.0, u32::MAX - 1)); n];
            scene.intersect_with(kernel, Coherence::Incoherent, &rays, &mut out);
            assert_eq!(out, single, "{} on {n} rays", kernel.intersect_name());
        }
    }
    let total: usize = SIZES.iter().sum();
    assert!(
        hits > total / 5 && hits < total * 4 / 5,
        "{hits} of {total} hit"
    );
}

/// Reversed and empty segments are never hit, by any call.
#[test]
fn reversed_and_empty_segments_miss() {
    let tri = [[
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ]];
    let scene = EmbreeScene::new(&tri, EmbreeQuality::Medium, Some(1)).unwrap();
    let down = |t_min, t_max| Ray::new(Vec3::new(0.0, 0.0, 1.0), -Vec3::Z, t_min, t_max);
    // The plane is at t = 1: through it, reversed around it, empty before it.
    let rays = [
        down(0.0, 2.0),
        down(1.5, 0.5),
        down(0.5, 0.5),
        down(0.0, 2.0),
    ];
    let expected = [true, false, false, true];
    for kernel in EmbreeKernel::ALL {
        let mut out = [false; 4];
        scene.occluded_with(kernel, Coherence::Incoherent, &rays, &mut out);
        assert_eq!(out, expected, "{}", kernel.occluded_name());
        let mut hits = [None; 4];
        scene.intersect_with(kernel, Coherence::Incoherent, &rays, &mut hits);
        let hit = hits.map(|h| h.is_some());
        assert_eq!(hit, expected, "{}", kernel.intersect_name());
    }
}
