//! The brute-force reference of a frame through alpha (shared with antumbra-scenes' leaf-cards
//! test by `#[path]`): camera rays by `brute_closest_hit_alpha`, each light's mask as the mean
//! of `brute_transmission` over the pixel's shadow rays in sample order, on the trees' own
//! triangle sets.
#![allow(dead_code)]

use antumbra_core::alpha::AlphaScene;
use antumbra_core::cancel::CancelToken;
use antumbra_core::geometry::Ray;
use antumbra_core::render::{
    alpha_scene, samples_for, FrameResult, LightSampler, PrimaryPass, PrimaryRays, RenderSettings,
    Renderer, SamplePlan,
};
use antumbra_core::scene::{Scene, TriangleRef};
use antumbra_core::trace::{
    brute_closest_hit_alpha, brute_transmission, Counters, Hit, NoStats, RayQuery,
};
use glam::Vec3;

/// Camera rays by brute force past clipped hits.
struct BruteCamera<'a> {
    triangles: &'a [[Vec3; 3]],
    alpha: &'a AlphaScene,
    clip: f32,
}

impl RayQuery for BruteCamera<'_> {
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        self.closest_hit(ray, stats).is_some()
    }
    fn closest_hit<C: Counters>(&self, ray: &Ray, _: &mut C) -> Option<Hit> {
        brute_closest_hit_alpha(self.triangles, ray, self.alpha, self.clip)
    }
}

/// What the reference gives for a frame.
pub struct Reference {
    pub primary_hits: Vec<TriangleRef>,
    /// One per shadow-casting light, in the frame's order.
    pub masks: Vec<Vec<f32>>,
}

/// The reference for `scene` under `settings`, on the flat geometry `renderer` last rendered.
pub fn reference(scene: &Scene, settings: &RenderSettings, renderer: &Renderer) -> Reference {
    let (geometry, _, _) = renderer.current().expect("a flat frame");
    let camera_alpha = alpha_scene(scene, &geometry.camera).unwrap();
    let shadow_alpha = alpha_scene(scene, geometry.shadow_set()).unwrap();
    let rays = PrimaryRays::new(&scene.camera, &scene.resolution, &geometry.space);
    let brute = BruteCamera {
        triangles: &geometry.camera.vertices,
        alpha: &camera_alpha,
        clip: settings.alpha_clip,
    };
    let primary =
        PrimaryPass::trace::<NoStats>(&rays, &brute, &geometry.camera, &CancelToken::new())
            .unwrap();
    let primary_hits = primary
        .surfaces
        .iter()
        .map(|s| s.map_or(TriangleRef::MISS, |s| s.reference))
        .collect();
    let triangles = &geometry.shadow_set().vertices;
    let max_hits = settings.shadow_max_hits();
    let mut masks = Vec::new();
    for (index, light) in scene
        .lights
        .iter()
        .enumerate()
        .filter(|(_, l)| l.casts_shadow)
    {
        let sampler = LightSampler::new(light, &geometry.space);
        let plan = SamplePlan {
            light_index: index as u32,
            samples: samples_for(&sampler, settings.spp),
            seed: settings.seed,
        };
        let mut scratch = Vec::new();
        let mask = (primary.surfaces.iter().enumerate())
            .map(|(pixel, s)| {
                let Some(s) = s else { return 1.0 };
                let mut sum = 0.0f32;
                let reached = plan.for_each_ray(s, pixel, &sampler, &mut scratch, |r| {
                    if let Some(r) = r {
                        sum += brute_transmission(triangles, &r, &shadow_alpha, max_hits);
                    }
                });
                if reached {
                    sum / plan.samples as f32
                } else {
                    0.0
                }
            })
            .collect();
        masks.push(mask);
    }
    Reference {
        primary_hits,
        masks,
    }
}

/// Checks a rendered frame's camera hits and masks against `reference` bit for bit.
pub fn compare(result: &FrameResult, reference: &Reference, label: &str) {
    assert!(
        result.primary_hits == reference.primary_hits,
        "{label}: camera hits differ from brute_closest_hit_alpha"
    );
    assert_eq!(result.masks.len(), reference.masks.len(), "{label}");
    for (m, r) in result.masks.iter().zip(&reference.masks) {
        if let Some(first) = (m.data.iter().zip(r)).position(|(a, b)| a.to_bits() != b.to_bits()) {
            panic!(
                "{label}: light '{}' pixel {first}: {} rendered, {} brute force",
                m.name, m.data[first], r[first]
            );
        }
    }
}

/// Renders `scene` with a fresh renderer; returns the frame and the renderer.
pub fn render(scene: &Scene, settings: &RenderSettings, label: &str) -> (FrameResult, Renderer) {
    let mut renderer = Renderer::new();
    let result = renderer
        .render("alpha", scene, settings)
        .unwrap_or_else(|e| panic!("{label}: {e}"));
    (result, renderer)
}
