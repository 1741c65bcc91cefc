//! Shadow rays: for each pixel with a surface, one ray per light sample, any hit.

use std::time::Instant;

use rayon::prelude::*;

use super::lights::LightFrom;
use super::primary::HeatWork;
use super::sample_lanes::SampleLanes;
use super::tiles::{band_pixels, band_tiles, tiles, Tile, TILE_PIXELS, TILE_SIDE};
use super::{LightSample, LightSampler, PrimaryPass, SurfacePoint};
use crate::cancel::CancelToken;
use crate::geometry::{offset_ray_origin, Ray};
use crate::image::ImagePlane;
use crate::sampling::{extend_stratified_2d, hash_combine, hash_u32};
use crate::trace::{AlphaQuery, AlphaScenes, Counters, NoStats, RayQuery, TraversalStats};
use crate::Result;
use glam::Vec3;

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
    /// Per-pixel work: empty when not counted, and when the pass added it into a frame's sums
    /// (the renderer's passes).
    pub work: Vec<TraversalStats>,
    /// The work of all of the pass's rays.
    pub totals: TraversalStats,
    pub outcome: ShadowRayOutcome,
    pub trace_ms: f64,
    /// Alpha evaluations of a pass counted in [`crate::trace::AlphaStats`] (else 0).
    pub alpha_lookups: u64,
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
    /// per tile ([`super::tiles`]), counting each pixel's work in `C` ([`TraversalStats`], or
    /// [`NoStats`] timed: `work` is then empty); stops with [`crate::Error::Cancelled`] once
    /// `cancel` is set (read once per tile).
    pub fn trace<C: Counters>(
        primary: &PrimaryPass,
        tracer: &impl RayQuery,
        light: &LightSampler,
        plan: SamplePlan,
        cancel: &CancelToken,
    ) -> Result<Self> {
        Self::kept::<C>(primary, |work| {
            Self::trace_tiles(
                primary,
                light,
                plan,
                cancel,
                work,
                put::<C>,
                occluded_step(tracer),
            )
        })
    }

    /// As [`ShadowPass::trace`] counted, each pixel's N_B, N_L and N_T added into `sums` (one
    /// per pixel) instead of kept: `work` is then empty. A frame's passes sum their lights so,
    /// without a per-pixel copy of every counter per light.
    pub(super) fn trace_adding<C: Counters>(
        primary: &PrimaryPass,
        tracer: &impl RayQuery,
        light: &LightSampler,
        plan: SamplePlan,
        cancel: &CancelToken,
        sums: &mut [HeatWork],
    ) -> Result<Self> {
        Self::trace_tiles(
            primary,
            light,
            plan,
            cancel,
            sums,
            add::<C>,
            occluded_step(tracer),
        )
    }

    /// As [`ShadowPass::trace`] through alpha-textured materials: each ray's transmission
    /// ([`AlphaQuery::transmission`], at most `max_hits` transparent hits) on the same tree and
    /// order, a pixel's mask the mean of its rays' transmissions (so 0/1 answers give the same
    /// bits as `trace`). Count in `C` = [`crate::trace::AlphaStats`] to get `alpha_lookups`.
    pub fn trace_alpha<C: Counters>(
        primary: &PrimaryPass,
        tracer: &impl AlphaQuery,
        alpha: &(impl AlphaScenes + ?Sized),
        max_hits: u32,
        light: &LightSampler,
        plan: SamplePlan,
        cancel: &CancelToken,
    ) -> Result<Self> {
        let step = transmitted_step(tracer, alpha, max_hits);
        Self::kept::<C>(primary, |work| {
            Self::trace_tiles(primary, light, plan, cancel, work, put::<C>, step)
        })
    }

    /// As [`ShadowPass::trace_alpha`] counted, each pixel's work added into `sums` as
    /// [`ShadowPass::trace_adding`] adds it.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn trace_alpha_adding<C: Counters>(
        primary: &PrimaryPass,
        tracer: &impl AlphaQuery,
        alpha: &(impl AlphaScenes + ?Sized),
        max_hits: u32,
        light: &LightSampler,
        plan: SamplePlan,
        cancel: &CancelToken,
        sums: &mut [HeatWork],
    ) -> Result<Self> {
        let step = transmitted_step(tracer, alpha, max_hits);
        Self::trace_tiles(primary, light, plan, cancel, sums, add::<C>, step)
    }

    /// A pass that keeps each pixel's work in `C` (nothing for [`NoStats`]), as `work` when
    /// counting.
    fn kept<C: Counters>(
        primary: &PrimaryPass,
        pass: impl FnOnce(&mut [C]) -> Result<Self>,
    ) -> Result<Self> {
        let mut work = vec![C::default(); primary.surfaces.len()];
        let mut pass = pass(&mut work)?;
        if C::COUNTING {
            pass.work = work.into_iter().map(Into::into).collect();
        }
        Ok(pass)
    }

    /// The tile loop of every pass: `step` traces a gathered tile's rays and writes its mask
    /// values (one monomorphised copy per pass, so the opaque pass is today's code); each
    /// traced pixel's work goes into its element of `work` (one per pixel) through `sink`.
    /// `totals` and `alpha_lookups` sum the traced pixels' work; `work` is left empty.
    fn trace_tiles<C: Counters, W: Send, F>(
        primary: &PrimaryPass,
        light: &LightSampler,
        plan: SamplePlan,
        cancel: &CancelToken,
        work: &mut [W],
        sink: fn(&mut W, C),
        step: F,
    ) -> Result<Self>
    where
        F: Fn(&mut TileRays<C>, &mut [f32]) -> ShadowRayOutcome + Sync,
    {
        assert_eq!(
            work.len(),
            primary.surfaces.len(),
            "one work sink per pixel"
        );
        let start = Instant::now();
        let mut mask = ImagePlane::new(light.name.clone(), primary.width, primary.height);
        let band = band_pixels(primary.width).max(1);
        let (outcome, totals, alpha_lookups) = primary
            .surfaces
            .par_chunks(band)
            .zip(mask.data.par_chunks_mut(band))
            .zip(work.par_chunks_mut(band))
            .enumerate()
            .map_init(
                TileRays::default,
                |buffers, (b, ((surfaces, mask), work))| {
                    let y0 = b as u32 * TILE_SIDE;
                    let mut outcome = ShadowRayOutcome::default();
                    let mut totals = TraversalStats::default();
                    let mut lookups = 0;
                    for tile in band_tiles(primary.width, primary.height, y0) {
                        if cancel.is_cancelled() {
                            break;
                        }
                        let band = Band {
                            surfaces,
                            first_pixel: b * band,
                            width: primary.width,
                        };
                        outcome += buffers.gather(&band, tile, light, plan);
                        outcome += step(buffers, mask);
                        if C::COUNTING {
                            buffers.pixel_work();
                            for (i, w) in buffers.points.iter().zip(&buffers.work) {
                                lookups += w.lookups();
                                totals += (*w).into();
                                sink(&mut work[*i as usize], *w);
                            }
                        }
                    }
                    (outcome, totals, lookups)
                },
            )
            .reduce(
                || (ShadowRayOutcome::default(), TraversalStats::default(), 0),
                |mut a, b| {
                    a.0 += b.0;
                    a.1 += b.1;
                    a.2 += b.2;
                    a
                },
            );
        cancel.check()?;
        let trace_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(ShadowPass {
            mask,
            work: Vec::new(),
            totals,
            outcome,
            trace_ms,
            alpha_lookups,
        })
    }
}

