//! A tile's shadow rays made lane by lane: the tile's shading points and their light samples
//! held as structure of arrays and worked on in packs of [`LANES`] values held in locals, which
//! the compiler turns into SIMD (compiled for AVX2 when the CPU has it). Every lane does the
//! scalar path's IEEE operations in the same order, so the rays are bit for bit those of
//! [`super::PointRays::ray`] (tested below), only made eight at a time instead of one long
//! dependency chain each.

// Lane loops index several packs by the same lane: the shape the vectoriser widens.
#![allow(clippy::needless_range_loop)]

use glam::Vec3;

use super::lights::{disk_axes, LightLanes, LightSample};
use super::shadow::{ray_origins, SamplePlan};
use super::tiles::TILE_PIXELS;
use super::{LightSampler, SurfacePoint};
use crate::geometry::Ray;
use crate::sampling::{combine_key, concentric_disk, hash_combine, hash_u32, Strata};

/// Lanes worked on together: one AVX2 register of f32.
const LANES: usize = 8;

/// One value per lane of a pack.
type Pack<T = f32> = [T; LANES];

/// The pack of `v` starting at lane `c`.
#[inline(always)]
fn pack<T: Copy + Default>(v: &[T], c: usize) -> Pack<T> {
    let mut p = [T::default(); LANES];
    p.copy_from_slice(&v[c..c + LANES]);
    p
}

/// Points a tile holds at most: its pixels (a whole number of packs).
const POINTS: usize = TILE_PIXELS;
const _: () = assert!(POINTS.is_multiple_of(LANES));

/// One coordinate per point, three arrays.
struct Lanes3 {
    x: [f32; POINTS],
    y: [f32; POINTS],
    z: [f32; POINTS],
}

impl Default for Lanes3 {
    fn default() -> Self {
        Lanes3 {
            x: [0.0; POINTS],
            y: [0.0; POINTS],
            z: [0.0; POINTS],
        }
    }
}

impl Lanes3 {
    #[inline(always)]
    fn get(&self, k: usize) -> Vec3 {
        Vec3::new(self.x[k], self.y[k], self.z[k])
    }

    #[inline(always)]
    fn set(&mut self, k: usize, v: Vec3) {
        (self.x[k], self.y[k], self.z[k]) = v.into();
    }

    /// The pack starting at lane `c`, one array per coordinate.
    #[inline(always)]
    fn pack(&self, c: usize) -> [Pack; 3] {
        [pack(&self.x, c), pack(&self.y, c), pack(&self.z, c)]
    }

    #[inline(always)]
    fn store(&mut self, c: usize, p: &[Pack; 3]) {
        self.x[c..c + LANES].copy_from_slice(&p[0]);
        self.y[c..c + LANES].copy_from_slice(&p[1]);
        self.z[c..c + LANES].copy_from_slice(&p[2]);
    }

    /// Lane `j` of a pack as a vector.
    #[inline(always)]
    fn lane(p: &[Pack; 3], j: usize) -> Vec3 {
        Vec3::new(p[0][j], p[1][j], p[2][j])
    }

    #[inline(always)]
    fn set_lane(p: &mut [Pack; 3], j: usize, v: Vec3) {
        (p[0][j], p[1][j], p[2][j]) = v.into();
    }
}

/// A tile's shading points (those the light reaches) and the buffers their samples are made in,
/// reused from tile to tile. Arrays are worked on in [`Self::width`] lanes: the points, then up
/// to a whole pack of lanes left from earlier tiles (made and never read).
pub(super) struct SampleLanes {
    /// Points held.
    len: usize,
    // Per point.
    position: Lanes3,
    normal: Lanes3,
    facing: Lanes3,
    /// The offset ray origins on the normal's side and on the other ([`ray_origins`]).
    front: Lanes3,
    back: Lanes3,
    /// A sphere light's disk axes facing the point.
    axis1: Lanes3,
    axis2: Lanes3,
    /// The image pixel (it seeds the point's pattern).
    pixel: [u32; POINTS],
    // The pattern's walk per point ([`Strata::walk`]).
    seed: [u32; POINTS],
    cell: [u32; POINTS],
    stride: [u32; POINTS],
    /// Every point's samples in [0,1)^2, sample by sample: sample `s` of point `k` at
    /// `s * width + k`.
    u: [Vec<f32>; 2],
    /// One sample of every point mapped to the unit disk.
    disk: [[f32; POINTS]; 2],
    /// The sample on the light (a point) or towards it (a direction).
    target: Lanes3,
    scratch: Vec<[f32; 2]>,
}

