//! Shadow rays: for each pixel with a surface, one ray per light sample, any hit.

use std::time::Instant;

use rayon::prelude::*;

use super::primary::{tile_stopped, TILE};
use super::{LightSample, LightSampler, PrimaryPass, SurfacePoint};
use crate::cancel::CancelToken;
use crate::geometry::{offset_ray_origin, Ray};
use crate::image::ImagePlane;
use crate::sampling::hash_u32;
use crate::sampling::{hash_combine, stratified_2d};
use crate::trace::{Counters, NoStats, OcclusionQuery, TraversalStats};
use crate::Result;

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
    /// `tracer` is the tree with this light's child order.
    pub fn counted(
        primary: &PrimaryPass,
        tracer: &impl OcclusionQuery,
        light: &LightSampler,
        light_index: u32,
        spp: u32,
        seed: u32,
    ) -> Self {
        let never = CancelToken::new();
        Self::counted_cancellable(primary, tracer, light, light_index, spp, seed, &never)
            .expect("a new token is never cancelled")
    }

    /// As [`counted`](Self::counted), stopping with [`crate::Error::Cancelled`] once `cancel`
    /// is set (read once per tile of pixels).
    pub fn counted_cancellable(
        primary: &PrimaryPass,
        tracer: &impl OcclusionQuery,
        light: &LightSampler,
        light_index: u32,
        spp: u32,
        seed: u32,
        cancel: &CancelToken,
    ) -> Result<Self> {
        let start = Instant::now();
        let n = samples_for(light, spp);
        let results: Vec<(f32, ShadowRayOutcome, TraversalStats)> = primary
            .surfaces
            .par_iter()
            .enumerate()
            .with_min_len(TILE)
            .map_init(
                || (Vec::new(), false),
                |(scratch, stopped), (pixel, s)| {
                    let mut stats = TraversalStats::default();
                    if tile_stopped(pixel, stopped, cancel) {
                        return (1.0, ShadowRayOutcome::default(), stats);
                    }
                    let (v, o) = shade_pixel(
                        s,
                        pixel,
                        tracer,
                        light,
                        light_index,
                        n,
                        seed,
                        scratch,
                        &mut stats,
                    );
                    (v, o, stats)
                },
            )
            .collect();
        cancel.check()?;
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
        Ok(ShadowPass {
            mask,
            work,
            totals,
            outcome,
            trace_ms,
        })
    }

    /// `tracer` is the tree with this light's child order.
    pub fn timed(
        primary: &PrimaryPass,
        tracer: &impl OcclusionQuery,
        light: &LightSampler,
        light_index: u32,
        spp: u32,
        seed: u32,
    ) -> Self {
        let never = CancelToken::new();
        Self::timed_cancellable(primary, tracer, light, light_index, spp, seed, &never)
            .expect("a new token is never cancelled")
    }

    /// As [`timed`](Self::timed), stopping with [`crate::Error::Cancelled`] once `cancel` is set.
    pub fn timed_cancellable(
        primary: &PrimaryPass,
        tracer: &impl OcclusionQuery,
        light: &LightSampler,
        light_index: u32,
        spp: u32,
        seed: u32,
        cancel: &CancelToken,
    ) -> Result<Self> {
        let start = Instant::now();
        let n = samples_for(light, spp);
        let results: Vec<(f32, ShadowRayOutcome)> = primary
            .surfaces
            .par_iter()
            .enumerate()
            .with_min_len(TILE)
            .map_init(
                || (Vec::new(), false),
                |(scratch, stopped), (pixel, s)| {
                    if tile_stopped(pixel, stopped, cancel) {
                        return (1.0, ShadowRayOutcome::default());
                    }
                    shade_pixel(
                        s,
                        pixel,
                        tracer,
                        light,
                        light_index,
                        n,
                        seed,
                        scratch,
                        &mut NoStats,
                    )
                },
            )
            .collect();
        cancel.check()?;
        let trace_ms = start.elapsed().as_secs_f64() * 1e3;
        let mut mask = ImagePlane::new(light.name.clone(), primary.width, primary.height);
        let mut outcome = ShadowRayOutcome::default();
        for (d, (v, o)) in mask.data.iter_mut().zip(results) {
            *d = v;
            outcome += o;
        }
        Ok(ShadowPass {
            mask,
            work: Vec::new(),
            totals: TraversalStats::default(),
            outcome,
            trace_ms,
        })
    }
}

