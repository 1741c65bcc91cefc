//! The passes trace 8x8 tiles in their own pixel and sample order, yet write row-major images
//! equal, bit for bit, to a pixel-by-pixel reference: brute-force surfaces, brute-force shadow
//! masks and the work of each pixel's rays traced one at a time, on an image whose sides are not
//! multiples of the tile.

mod common;

use antumbra_core::build::{build_binned_sah, BuildSettings};
use antumbra_core::cancel::CancelToken;
use antumbra_core::render::{
    samples_for, shadow_ray_batches, shadow_rays, LightSampler, PrimaryPass, PrimaryRays,
    SamplePlan, ShadowPass,
};
use antumbra_core::scene::{FrameGeometry, LightKind, Scene};
use antumbra_core::trace::{brute_closest_hit, brute_occluded, RayQuery, TraversalStats};
use glam::DVec3;

/// The boxes scene at 37x27 with soft lights and a spot whose cone leaves pixels unreached.
fn scene() -> Scene {
    let mut scene = common::boxes_scene(37);
    scene.lights[0].kind = LightKind::Sun { angle: 0.1 };
    scene.lights[1].kind = LightKind::Point { radius: 0.4 };
    let mut spot = scene.lights[1].clone();
    spot.name = "Spot".into();
    spot.world_from_light =
        glam::DMat4::look_at_rh(DVec3::new(1.0, -1.0, 6.0), DVec3::ZERO, DVec3::Z).inverse();
    spot.kind = LightKind::Spot {
        radius: 0.2,
        spot_size: 0.6,
        spot_blend: 0.0,
    };
    scene.lights.push(spot);
    scene
}

#[test]
fn tiled_passes_equal_a_pixel_by_pixel_reference() {
    let scene = scene();
    let geometry = FrameGeometry::from_scene(&scene).unwrap();
    let triangles = &geometry.camera;
    let bvh = build_binned_sah(&triangles.vertices, &BuildSettings::default());
    let rays = PrimaryRays::new(&scene.camera, &scene.resolution, &geometry.space);
    let never = CancelToken::new();
    let primary = PrimaryPass::trace::<TraversalStats>(&rays, &bvh, triangles, &never).unwrap();
    let (w, h) = (rays.width, rays.height);
    assert_eq!((w % 8 != 0, h % 8 != 0), (true, true), "edges cut tiles");

    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let ray = rays.ray(x, y);
            let hit = brute_closest_hit(&triangles.vertices, &ray);
            assert_eq!(
                primary.surfaces[i].map(|s| s.triangle),
                hit.map(|h| h.triangle)
            );
            let mut work = TraversalStats::default();
            bvh.closest_hit(&ray, &mut work);
            assert_eq!(primary.work[i], work, "pixel ({x}, {y})");
        }
    }

    let shadow_set = geometry.shadow_set();
    let shadow_bvh = build_binned_sah(&shadow_set.vertices, &BuildSettings::default());
    let mut unreached = 0;
    for (index, light) in scene.lights.iter().enumerate() {
        let sampler = LightSampler::new(light, &geometry.space);
        let plan = SamplePlan {
            light_index: index as u32,
            samples: samples_for(&sampler, 4),
            seed: 7,
        };
        let pass =
            ShadowPass::trace::<TraversalStats>(&primary, &shadow_bvh, &sampler, plan, &never)
                .unwrap();
        let mut scratch = Vec::new();
        // Every ray one pixel after another, each pixel's in sample order.
        let mut in_pixel_order = Vec::new();
        for (pixel, s) in primary.surfaces.iter().enumerate() {
            let (mut lit, mut work) = (0, TraversalStats::default());
            let reached = s.as_ref().is_none_or(|s| {
                plan.for_each_ray(s, pixel, &sampler, &mut scratch, |r| {
                    if let Some(r) = r {
                        in_pixel_order.push(format!("{r:?}"));
                        lit += u32::from(!brute_occluded(&shadow_set.vertices, &r));
                        shadow_bvh.occluded(&r, &mut work);
                    }
                })
            });
            unreached += u32::from(!reached);
            let expected = if s.is_none() {
                1.0
            } else {
                lit as f32 / plan.samples as f32
            };
            assert_eq!(
                pass.mask.data[pixel], expected,
                "{} pixel {pixel}",
                light.name
            );
            assert_eq!(pass.work[pixel], work, "{} pixel {pixel}", light.name);
        }
        // The benchmarks' batches hold exactly the pass's rays.
        let mut batched: Vec<_> = shadow_ray_batches(&primary, &sampler, plan)
            .concat()
            .iter()
            .map(|r| format!("{r:?}"))
            .collect();
        let mut all: Vec<_> = shadow_rays(&primary, &sampler, plan)
            .iter()
            .map(|r| format!("{r:?}"))
            .collect();
        // The scan for representative rays makes them a tile at a time, yet hands them over
        // in pixel order, the rays of one point by one.
        assert_eq!(all, in_pixel_order, "{}", light.name);
        batched.sort();
        all.sort();
        assert_eq!(batched, all, "{}", light.name);
        assert_eq!(batched.len() as u64, pass.outcome.rays);
    }
    assert!(unreached > 0, "the spot leaves some pixels unreached");
}