/// A pixel's counters kept as they are.
#[inline(always)]
fn put<C>(w: &mut C, c: C) {
    *w = c;
}

/// A pixel's counters added into its heat-map sums.
#[inline(always)]
fn add<C: Counters>(w: &mut HeatWork, c: C) {
    let c: TraversalStats = c.into();
    *w += &c;
}

/// The opaque passes' step: any hit per ray on `tracer`, then the tile's mask values.
fn occluded_step<C: Counters>(
    tracer: &impl RayQuery,
) -> impl Fn(&mut TileRays<C>, &mut [f32]) -> ShadowRayOutcome + Sync + '_ {
    move |buffers, mask| {
        tracer.occluded_batch(&buffers.rays, &mut buffers.occluded, &mut buffers.counters);
        buffers.write(mask)
    }
}

/// The alpha passes' step: each ray's transmission through `alpha`, then the tile's mask
/// values.
fn transmitted_step<'a, C: Counters>(
    tracer: &'a impl AlphaQuery,
    alpha: &'a (impl AlphaScenes + ?Sized),
    max_hits: u32,
) -> impl Fn(&mut TileRays<C>, &mut [f32]) -> ShadowRayOutcome + Sync + 'a {
    move |buffers, mask| {
        let n = buffers.rays.len();
        buffers.transmitted.clear();
        buffers.transmitted.resize(n, 0.0);
        tracer.transmission_batch(
            &buffers.rays,
            alpha,
            max_hits,
            &mut buffers.transmitted,
            &mut buffers.counters,
        );
        buffers.write_transmitted(mask)
    }
}

