//! Shadow rays: for each pixel with a surface, one ray per light sample, any hit.

use std::time::Instant;

use rayon::prelude::*;

use super::primary::TILE;
use super::{LightSample, LightSampler, PrimaryPass, SurfacePoint};
use crate::cancel::CancelToken;
use crate::geometry::{offset_ray_origin, Ray};
use crate::image::ImagePlane;
use crate::sampling::hash_u32;
use crate::sampling::{hash_combine, stratified_2d};
#[cfg(doc)]
use crate::trace::NoStats;
use crate::trace::{Counters, RayQuery, TraversalStats};
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
    /// Traces `tracer` (the tree with this light's child order) tile by tile, one batch of rays
    /// per tile, counting each pixel's work in `C` ([`TraversalStats`], or [`NoStats`] timed:
    /// `work` is then empty); stops with [`crate::Error::Cancelled`] once `cancel` is set (read
    /// once per tile).
    pub fn trace<C: Counters>(
        primary: &PrimaryPass,
        tracer: &impl RayQuery,
        light: &LightSampler,
        plan: SamplePlan,
        cancel: &CancelToken,
    ) -> Result<Self> {
        let start = Instant::now();
        let mut mask = ImagePlane::new(light.name.clone(), primary.width, primary.height);
        let mut work = vec![C::default(); primary.surfaces.len()];
        let outcome = primary
            .surfaces
            .par_chunks(TILE)
            .zip(mask.data.par_chunks_mut(TILE))
            .zip(work.par_chunks_mut(TILE))
            .enumerate()
            .map_init(
                TileRays::default,
                |buffers, (tile, ((surfaces, mask), work))| {
                    if cancel.is_cancelled() {
                        return ShadowRayOutcome::default();
                    }
                    let first_pixel = tile * TILE;
                    buffers.trace(surfaces, first_pixel, tracer, light, plan, mask, work)
                },
            )
            .reduce(ShadowRayOutcome::default, |mut a, b| {
                a += b;
                a
            });
        cancel.check()?;
        let trace_ms = start.elapsed().as_secs_f64() * 1e3;
        let work: Vec<TraversalStats> = if C::COUNTING {
            work.into_iter().map(Into::into).collect()
        } else {
            Vec::new()
        };
        let mut totals = TraversalStats::default();
        for w in &work {
            totals += *w;
        }
        Ok(ShadowPass {
            mask,
            work,
            totals,
            outcome,
            trace_ms,
        })
    }
}

/// One thread's buffers for a tile's shadow rays, reused from tile to tile.
#[derive(Default)]
struct TileRays<C> {
    rays: Vec<Ray>,
    occluded: Vec<bool>,
    counters: Vec<C>,
    /// Per pixel of the tile: its rays' end in `rays`, its back-facing samples, and whether the
    /// light reaches it.
    pixels: Vec<(u32, u32, bool)>,
    samples: Vec<[f32; 2]>,
}

impl<C: Counters> TileRays<C> {
    /// A tile's rays traced in one batch; its mask values and per-pixel work written, its
    /// outcome returned.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn trace(
        &mut self,
        surfaces: &[Option<SurfacePoint>],
        first_pixel: usize,
        tracer: &impl RayQuery,
        light: &LightSampler,
        plan: SamplePlan,
        mask: &mut [f32],
        work: &mut [C],
    ) -> ShadowRayOutcome {
        self.rays.clear();
        self.pixels.clear();
        for (i, s) in surfaces.iter().enumerate() {
            let mut back_facing = 0;
            let reached = s.as_ref().is_none_or(|s| {
                let rays = &mut self.rays;
                plan.for_each_ray(s, first_pixel + i, light, &mut self.samples, |r| match r {
                    Some(r) => rays.push(r),
                    None => back_facing += 1,
                })
            });
            self.pixels
                .push((self.rays.len() as u32, back_facing, reached));
        }
        let n = self.rays.len();
        self.occluded.resize(n, false);
        self.counters.clear();
        self.counters.resize(n, C::default());
        tracer.occluded_batch(&self.rays, &mut self.occluded, &mut self.counters);
        let mut outcome = ShadowRayOutcome::default();
        let mut begin = 0;
        for (i, &(end, back_facing, reached)) in self.pixels.iter().enumerate() {
            let range = begin as usize..end as usize;
            begin = end;
            if surfaces[i].is_none() {
                mask[i] = 1.0;
                continue;
            }
            let occluded = self.occluded[range.clone()].iter().filter(|o| **o).count() as u32;
            let rays = end - range.start as u32;
            if C::COUNTING {
                let mut w = C::default();
                for c in &self.counters[range] {
                    w += *c;
                }
                work[i] = w;
            }
            outcome.rays += rays as u64;
            outcome.occluded += occluded as u64;
            outcome.back_facing += back_facing as u64;
            if !reached {
                outcome.unreached += plan.samples as u64;
            }
            mask[i] = (rays - occluded) as f32 / plan.samples as f32;
        }
        outcome
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
