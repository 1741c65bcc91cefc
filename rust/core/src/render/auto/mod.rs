//! `auto` as a build and as an order: per frame the camera tree's build and per light the
//! shadow order, chosen from work counted on earlier frames of the same Renderer.

mod cost;
mod history;
mod policy;
mod structure;

pub use cost::{Traversal, Weights, WEIGHTS};
pub use history::{BuildChoice, History, Measured, OrderChoice};
pub use policy::{
    build_candidates, build_ns, choose_build, choose_order, order_candidates, order_estimate,
    prep_ns, BuildContext, Choice, LightContext, Moment, OrderPlan, EXPLORE_ONE_IN, MIN_PREP_RAYS,
    SAMPLE_SHARE, STALE_FRAMES,
};
pub use structure::{
    choose_structure, StructureContext, ENTER_TRIANGLES_PER_RAY, LEAVE_TRIANGLES_PER_RAY,
};

use super::shadow::{samples_for, SamplePlan};
use super::{LightSampler, PrimaryPass};
use crate::order::{RaySetSource, SortSettings, SrdhSettings};
use crate::sampling::hash_combine;
use crate::stats::StatsRow;
use crate::trace::{RayQuery, TraversalStats};

/// A light's shadow rays this frame, before tracing: its samples at every surface it reaches
/// (back-facing samples, which trace no ray, are not told apart).
pub fn light_rays(primary: &PrimaryPass, light: &LightSampler, spp: u32) -> u64 {
    let reached = primary
        .surfaces
        .iter()
        .flatten()
        .filter(|s| light.reaches(s.position))
        .count() as u64;
    reached * samples_for(light, spp) as u64
}

/// The rays a frame traces, from its primary pass: a ray per pixel, and every shadow-casting
/// light's samples at the surfaces it reaches ([`light_rays`]).
pub fn frame_rays(
    scene: &crate::scene::Scene,
    space: &crate::scene::RenderSpace,
    primary: &PrimaryPass,
    spp: u32,
) -> u64 {
    let camera = primary.width as u64 * primary.height as u64;
    let lights = scene.lights.iter().filter(|l| l.casts_shadow);
    camera
        + lights
            .map(|l| light_rays(primary, &LightSampler::new(l, space), spp))
            .sum::<u64>()
}

/// Representative rays of a light's sorting and SRDH build at their default options, from the
/// light's rays this frame and the frame's pixels with a surface.
pub fn prep_rays(rays: u64, surfaces: u64, samples: u64) -> (u64, u64) {
    let log = (rays as f64 * SortSettings::default().budget as f64).ceil() as u64;
    let srdh = match SrdhSettings::default().rays {
        RaySetSource::Prepass { width, height } => (width as u64 * height as u64).min(surfaces),
        RaySetSource::Budget(f) => (surfaces as f64 * f as f64).ceil() as u64,
        RaySetSource::All => surfaces,
    };
    (log, srdh * samples)
}

/// What a counted frame teaches: the measured cost per ray of the work `totals` of `rays` rays
/// on `kernel`.
pub fn measured(
    kernel: Traversal,
    totals: &TraversalStats,
    rays: u64,
    frame: u64,
    built: bool,
) -> Option<Measured> {
    (rays > 0).then(|| Measured {
        per_ray_ns: WEIGHTS.per_ray_ns(kernel, totals, rays),
        frame,
        built,
    })
}

/// Writes a choice into its statistics row: `auto_choice` and `auto_estimate_ms`.
pub fn mark_row<T>(row: &mut StatsRow, choice: &Choice<T>, name: impl Fn(&T) -> &'static str) {
    row.auto_choice = choice.label(name);
    row.auto_estimate_ms = choice.estimate_ns * 1e-6;
}

/// Triangles a frame's builds read: every object's mesh that the camera sees or that casts
/// shadows (read before the frame's geometry is made).
pub fn scene_triangles(scene: &crate::scene::Scene) -> u64 {
    scene
        .objects
        .iter()
        .filter(|o| o.visible_to_camera || o.casts_shadow)
        .filter_map(|o| scene.meshes.get(o.mesh))
        .map(|m| m.triangles.len() as u64)
        .sum()
}

/// The work of a light's rays from a [`SAMPLE_SHARE`] of its pixels traced by `tracer`, and
/// how many rays that was. The pixels are a seeded hash's, apart from the representative rays
/// sorting learns from, so a sorted order is not measured on the rays it was sorted by.
pub fn sample_work(
    primary: &PrimaryPass,
    light: &LightSampler,
    plan: SamplePlan,
    tracer: &impl RayQuery,
) -> (TraversalStats, u64) {
    let threshold = (SAMPLE_SHARE as f64 * u32::MAX as f64) as u32;
    let salt = hash_combine(plan.seed ^ 0x5a5a_5a5a, plan.light_index);
    let mut work = TraversalStats::default();
    let mut rays = 0;
    let mut scratch = Vec::new();
    for (pixel, s) in primary.surfaces.iter().enumerate() {
        let Some(s) = s else { continue };
        if hash_combine(salt, pixel as u32) >= threshold {
            continue;
        }
        plan.for_each_ray(s, pixel, light, &mut scratch, |r| {
            if let Some(r) = r {
                rays += 1;
                tracer.occluded(&r, &mut work);
            }
        });
    }
    (work, rays)
}