/// The primary hits of one band of rows ([`super::tiles`]).
struct Band<'a> {
    surfaces: &'a [Option<SurfacePoint>],
    /// The band's first pixel in the image.
    first_pixel: usize,
    width: u32,
}

/// One thread's buffers for a tile's shadow rays, reused from tile to tile.
#[derive(Default)]
struct TileRays<C> {
    rays: Vec<Ray>,
    occluded: Vec<bool>,
    /// Per ray, its transmission (the alpha pass's answers).
    transmitted: Vec<f32>,
    counters: Vec<C>,
    /// Per ray, its pixel in `points`.
    owners: Vec<u32>,
    /// The tile's pixels the light reaches: their index in the band.
    points: Vec<u32>,
    /// The shading points of `points` and their samples, made lane by lane.
    lanes: SampleLanes,
    /// Pixels whose value needs no ray: no surface (lit) or out of the light's reach (dark).
    settled: Vec<(u32, f32)>,
    /// Per pixel of `points`: its rays not occluded.
    lit: Vec<u32>,
    /// Per pixel of `points`: the sum of its rays' transmissions (the alpha pass).
    pixel_sums: Vec<f32>,
    /// Per pixel of `points`: its rays' work.
    work: Vec<C>,
    /// Samples per pixel of the gathered tile's light.
    spp: u32,
}

impl<C: Counters> TileRays<C> {
    /// The tile's rays in `rays`, sample by sample and, within a sample, in the tile's pixel
    /// order (so consecutive rays are neighbours, as packets want), made lane by lane
    /// ([`SampleLanes`]); the answer buffers sized. Returns the samples that need no ray.
    fn gather(
        &mut self,
        band: &Band,
        tile: Tile,
        light: &LightSampler,
        plan: SamplePlan,
    ) -> ShadowRayOutcome {
        let mut outcome = ShadowRayOutcome::default();
        self.spp = plan.samples;
        self.points.clear();
        self.lanes.clear();
        self.settled.clear();
        for i in tile.band_indices(band.width) {
            let Some(s) = &band.surfaces[i] else {
                self.settled.push((i as u32, 1.0));
                continue;
            };
            if !light.reaches(s.position) {
                outcome.unreached += plan.samples as u64;
                self.settled.push((i as u32, 0.0));
                continue;
            }
            self.points.push(i as u32);
            self.lanes.push(s, band.first_pixel + i);
        }
        outcome.back_facing += self
            .lanes
            .make_rays(light, plan, &mut self.rays, &mut self.owners);
        let n = self.rays.len();
        self.occluded.clear();
        self.occluded.resize(n, false);
        self.counters.clear();
        self.counters.resize(n, C::default());
        outcome
    }

    /// Per pixel of `points`, the sum of its rays' counters in `work` (in ray order).
    fn pixel_work(&mut self) {
        self.work.clear();
        self.work.resize(self.points.len(), C::default());
        for (&k, c) in self.owners.iter().zip(&self.counters) {
            self.work[k as usize] += *c;
        }
    }

    /// The traced tile's mask values written into its band; returns its rays and how many were
    /// occluded.
    fn write(&mut self, mask: &mut [f32]) -> ShadowRayOutcome {
        let pixels = self.points.len();
        self.lit.clear();
        self.lit.resize(pixels, 0);
        let mut occluded = 0;
        for (&k, &o) in self.owners.iter().zip(&self.occluded) {
            self.lit[k as usize] += u32::from(!o);
            occluded += u64::from(o);
        }
        let samples = self.spp as f32;
        for (i, &lit) in self.points.iter().zip(&self.lit) {
            mask[*i as usize] = lit as f32 / samples;
        }
        for &(i, value) in &self.settled {
            mask[i as usize] = value;
        }
        ShadowRayOutcome {
            rays: self.rays.len() as u64,
            occluded,
            ..ShadowRayOutcome::default()
        }
    }
}

