//! One light's SRDH tree in a frame: its representative rays (a low-resolution grid of the
//! frame's pixels, a hashed share, or all), their hit lists through the shadow BVH, and the
//! build, made only when enough of those rays are occluded for the tree to pay.

use std::time::Instant;

use glam::Vec3;

use super::shadow::{representative_rays, shadow_rays, SamplePlan};
use super::{LightSampler, PrimaryPass};
use crate::build::BuildSettings;
use crate::bvh::Bvh;
use crate::geometry::Ray;
use crate::order::{RaySetSource, SrdhSettings};
use crate::srdh::{build_srdh, RaySet, SrdhBvh};

/// What one light's SRDH preparation made.
pub struct LightSrdh {
    /// `None`: too few occluded representative rays; the light traces the SAH tree.
    pub tree: Option<SrdhBvh>,
    /// Ray selection, hit lists and build, milliseconds.
    pub ms: f64,
    pub rays: usize,
    pub occluded_fraction: f64,
}

/// The light's representative rays for `source`.
pub fn srdh_rays(
    primary: &PrimaryPass,
    light: &LightSampler,
    plan: SamplePlan,
    source: RaySetSource,
) -> Vec<Ray> {
    match source {
        RaySetSource::All => shadow_rays(primary, light, plan),
        RaySetSource::Budget(f) => representative_rays(primary, light, plan, f),
        RaySetSource::Prepass { width, height } => grid_rays(primary, light, plan, width, height),
    }
}

/// The rays of the pixels nearest the centres of a `gw` x `gh` grid over the frame: what a
/// `gw` x `gh` prepass would trace, taken from the frame's own primary hits.
fn grid_rays(
    primary: &PrimaryPass,
    light: &LightSampler,
    plan: SamplePlan,
    gw: u32,
    gh: u32,
) -> Vec<Ray> {
    let (w, h) = (primary.width as u64, primary.height as u64);
    let mut rays = Vec::new();
    let mut scratch = Vec::new();
    let mut last = usize::MAX;
    for gy in 0..gh as u64 {
        for gx in 0..gw as u64 {
            let x = ((2 * gx + 1) * w / (2 * gw as u64)).min(w.saturating_sub(1));
            let y = ((2 * gy + 1) * h / (2 * gh as u64)).min(h.saturating_sub(1));
            let pixel = (y * w + x) as usize;
            // A grid finer than the frame repeats pixels; take each once.
            if pixel == last {
                continue;
            }
            last = pixel;
            if let Some(Some(s)) = primary.surfaces.get(pixel) {
                plan.for_each_ray(s, pixel, light, &mut scratch, |r| rays.extend(r));
            }
        }
    }
    rays
}

/// Selects the light's rays, traces their hit lists through `shadow_bvh` (built over
/// `triangles`) and builds the light's SRDH tree if at least `min_occluded` of them are occluded.
#[allow(clippy::too_many_arguments)]
pub fn srdh_for_light(
    primary: &PrimaryPass,
    light: &LightSampler,
    plan: SamplePlan,
    settings: &SrdhSettings,
    shadow_bvh: &Bvh,
    triangles: &[[Vec3; 3]],
    sah: &BuildSettings,
) -> LightSrdh {
    let start = Instant::now();
    let rays = srdh_rays(primary, light, plan, settings.rays);
    let set = RaySet::trace(shadow_bvh, rays);
    let occluded_fraction = set.occluded_fraction();
    let tree = (!set.is_empty() && occluded_fraction >= settings.min_occluded as f64)
        .then(|| build_srdh(triangles, &set, settings, sah));
    LightSrdh {
        tree,
        ms: start.elapsed().as_secs_f64() * 1e3,
        rays: set.len(),
        occluded_fraction,
    }
}
