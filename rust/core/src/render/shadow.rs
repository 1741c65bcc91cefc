//! Shadow rays: for each pixel with a surface, one ray per light sample, any hit.

use std::time::Instant;

use rayon::prelude::*;

use super::{LightSample, LightSampler, PrimaryPass, SurfacePoint};
use crate::bvh::Bvh;
use crate::geometry::{offset_ray_origin, Ray};
use crate::output::ImagePlane;
use crate::sampling::{hash_combine, stratified_2d};
use crate::trace::{occluded, AnyHitOrder, Counters, NoStats, TraversalStats};

/// What happened to the shadow samples of one light, counted over a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ShadowRayOutcome {
    /// Rays traced.
    pub rays: u64,
    /// Traced rays that hit an occluder.
    pub occluded: u64,
    /// Samples on the far side of the surface's own plane: shadowed without a ray.
    pub back_facing: u64,
    /// Samples of points the light cannot reach (outside a spot cone, behind an area light).
    pub unreached: u64,
}

impl std::ops::AddAssign for ShadowRayOutcome {
    fn add_assign(&mut self, o: Self) {
        self.rays += o.rays;
        self.occluded += o.occluded;
        self.back_facing += o.back_facing;
        self.unreached += o.unreached;
    }
}

/// The shadow pass of one light.
#[derive(Clone, Debug)]
pub struct ShadowPass {
    /// 1 = lit, 0 = shadowed; fractions for soft lights. Pixels whose primary ray missed are 1.
    pub mask: ImagePlane,
    pub work: Vec<TraversalStats>,
    pub totals: TraversalStats,
    pub outcome: ShadowRayOutcome,
    pub trace_ms: f64,
}

/// Samples per pixel actually used for a light.
pub fn samples_for(light: &LightSampler, spp: u32) -> u32 {
    if light.hard {
        1
    } else {
        spp
    }
}

impl ShadowPass {
    pub fn counted(
        primary: &PrimaryPass,
        bvh: &Bvh,
        light: &LightSampler,
        light_index: u32,
        spp: u32,
        seed: u32,
        order: AnyHitOrder,
    ) -> Self {
        let start = Instant::now();
        let n = samples_for(light, spp);
        let results: Vec<(f32, ShadowRayOutcome, TraversalStats)> = primary
            .surfaces
            .par_iter()
            .enumerate()
            .with_min_len(64)
            .map_init(Vec::new, |scratch, (pixel, s)| {
                let mut stats = TraversalStats::default();
                let (v, o) = shade_pixel(
                    s,
                    pixel,
                    bvh,
                    light,
                    light_index,
                    n,
                    seed,
                    order,
                    scratch,
                    &mut stats,
                );
                (v, o, stats)
            })
            .collect();
        let trace_ms = start.elapsed().as_secs_f64() * 1e3;
        let mut mask = ImagePlane::new(light.name.clone(), primary.width, primary.height);
        let mut work = Vec::with_capacity(results.len());
        let mut totals = TraversalStats::default();
        let mut outcome = ShadowRayOutcome::default();
        for (d, (v, o, w)) in mask.data.iter_mut().zip(results) {
            *d = v;
            outcome += o;
            totals += w;
            work.push(w);
        }
        ShadowPass {
            mask,
            work,
            totals,
            outcome,
            trace_ms,
        }
    }

    pub fn timed(
        primary: &PrimaryPass,
        bvh: &Bvh,
        light: &LightSampler,
        light_index: u32,
        spp: u32,
        seed: u32,
        order: AnyHitOrder,
    ) -> Self {
        let start = Instant::now();
        let n = samples_for(light, spp);
        let results: Vec<(f32, ShadowRayOutcome)> = primary
            .surfaces
            .par_iter()
            .enumerate()
            .with_min_len(64)
            .map_init(Vec::new, |scratch, (pixel, s)| {
                shade_pixel(
                    s,
                    pixel,
                    bvh,
                    light,
                    light_index,
                    n,
                    seed,
                    order,
                    scratch,
                    &mut NoStats,
                )
            })
            .collect();
        let trace_ms = start.elapsed().as_secs_f64() * 1e3;
        let mut mask = ImagePlane::new(light.name.clone(), primary.width, primary.height);
        let mut outcome = ShadowRayOutcome::default();
        for (d, (v, o)) in mask.data.iter_mut().zip(results) {
            *d = v;
            outcome += o;
        }
        ShadowPass {
            mask,
            work: Vec::new(),
            totals: TraversalStats::default(),
            outcome,
            trace_ms,
        }
    }
}

/// The shadow ray from a surface point towards a light sample, or `None` when the sample lies
/// behind the surface's own plane.
#[inline]
pub fn shadow_ray(surface: &SurfacePoint, sample: LightSample) -> Option<Ray> {
    let p = surface.position;
    let n = surface.normal;
    let towards = match sample {
        LightSample::Point(q) => q - p,
        LightSample::Direction(w) => w,
    };
    if n.dot(towards) <= 0.0 {
        return None;
    }
    let origin = offset_ray_origin(p, n);
    Some(match sample {
        // t in (0, 1]: the segment ends on the light (lights are not geometry).
        LightSample::Point(q) => Ray::new(origin, q - origin, 0.0, 1.0),
        LightSample::Direction(w) => Ray::new(origin, w, 0.0, f32::INFINITY),
    })
}

#[allow(clippy::too_many_arguments)]
#[inline]
fn shade_pixel<C: Counters>(
    surface: &Option<SurfacePoint>,
    pixel: usize,
    bvh: &Bvh,
    light: &LightSampler,
    light_index: u32,
    n: u32,
    seed: u32,
    order: AnyHitOrder,
    scratch: &mut Vec<[f32; 2]>,
    stats: &mut C,
) -> (f32, ShadowRayOutcome) {
    let mut outcome = ShadowRayOutcome::default();
    let Some(s) = surface else {
        return (1.0, outcome);
    };
    if !light.reaches(s.position) {
        outcome.unreached = n as u64;
        return (0.0, outcome);
    }
    if n == 1 {
        scratch.clear();
        scratch.push([0.5, 0.5]);
    } else {
        stratified_2d(
            n,
            hash_combine(hash_combine(seed, light_index), pixel as u32),
            scratch,
        );
    }
    let mut lit = 0u32;
    for &u in scratch.iter() {
        let Some(ray) = shadow_ray(s, light.sample(s.position, u)) else {
            outcome.back_facing += 1;
            continue;
        };
        outcome.rays += 1;
        if occluded(bvh, &ray, order, stats) {
            outcome.occluded += 1;
        } else {
            lit += 1;
        }
    }
    (lit as f32 / n as f32, outcome)
}