impl<C: Counters> TileRays<C> {
    /// [`TileRays::write`] for transmissions: a pixel's value is the sum of its rays'
    /// transmissions in sample order over the samples; a ray counts as occluded when it lets
    /// less than all light through.
    fn write_transmitted(&mut self, mask: &mut [f32]) -> ShadowRayOutcome {
        let pixels = self.points.len();
        let mut sums = std::mem::take(&mut self.pixel_sums);
        sums.clear();
        sums.resize(pixels, 0.0);
        let mut occluded = 0;
        for (&k, &t) in self.owners.iter().zip(&self.transmitted) {
            sums[k as usize] += t;
            occluded += u64::from(t < 1.0);
        }
        let samples = self.spp as f32;
        for (i, &sum) in self.points.iter().zip(&sums) {
            mask[*i as usize] = sum / samples;
        }
        for &(i, value) in &self.settled {
            mask[i as usize] = value;
        }
        self.pixel_sums = sums;
        ShadowRayOutcome {
            rays: self.rays.len() as u64,
            occluded,
            ..ShadowRayOutcome::default()
        }
    }
}

/// One surface point's shadow rays to one light: the light as seen from the point and the ray
/// origins on either side of its plane, made once for all of the point's samples.
#[derive(Clone, Copy, Debug)]
pub struct PointRays<'l> {
    light: LightFrom<'l>,
    position: glam::Vec3,
    normal: glam::Vec3,
    facing: glam::Vec3,
    /// The offset origins on the normal's side and on the other.
    front: glam::Vec3,
    back: glam::Vec3,
}

impl<'l> PointRays<'l> {
    #[inline]
    pub fn new(surface: &SurfacePoint, light: &'l LightSampler) -> Self {
        let (front, back) = ray_origins(surface.position, surface.normal, surface.facing);
        PointRays {
            light: light.seen_from(surface.position),
            position: surface.position,
            normal: surface.normal,
            facing: surface.facing,
            front,
            back,
        }
    }

    /// The ray towards the light's sample for `u` in [0,1)^2, or `None` when the sample lies
    /// behind the surface's facing normal (its own plane, or its shading normal:
    /// [`super::Facing`]).
    #[inline]
    pub fn ray(&self, u: [f32; 2]) -> Option<Ray> {
        self.ray_to(self.light.sample(u))
    }

    /// The ray towards `sample`, a sample of this point's light ([`Self::ray`]).
    #[inline(always)]
    fn ray_to(&self, sample: LightSample) -> Option<Ray> {
        let towards = match sample {
            LightSample::Point(q) => q - self.position,
            LightSample::Direction(w) => w,
        };
        if self.facing.dot(towards) <= 0.0 {
            return None;
        }
        // A shading normal may let a sample behind the plane through: the ray leaves on that side.
        let origin = if self.normal.dot(towards) > 0.0 {
            self.front
        } else {
            self.back
        };
        Some(match sample {
            // t in (0, 1]: the segment ends on the light (lights are not geometry).
            LightSample::Point(q) => Ray::new(origin, q - origin, 0.0, 1.0),
            LightSample::Direction(w) => Ray::new(origin, w, 0.0, f32::INFINITY),
        })
    }
}

/// A surface point's shadow ray origins, offset off its plane on the normal's side and on the
/// other (`p`, its geometric normal `n`, its facing normal `facing`).
#[inline(always)]
pub(super) fn ray_origins(
    p: glam::Vec3,
    n: glam::Vec3,
    facing: glam::Vec3,
) -> (glam::Vec3, glam::Vec3) {
    // Only a shading normal lets a ray leave behind the plane: with the geometric one
    // (facing == normal) the back origin is never taken.
    let behind = offset_ray_origin(p, -n);
    let back = if facing == n { p } else { behind };
    (offset_ray_origin(p, n), back)
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
    /// The pixel's sample positions in [0,1)^2 appended to `out` (`samples` of them): the
    /// light's centre for one sample, else a stratified pattern seeded by seed, light and pixel.
    #[inline]
    pub fn extend_samples(&self, pixel: usize, out: &mut Vec<[f32; 2]>) {
        if self.samples == 1 {
            out.push([0.5, 0.5]);
        } else {
            let seed = hash_combine(hash_combine(self.seed, self.light_index), pixel as u32);
            extend_stratified_2d(self.samples, seed, out);
        }
    }

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
        scratch.clear();
        self.extend_samples(pixel, scratch);
        let point = PointRays::new(surface, light);
        for &u in scratch.iter() {
            f(point.ray(u));
        }
        true
    }
}