/// The shadow ray from a surface point towards a light sample, or `None` when the sample lies
/// behind the surface's facing normal (its own plane, or its shading normal: [`super::Facing`]).
#[inline]
pub fn shadow_ray(surface: &SurfacePoint, sample: LightSample) -> Option<Ray> {
    let p = surface.position;
    let n = surface.normal;
    let towards = match sample {
        LightSample::Point(q) => q - p,
        LightSample::Direction(w) => w,
    };
    if surface.facing.dot(towards) <= 0.0 {
        return None;
    }
    // A shading normal may let a sample behind the plane through: the ray leaves on that side.
    let origin = offset_ray_origin(p, if n.dot(towards) > 0.0 { n } else { -n });
    Some(match sample {
        // t in (0, 1]: the segment ends on the light (lights are not geometry).
        LightSample::Point(q) => Ray::new(origin, q - origin, 0.0, 1.0),
        LightSample::Direction(w) => Ray::new(origin, w, 0.0, f32::INFINITY),
    })
}

/// How a pixel's shadow samples for one light are drawn: the same for every traversal, so
/// every method sees the same rays.
#[derive(Clone, Copy, Debug)]
pub struct SamplePlan {
    pub light_index: u32,
    pub samples: u32,
    pub seed: u32,
}

impl SamplePlan {
    /// Calls `f` with each sample's shadow ray (`None` for a sample behind the surface's own
    /// plane). Returns false, without calling `f`, when the light cannot reach the point.
    #[inline]
    pub fn for_each_ray(
        &self,
        surface: &SurfacePoint,
        pixel: usize,
        light: &LightSampler,
        scratch: &mut Vec<[f32; 2]>,
        mut f: impl FnMut(Option<Ray>),
    ) -> bool {
        if !light.reaches(surface.position) {
            return false;
        }
        if self.samples == 1 {
            scratch.clear();
            scratch.push([0.5, 0.5]);
        } else {
            let seed = hash_combine(hash_combine(self.seed, self.light_index), pixel as u32);
            stratified_2d(self.samples, seed, scratch);
        }
        for &u in scratch.iter() {
            f(shadow_ray(surface, light.sample(surface.position, u)));
        }
        true
    }
}

/// Every shadow ray of one light for a primary pass, in pixel order (for benchmarks and
/// oracles that must trace exactly the rays the shadow pass traces).
pub fn shadow_rays(primary: &PrimaryPass, light: &LightSampler, plan: SamplePlan) -> Vec<Ray> {
    let mut rays = Vec::new();
    let mut scratch = Vec::new();
    for (pixel, s) in primary.surfaces.iter().enumerate() {
        if let Some(s) = s {
            plan.for_each_ray(s, pixel, light, &mut scratch, |r| rays.extend(r));
        }
    }
    rays
}

/// The representative shadow rays of one light for per-light child sorting: the rays of a
/// pseudo-random `budget` share of the pixels (a hash of the pixel index, so the choice has no
/// image-space pattern and is the same in every run).
pub fn representative_rays(
    primary: &PrimaryPass,
    light: &LightSampler,
    plan: SamplePlan,
    budget: f32,
) -> Vec<Ray> {
    let threshold = (budget.clamp(0.0, 1.0) as f64 * u32::MAX as f64) as u32;
    let mut rays = Vec::new();
    let mut scratch = Vec::new();
    for (pixel, s) in primary.surfaces.iter().enumerate() {
        if let Some(s) = s {
            if budget >= 1.0 || hash_u32(pixel as u32 ^ 0x9e37_79b9) < threshold {
                plan.for_each_ray(s, pixel, light, &mut scratch, |r| rays.extend(r));
            }
        }
    }
    rays
}

#[allow(clippy::too_many_arguments)]
#[inline]
fn shade_pixel<C: Counters>(
    surface: &Option<SurfacePoint>,
    pixel: usize,
    tracer: &impl OcclusionQuery,
    light: &LightSampler,
    light_index: u32,
    n: u32,
    seed: u32,
    scratch: &mut Vec<[f32; 2]>,
    stats: &mut C,
) -> (f32, ShadowRayOutcome) {
    let mut outcome = ShadowRayOutcome::default();
    let Some(s) = surface else {
        return (1.0, outcome);
    };
    let plan = SamplePlan {
        light_index,
        samples: n,
        seed,
    };
    let mut lit = 0u32;
    let reached = plan.for_each_ray(s, pixel, light, scratch, |ray| match ray {
        None => outcome.back_facing += 1,
        Some(ray) => {
            outcome.rays += 1;
            if tracer.occluded(&ray, stats) {
                outcome.occluded += 1;
            } else {
                lit += 1;
            }
        }
    });
    if !reached {
        outcome.unreached = n as u64;
    }
    (lit as f32 / n as f32, outcome)
}