impl Default for SampleLanes {
    fn default() -> Self {
        SampleLanes {
            len: 0,
            position: Lanes3::default(),
            normal: Lanes3::default(),
            facing: Lanes3::default(),
            front: Lanes3::default(),
            back: Lanes3::default(),
            axis1: Lanes3::default(),
            axis2: Lanes3::default(),
            pixel: [0; POINTS],
            seed: [0; POINTS],
            cell: [0; POINTS],
            stride: [0; POINTS],
            u: Default::default(),
            disk: [[0.0; POINTS]; 2],
            target: Lanes3::default(),
            scratch: Vec::new(),
        }
    }
}

impl SampleLanes {
    pub(super) fn clear(&mut self) {
        self.len = 0;
    }

    /// Points held.
    pub(super) fn len(&self) -> usize {
        self.len
    }

    /// True when no more points fit (a tile's pixels).
    pub(super) fn is_full(&self) -> bool {
        self.len == POINTS
    }

    /// Lanes the loops work on: the points rounded up to whole packs.
    fn width(&self) -> usize {
        self.len.next_multiple_of(LANES)
    }

    /// Adds the shading point of image pixel `pixel` (one the light reaches).
    #[inline]
    pub(super) fn push(&mut self, surface: &SurfacePoint, pixel: usize) {
        // A tile has at most `POINTS` pixels.
        let k = self.len;
        self.position.set(k, surface.position);
        self.normal.set(k, surface.normal);
        self.facing.set(k, surface.facing);
        self.pixel[k] = pixel as u32;
        self.len += 1;
    }