/// Every shadow ray of one light for a primary pass, in pixel order (for benchmarks and
/// oracles that must trace exactly the rays the shadow pass traces).
pub fn shadow_rays(primary: &PrimaryPass, light: &LightSampler, plan: SamplePlan) -> Vec<Ray> {
    rays_of_pixels(primary, light, plan, |_| true)
}

/// The shadow pass's batches of one light: each tile's rays in the order the pass hands them to
/// the tree ([`super::tiles`]), for benchmarks that must batch rays as the pass does.
pub fn shadow_ray_batches(
    primary: &PrimaryPass,
    light: &LightSampler,
    plan: SamplePlan,
) -> Vec<Vec<Ray>> {
    let band = band_pixels(primary.width).max(1);
    let mut buffers = TileRays::<NoStats>::default();
    tiles(primary.width, primary.height)
        .map(|tile| {
            let b = (tile.y0 / TILE_SIDE) as usize;
            let first_pixel = b * band;
            let end = (first_pixel + band).min(primary.surfaces.len());
            let band = Band {
                surfaces: &primary.surfaces[first_pixel..end],
                first_pixel,
                width: primary.width,
            };
            buffers.gather(&band, tile, light, plan);
            buffers.rays.clone()
        })
        .collect()
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
    rays_of_pixels(primary, light, plan, |pixel| {
        budget >= 1.0 || hash_u32(pixel as u32 ^ 0x9e37_79b9) < threshold
    })
}

/// Pixels scanned per parallel task when collecting rays in pixel order.
const SCAN_CHUNK: usize = 4096;

/// The shadow rays of the pixels with a surface that `keep` accepts, in pixel order (a
/// pixel's rays in sample order, as [`SamplePlan::for_each_ray`] gives them), the pixels
/// scanned in parallel and their rays made a tile's worth at a time ([`SampleLanes`]).
fn rays_of_pixels(
    primary: &PrimaryPass,
    light: &LightSampler,
    plan: SamplePlan,
    keep: impl Fn(usize) -> bool + Sync,
) -> Vec<Ray> {
    let chunks: Vec<Vec<Ray>> = primary
        .surfaces
        .par_chunks(SCAN_CHUNK)
        .enumerate()
        .map_init(PixelRays::default, |buffers, (c, surfaces)| {
            let mut rays = Vec::new();
            buffers.lanes.clear();
            for (j, s) in surfaces.iter().enumerate() {
                let pixel = c * SCAN_CHUNK + j;
                if let Some(s) = s
                    .as_ref()
                    .filter(|s| keep(pixel) && light.reaches(s.position))
                {
                    buffers.lanes.push(s, pixel);
                    if buffers.lanes.is_full() {
                        buffers.append(light, plan, &mut rays);
                    }
                }
            }
            buffers.append(light, plan, &mut rays);
            rays
        })
        .collect();
    chunks.concat()
}

/// One thread's buffers for [`rays_of_pixels`].
#[derive(Default)]
struct PixelRays {
    lanes: SampleLanes,
    made: Vec<Ray>,
    owners: Vec<u32>,
}

impl PixelRays {
    /// The held points' rays appended to `rays` point by point (each point's in sample
    /// order: a stable counting sort of the lanes' sample-major rays by point); the points
    /// cleared.
    fn append(&mut self, light: &LightSampler, plan: SamplePlan, rays: &mut Vec<Ray>) {
        let points = self.lanes.len();
        if points == 0 {
            return;
        }
        self.lanes
            .make_rays(light, plan, &mut self.made, &mut self.owners);
        // A tile's points at most: the counts live on the stack, not in an allocation per batch.
        let mut next = [0usize; TILE_PIXELS + 1];
        for &k in &self.owners {
            next[k as usize + 1] += 1;
        }
        for k in 0..points {
            next[k + 1] += next[k];
        }
        let start = rays.len();
        rays.resize(
            start + self.made.len(),
            Ray::new(Vec3::ZERO, Vec3::ZERO, 0.0, 0.0),
        );
        for (ray, &k) in self.made.iter().zip(&self.owners) {
            rays[start + next[k as usize]] = *ray;
            next[k as usize] += 1;
        }
        self.lanes.clear();
    }
}
