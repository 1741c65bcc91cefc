//! Random triangle soups and rays in the caller's space, and the brute-force reference in the
//! scene's render space, for the ray-query tests.
#![allow(dead_code)]

use antumbra_core::geometry::Ray as RenderRay;
use antumbra_core::trace::{brute_closest_hit, brute_occluded};
use antumbra_rays::{Hit, Ray, Scene};
use glam::{DVec3, Vec3};

/// SplitMix64: deterministic, no dependencies.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [lo, hi), on f32's grid of [0, 1).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * ((self.next_u64() >> 40) as f32 / (1u64 << 24) as f32)
    }
    pub fn vec3(&mut self, lo: f32, hi: f32) -> [f32; 3] {
        [0; 3].map(|_| self.range(lo, hi))
    }
}

/// `n` random, mutually intersecting triangles in about [-5, 5]^3, each with its own vertices.
pub fn soup(rng: &mut Rng, n: usize) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut vertices = Vec::with_capacity(3 * n);
    let mut triangles = Vec::with_capacity(n);
    for t in 0..n as u32 {
        let c = Vec3::from(rng.vec3(-5.0, 5.0));
        let size = rng.range(0.2, 4.0);
        for _ in 0..3 {
            vertices.push((c + Vec3::from(rng.vec3(-0.5, 0.5)) * size).to_array());
        }
        triangles.push([3 * t, 3 * t + 1, 3 * t + 2]);
    }
    (vertices, triangles)
}

/// Rays from about [-7, 7]^3 in random directions; some axis-parallel (zeros of both signs),
/// some grazing, a third of them segments.
pub fn rays(rng: &mut Rng, n: usize) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let o = rng.vec3(-7.0, 7.0).map(f64::from);
            let mut d = rng.vec3(-1.0, 1.0).map(f64::from);
            match i % 8 {
                0 => (d[1], d[2]) = (0.0, -0.0),
                1 => (d[0], d[2]) = (-0.0, 0.0),
                2 => d[1] = 1e-7,
                _ => {}
            }
            if d == [0.0; 3] || d == [-0.0, 0.0, 0.0] {
                d = [1.0, 0.0, 0.0];
            }
            let t_far = if i % 3 == 0 { 4.0 } else { f32::INFINITY };
            Ray::segment(o, d, 0.0, t_far)
        })
        .collect()
}

/// `ray` in the scene's render space, as the scene moves it (the default interval).
pub fn render_ray(scene: &Scene, ray: &Ray) -> RenderRay {
    let space = scene.space();
    RenderRay::new(
        space.point(DVec3::from(ray.origin)).as_vec3(),
        space.vector(DVec3::from(ray.direction)).as_vec3(),
        ray.t_near,
        ray.t_far,
    )
}

/// The caller's triangles in the scene's render space; a triangle's index is the caller's.
pub fn render_triangles(
    scene: &Scene,
    vertices: &[[f32; 3]],
    triangles: &[[u32; 3]],
) -> Vec<[Vec3; 3]> {
    let space = scene.space();
    triangles
        .iter()
        .map(|t| {
            t.map(|i| {
                space
                    .point(Vec3::from(vertices[i as usize]).as_dvec3())
                    .as_vec3()
            })
        })
        .collect()
}

/// The brute-force closest hit, in the caller's terms.
pub fn brute_hit(tris: &[[Vec3; 3]], ray: &RenderRay) -> Option<Hit> {
    brute_closest_hit(tris, ray).map(|h| Hit {
        t: h.t,
        triangle: h.triangle,
        u: h.b1,
        v: h.b2,
    })
}

pub fn brute_blocked(tris: &[[Vec3; 3]], ray: &RenderRay) -> bool {
    brute_occluded(tris, ray)
}