    /// The points' rays to `light` in `rays`, sample by sample and, within a sample, in the
    /// points' order, with each ray's point in `owners`; samples behind a point's facing
    /// normal take no ray. Returns how many did not.
    pub(super) fn make_rays(
        &mut self,
        light: &LightSampler,
        plan: SamplePlan,
        rays: &mut Vec<Ray>,
        owners: &mut Vec<u32>,
    ) -> u64 {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked just above).
            return unsafe { self.make_rays_avx2(light, plan, rays, owners) };
        }
        self.make_rays_lanes(light, plan, rays, owners)
    }

    /// [`Self::make_rays`] with every loop compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn make_rays_avx2(
        &mut self,
        light: &LightSampler,
        plan: SamplePlan,
        rays: &mut Vec<Ray>,
        owners: &mut Vec<u32>,
    ) -> u64 {
        self.make_rays_lanes(light, plan, rays, owners)
    }

    #[inline(always)]
    fn make_rays_lanes(
        &mut self,
        light: &LightSampler,
        plan: SamplePlan,
        rays: &mut Vec<Ray>,
        owners: &mut Vec<u32>,
    ) -> u64 {
        let n = self.len();
        let spp = plan.samples as usize;
        let shape = light.lanes();
        self.prepare_points(shape);
        self.pattern(plan);
        rays.clear();
        owners.clear();
        rays.resize(spp * n, Ray::new(Vec3::ZERO, Vec3::ZERO, 0.0, 0.0));
        owners.resize(spp * n, 0);
        let mut len = 0;
        for s in 0..spp {
            len = if self.targets(s, shape, light) {
                self.rays_to::<true>(rays, owners, len)
            } else {
                self.rays_to::<false>(rays, owners, len)
            };
        }
        rays.truncate(len);
        owners.truncate(len);
        (spp * n - len) as u64
    }

    /// What each point's samples share: its ray origins ([`ray_origins`]) and a sphere light's
    /// disk axes facing it ([`disk_axes`]).
    #[inline(always)]
    fn prepare_points(&mut self, shape: LightLanes) {
        for c in (0..self.width()).step_by(LANES) {
            let p = self.position.pack(c);
            let n = self.normal.pack(c);
            let f = self.facing.pack(c);
            let (mut front, mut back) = ([[0.0; LANES]; 3], [[0.0; LANES]; 3]);
            for j in 0..LANES {
                let origins = ray_origins(
                    Lanes3::lane(&p, j),
                    Lanes3::lane(&n, j),
                    Lanes3::lane(&f, j),
                );
                Lanes3::set_lane(&mut front, j, origins.0);
                Lanes3::set_lane(&mut back, j, origins.1);
            }
            self.front.store(c, &front);
            self.back.store(c, &back);
            if let LightLanes::Sphere { center, .. } = shape {
                let (mut s, mut t) = ([[0.0; LANES]; 3], [[0.0; LANES]; 3]);
                for j in 0..LANES {
                    let axes = disk_axes(Lanes3::lane(&p, j), center);
                    Lanes3::set_lane(&mut s, j, axes.0);
                    Lanes3::set_lane(&mut t, j, axes.1);
                }
                self.axis1.store(c, &s);
                self.axis2.store(c, &t);
            }
        }
    }

    /// Every point's samples in `u` ([`SamplePlan::extend_samples`] per point).
    #[inline(always)]
    fn pattern(&mut self, plan: SamplePlan) {
        let (n, width) = (self.len(), self.width());
        let spp = plan.samples as usize;
        for u in &mut self.u {
            u.clear();
            u.resize(spp * width, 0.5);
        }
        if plan.samples == 1 {
            return;
        }
        let strata = Strata::new(plan.samples);
        if !strata.pow2 {
            // Grids of other sides divide per sample: made one point at a time.
            for k in 0..n {
                self.scratch.clear();
                plan.extend_samples(self.pixel[k] as usize, &mut self.scratch);
                for (s, p) in self.scratch.iter().enumerate() {
                    self.u[0][s * width + k] = p[0];
                    self.u[1][s * width + k] = p[1];
                }
            }
            return;
        }
        let base = hash_combine(plan.seed, plan.light_index);
        for k in 0..width {
            self.seed[k] = hash_combine(base, self.pixel[k]);
        }
        for k in 0..width {
            (self.cell[k], self.stride[k]) = strata.walk(self.seed[k]);
        }
        for c in (0..width).step_by(LANES) {
            let seeds = pack(&self.seed, c);
            let strides = pack(&self.stride, c);
            let mut cells = pack(&self.cell, c);
            for s in 0..spp {
                let key = combine_key(s as u32);
                let (mut ux, mut uy) = ([0.0; LANES], [0.0; LANES]);
                for j in 0..LANES {
                    [ux[j], uy[j]] = strata.point_pow2(cells[j], hash_u32(seeds[j] ^ key));
                    let next = cells[j] + strides[j];
                    cells[j] = if next >= strata.cells {
                        next - strata.cells
                    } else {
                        next
                    };
                }
                let at = s * width + c;
                self.u[0][at..at + LANES].copy_from_slice(&ux);
                self.u[1][at..at + LANES].copy_from_slice(&uy);
            }
        }
    }

    /// Sample `s` of every point on (or towards) the light in `target`; true when the targets
    /// are points on the light, false when they are directions.
    #[inline(always)]
    fn targets(&mut self, s: usize, shape: LightLanes, light: &LightSampler) -> bool {
        let width = self.width();
        let at = s * width;
        match shape {
            LightLanes::Fixed(sample) => {
                let (LightSample::Point(q) | LightSample::Direction(q)) = sample;
                self.target.x[..width].fill(q.x);
                self.target.y[..width].fill(q.y);
                self.target.z[..width].fill(q.z);
                matches!(sample, LightSample::Point(_))
            }
            LightLanes::Sphere { center, radius } => {
                self.disk_map(at);
                for c in (0..width).step_by(LANES) {
                    let d = [pack(&self.disk[0], c), pack(&self.disk[1], c)];
                    let (a, b) = (self.axis1.pack(c), self.axis2.pack(c));
                    let mut q = [[0.0; LANES]; 3];
                    for j in 0..LANES {
                        // center + (t1 * d[0] + t2 * d[1]) * radius, as `LightFrom::sample`.
                        let (t1, t2) = (Lanes3::lane(&a, j), Lanes3::lane(&b, j));
                        let v = center + (t1 * d[0][j] + t2 * d[1][j]) * radius;
                        Lanes3::set_lane(&mut q, j, v);
                    }
                    self.target.store(c, &q);
                }
                true
            }
            LightLanes::Sun {
                to_sun,
                tan_half_angle,
                t1,
                t2,
            } => {
                self.disk_map(at);
                for c in (0..width).step_by(LANES) {
                    let d = [pack(&self.disk[0], c), pack(&self.disk[1], c)];
                    let mut q = [[0.0; LANES]; 3];
                    for j in 0..LANES {
                        // As `LightFrom::sample`: glam's normalize is a reciprocal length.
                        let w = to_sun + (t1 * d[0][j] + t2 * d[1][j]) * tan_half_angle;
                        Lanes3::set_lane(&mut q, j, w.normalize());
                    }
                    self.target.store(c, &q);
                }
                false
            }
            LightLanes::Area => {
                for k in 0..self.len() {
                    let u = [self.u[0][at + k], self.u[1][at + k]];
                    let (LightSample::Point(q) | LightSample::Direction(q)) =
                        light.sample(self.position.get(k), u);
                    self.target.set(k, q);
                }
                true
            }
        }
    }

    /// The samples at lane `at` of `u` (one per point) mapped to the disk, in `disk`.
    #[inline(always)]
    fn disk_map(&mut self, at: usize) {
        let width = self.width();
        let [ux, uy] = &self.u;
        let [dx, dy] = &mut self.disk;
        disk_lanes(
            &ux[at..at + width],
            &uy[at..at + width],
            &mut dx[..width],
            &mut dy[..width],
        );
    }

    /// Each point's ray towards its target (a point on the light when `AT_LIGHT`, else a
    /// direction) written at `rays[len..]`, with its point in `owners`, when the target is in
    /// front of the point's facing normal (`PointRays::ray_to`); returns the new `len`.
    #[inline(always)]
    fn rays_to<const AT_LIGHT: bool>(
        &self,
        rays: &mut [Ray],
        owners: &mut [u32],
        mut len: usize,
    ) -> usize {
        let t_max = if AT_LIGHT { 1.0 } else { f32::INFINITY };
        let points = self.len();
        for c in (0..self.width()).step_by(LANES) {
            let q = self.target.pack(c);
            let p = self.position.pack(c);
            let n = self.normal.pack(c);
            let f = self.facing.pack(c);
            let front = self.front.pack(c);
            let back = self.back.pack(c);
            let (mut origin, mut direction) = ([[0.0; LANES]; 3], [[0.0; LANES]; 3]);
            let mut valid = [false; LANES];
            for j in 0..LANES {
                let q = Lanes3::lane(&q, j);
                let towards = if AT_LIGHT { q - Lanes3::lane(&p, j) } else { q };
                // NaN takes a ray, as in `PointRays::ray_to`.
                let behind = Lanes3::lane(&f, j).dot(towards) <= 0.0;
                valid[j] = !behind;
                // Selected coordinate by coordinate: a select per lane, not a branch.
                let on_front = Lanes3::lane(&n, j).dot(towards) > 0.0;
                for a in 0..3 {
                    origin[a][j] = if on_front { front[a][j] } else { back[a][j] };
                }
                let o = Lanes3::lane(&origin, j);
                Lanes3::set_lane(&mut direction, j, if AT_LIGHT { q - o } else { q });
            }
            // Kept rays packed to the front: every lane is written, the count moves only for
            // the valid ones (no branch on a coin toss).
            for j in 0..LANES.min(points - c) {
                rays[len] = Ray::new(
                    Lanes3::lane(&origin, j),
                    Lanes3::lane(&direction, j),
                    0.0,
                    t_max,
                );
                owners[len] = (c + j) as u32;
                len += usize::from(valid[j]);
            }
        }
        len
    }
}

