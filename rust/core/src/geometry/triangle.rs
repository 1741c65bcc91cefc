//! The watertight ray/triangle test of Woop, Benthin and Wald (JCGT 2013).
//!
//! The ray is sheared so that it runs along +z through the origin; the three 2D edge functions
//! of the projected triangle then decide the hit. Edges shared by two triangles give the same
//! edge function value with opposite sign in both, so a ray through a shared edge or vertex hits
//! at least one of them: no cracks. When an edge function is exactly 0 in f32 it is recomputed
//! in f64, where the product of two f32 is exact, so the sign is the true sign.

use glam::Vec3;

use super::Ray;

/// Per-ray values of the watertight test, computed once per ray.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    pub origin: Vec3,
    pub(crate) kx: usize,
    pub(crate) ky: usize,
    pub(crate) kz: usize,
    pub(crate) sx: f32,
    pub(crate) sy: f32,
    pub(crate) sz: f32,
}

impl WatertightRay {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        // Components by a runtime axis from the ray's own memory: indexing a Vec3 by a runtime
        // axis compiles to a branchy match, an array index to one load.
        let d: &[f32; 3] = ray.direction.as_ref();
        let a = ray.direction.abs();
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Keep the winding of the projected triangle independent of the direction's sign.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        WatertightRay {
            origin: ray.origin,
            kx,
            ky,
            kz,
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: 1.0 / d[kz],
        }
    }
}

/// A hit: the ray parameter and the barycentric weights of the three vertices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    pub t: f32,
    pub b0: f32,
    pub b1: f32,
    pub b2: f32,
}

/// Intersects the ray with triangle `v` for t in (`t_min`, `t_max`]. Both faces count. Returns
/// `None` for degenerate triangles (zero determinant).
#[inline(always)]
pub fn intersect_triangle(
    ray: &WatertightRay,
    v: &[Vec3; 3],
    t_min: f32,
    t_max: f32,
) -> Option<TriangleHit> {
    let (kx, ky, kz) = (ray.kx, ray.ky, ray.kz);
    // Arrays, not Vec3: indexing a Vec3 by a runtime axis compiles to a branchy match.
    let a = (v[0] - ray.origin).to_array();
    let b = (v[1] - ray.origin).to_array();
    let c = (v[2] - ray.origin).to_array();
    let ax = a[kx] - ray.sx * a[kz];
    let ay = a[ky] - ray.sy * a[kz];
    let bx = b[kx] - ray.sx * b[kz];
    let by = b[ky] - ray.sy * b[kz];
    let cx = c[kx] - ray.sx * c[kz];
    let cy = c[ky] - ray.sy * c[kz];
    let mut u = cx * by - cy * bx;
    let mut v_ = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v_ == 0.0 || w == 0.0 {
        u = (cx as f64 * by as f64 - cy as f64 * bx as f64) as f32;
        v_ = (ax as f64 * cy as f64 - ay as f64 * cx as f64) as f32;
        w = (bx as f64 * ay as f64 - by as f64 * ax as f64) as f32;
    }
    if (u < 0.0 || v_ < 0.0 || w < 0.0) && (u > 0.0 || v_ > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v_ + w;
    if det == 0.0 {
        return None;
    }
    let az = ray.sz * a[kz];
    let bz = ray.sz * b[kz];
    let cz = ray.sz * c[kz];
    let t_scaled = u * az + v_ * bz + w * cz;
    // Divide only for triangles that passed the edge tests, and compare the quotient itself:
    // a scaled comparison before dividing rounds differently and would let two traversal
    // orders disagree on exact ties.
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    if !(t > t_min && t <= t_max) {
        return None;
    }
    Some(TriangleHit {
        t,
        b0: u * inv,
        b1: v_ * inv,
        b2: w * inv,
    })
}

/// Unnormalised geometric normal, (v1 - v0) x (v2 - v0).
#[inline]
pub fn triangle_normal(v: &[Vec3; 3]) -> Vec3 {
    (v[1] - v[0]).cross(v[2] - v[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> [Vec3; 3] {
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]
    }

    #[test]
    fn hits_front_and_back() {
        for dz in [-1.0f32, 1.0] {
            let ray = Ray::new(
                Vec3::new(0.25, 0.25, -dz),
                Vec3::new(0.0, 0.0, dz),
                0.0,
                10.0,
            );
            let h = intersect_triangle(&WatertightRay::new(&ray), &tri(), 0.0, 10.0).unwrap();
            assert_eq!(h.t, 1.0);
            assert!((h.b0 - 0.5).abs() < 1e-6 && (h.b1 - 0.25).abs() < 1e-6);
        }
    }

    #[test]
    fn respects_segment() {
        let ray = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, 0.5);
        assert!(intersect_triangle(&WatertightRay::new(&ray), &tri(), 0.0, 0.5).is_none());
        assert!(intersect_triangle(&WatertightRay::new(&ray), &tri(), 0.0, 1.0).is_some());
        assert!(intersect_triangle(&WatertightRay::new(&ray), &tri(), 1.0, 2.0).is_none());
    }

    #[test]
    fn shared_edge_is_hit_by_one_of_two() {
        let t1 = tri();
        let t2 = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        // Through the diagonal edge, exactly.
        let ray = Ray::new(Vec3::new(0.5, 0.5, 1.0), Vec3::NEG_Z, 0.0, 10.0);
        let w = WatertightRay::new(&ray);
        let hits = [&t1, &t2]
            .iter()
            .filter(|t| intersect_triangle(&w, t, 0.0, 10.0).is_some())
            .count();
        assert!(hits >= 1);
    }

    #[test]
    fn degenerate_triangle_never_hits() {
        let line = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        let ray = Ray::new(Vec3::new(1.0, 0.0, 1.0), Vec3::NEG_Z, 0.0, 10.0);
        assert!(intersect_triangle(&WatertightRay::new(&ray), &line, 0.0, 10.0).is_none());
    }
}
