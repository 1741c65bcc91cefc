//! The shadow-casting lights of a frame with the sampling plan of each, as the renderer draws
//! their rays: what `bench` and the example programs trace.

use antumbra_core::render::{samples_for, LightSampler, SamplePlan};
use antumbra_core::scene::{RenderSpace, Scene};

/// One shadow-casting light: its sampler and the plan of its rays.
pub struct ShadowLight {
    pub sampler: LightSampler,
    pub plan: SamplePlan,
}

/// The scene's shadow-casting lights, in order, with `spp` samples per pixel for soft lights.
pub fn shadow_lights(scene: &Scene, space: &RenderSpace, spp: u32, seed: u32) -> Vec<ShadowLight> {
    scene
        .lights
        .iter()
        .enumerate()
        .filter(|(_, l)| l.casts_shadow)
        .map(|(i, light)| {
            let sampler = LightSampler::new(light, space);
            let plan = SamplePlan {
                light_index: i as u32,
                samples: samples_for(&sampler, spp),
                seed,
            };
            ShadowLight { sampler, plan }
        })
        .collect()
}