/// The concentric disk map of each lane's `(ux, uy)` into `(dx, dy)`. A loop over slices, not
/// packs: the vectoriser widens its f64 series here, where it leaves a pack's unrolled lanes
/// scalar.
#[inline(always)]
fn disk_lanes(ux: &[f32], uy: &[f32], dx: &mut [f32], dy: &mut [f32]) {
    let n = ux.len();
    let (uy, dx, dy) = (&uy[..n], &mut dx[..n], &mut dy[..n]);
    for k in 0..n {
        [dx[k], dy[k]] = concentric_disk([ux[k], uy[k]]);
    }
}

#[cfg(test)]
mod tests {
    use glam::{DMat4, DQuat, DVec3};

    use super::*;
    use crate::render::PointRays;
    use crate::sampling::{hash_u32, unit_float};
    use crate::scene::{AreaShape, Light, LightKind, RenderSpace, TriangleRef};

    fn every_light_kind() -> Vec<Light> {
        let at = |p: DVec3, turn: f64| {
            DMat4::from_rotation_translation(
                DQuat::from_euler(glam::EulerRot::XYZ, turn, 0.4, 0.1),
                p,
            )
        };
        let area = |shape, size_x, size_y| LightKind::Area {
            shape,
            size_x,
            size_y,
        };
        [
            LightKind::Point { radius: 0.0 },
            LightKind::Point { radius: 0.7 },
            LightKind::Spot {
                radius: 0.3,
                spot_size: 2.0,
                spot_blend: 0.1,
            },
            LightKind::Sun { angle: 0.0 },
            LightKind::Sun { angle: 0.2 },
            area(AreaShape::Square, 1.5, 0.0),
            area(AreaShape::Rectangle, 2.0, 0.5),
            area(AreaShape::Disk, 1.0, 0.0),
            area(AreaShape::Ellipse, 3.0, 0.25),
        ]
        .into_iter()
        .enumerate()
        .map(|(i, kind)| {
            let p = DVec3::new(0.5 * i as f64 - 2.0, 3.0, 1.0 + 0.25 * i as f64);
            Light::new(format!("light {i}"), at(p, 2.8 + 0.1 * i as f64), kind)
        })
        .collect()
    }

    /// Points on every side of every light, some with a shading normal turned from the
    /// geometric one (so both ray origins and back-facing samples occur).
    fn surface_points(n: u32) -> Vec<SurfacePoint> {
        (0..n)
            .map(|i| {
                let f = |salt: u32| unit_float(hash_u32(i * 7 + salt)) * 2.0 - 1.0;
                let position = Vec3::new(4.0 * f(1), 2.0 * f(2), 3.0 * f(3));
                let normal = Vec3::new(f(4), f(5), f(6)).normalize_or(Vec3::Z);
                let facing = if i % 3 == 0 {
                    (normal + 0.8 * Vec3::new(f(7), f(8), f(9))).normalize_or(normal)
                } else {
                    normal
                };
                SurfacePoint {
                    position,
                    normal,
                    facing,
                    triangle: 0,
                    instance: 0,
                    reference: TriangleRef {
                        object: 0,
                        primitive: 0,
                    },
                }
            })
            .collect()
    }

    /// A ray's bits, so -0.0 and NaN compare as the scalar path made them.
    fn bits(r: &Ray) -> [u32; 8] {
        let (o, d) = (r.origin, r.direction);
        [o.x, o.y, o.z, d.x, d.y, d.z, r.t_min, r.t_max].map(f32::to_bits)
    }

    /// The lanes' rays, on the dispatched path (AVX2 here) and on the portable one, are the
    /// scalar `PointRays::ray` of every sample, bit for bit and in the pass's order, for every
    /// light kind, grids of power-of-two and other sides, and one sample.
    #[test]
    fn lanes_make_the_scalar_rays_bit_for_bit() {
        let space = RenderSpace {
            origin: DVec3::new(0.25, -0.5, 0.0),
            scale: 2.0,
        };
        let points = surface_points(61);
        let mut lanes = SampleLanes::default();
        let (mut rays, mut owners) = (Vec::new(), Vec::new());
        for (light_index, light) in every_light_kind().iter().enumerate() {
            let sampler = LightSampler::new(light, &space);
            for samples in [1u32, 2, 4, 7, 9, 16, 64] {
                let plan = SamplePlan {
                    light_index: light_index as u32,
                    samples,
                    seed: 11,
                };
                lanes.clear();
                let first_pixel = 1000;
                for (k, p) in points.iter().enumerate() {
                    lanes.push(p, first_pixel + k);
                }
                let (mut want, mut want_owners, mut behind) = (Vec::new(), Vec::new(), 0);
                let mut u = Vec::new();
                for s in 0..samples as usize {
                    for (k, p) in points.iter().enumerate() {
                        u.clear();
                        plan.extend_samples(first_pixel + k, &mut u);
                        match PointRays::new(p, &sampler).ray(u[s]) {
                            Some(r) => {
                                want.push(bits(&r));
                                want_owners.push(k as u32);
                            }
                            None => behind += 1,
                        }
                    }
                }
                let what = format!("{} at {samples} samples", light.name);
                assert!(
                    !want.is_empty() && behind > 0,
                    "{what}: both kinds of sample"
                );
                for portable in [false, true] {
                    let back_facing = if portable {
                        lanes.make_rays_lanes(&sampler, plan, &mut rays, &mut owners)
                    } else {
                        lanes.make_rays(&sampler, plan, &mut rays, &mut owners)
                    };
                    let got: Vec<_> = rays.iter().map(bits).collect();
                    assert_eq!(got, want, "{what}, portable {portable}");
                    assert_eq!(owners, want_owners, "{what}, portable {portable}");
                    assert_eq!(back_facing, behind, "{what}, portable {portable}");
                }
            }
        }
    }
}
