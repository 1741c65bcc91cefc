//! The ray queries give the renderer's answers on the renderer's own rays: a built-in scene,
//! flattened into one world-space mesh (the triangles a caller would hand in), is rendered with
//! core's `Renderer`; its camera rays and every light's shadow rays, moved back to world space,
//! are traced through the public API; the closest-hit triangle of every pixel and every shadow
//! mask (the share of each pixel's shadow rays that got through) are equal bit for bit.

use std::sync::Arc;

use antumbra_core::cancel::CancelToken;
use antumbra_core::geometry::Ray as RenderRay;
use antumbra_core::render::{
    samples_for, visibility_flags, LightSampler, PrimaryPass, PrimaryRays, RenderSettings,
    Renderer, SamplePlan,
};
use antumbra_core::scene::{Mesh, Object, RenderSpace, Resolution, Scene as CoreScene};
use antumbra_core::trace::TraversalStats;
use antumbra_rays::{BuildMethod, BuildOptions, BvhWidth, Ray, Scene, ShadowOrder, TraceOptions};
use antumbra_scenes::SceneParams;
use glam::{DMat4, DVec3};

/// A frame of a built-in scene as one mesh in world space, and its f32 vertices.
fn flattened(name: &str, frame: i32) -> (CoreScene, Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let params = SceneParams {
        triangles: 20_000,
        frames: 4,
        rotated: false,
        instances: None,
    };
    let mut scene = antumbra_scenes::builtin(name, &params)
        .unwrap()
        .frame(frame);
    scene.resolution = Resolution::new(96, 64);
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    for object in scene
        .objects
        .iter()
        .filter(|o| o.visible_to_camera && o.casts_shadow)
    {
        let mesh = &scene.meshes[object.mesh];
        let first = vertices.len() as u32;
        vertices.extend(mesh.positions.iter().map(|p| {
            let w = object.world_from_object.transform_point3(p.as_dvec3());
            w.as_vec3()
        }));
        triangles.extend(mesh.triangles.iter().map(|t| t.map(|i| i + first)));
    }
    let mesh = Mesh::new("world", vertices.clone(), triangles.clone());
    scene.meshes = vec![Arc::new(mesh)];
    scene.objects = vec![Object::new("world", 0, DMat4::IDENTITY)];
    let caller = vertices.iter().map(|v| v.to_array()).collect();
    (scene, caller, triangles)
}

/// A render-space ray in world space; the public API must move it back to exactly this ray.
fn world_ray(space: &RenderSpace, r: &RenderRay) -> Ray {
    let back = |v: glam::Vec3| v.as_dvec3() / space.scale;
    let origin = back(r.origin) + space.origin;
    Ray::segment(
        origin.to_array(),
        back(r.direction).to_array(),
        r.t_min,
        r.t_max,
    )
}

/// Asserts that every world ray moves back to its render ray bit for bit (else the comparison
/// would test the round trip, not the queries).
fn assert_round_trip(space: &RenderSpace, render: &[RenderRay], world: &[Ray]) {
    for (r, w) in render.iter().zip(world) {
        let o = space.point(DVec3::from(w.origin)).as_vec3();
        let d = space.vector(DVec3::from(w.direction)).as_vec3();
        assert_eq!((o, d), (r.origin, r.direction), "{w:?}");
    }
}

/// Frame 3 rendered after frame 2 (so visibility-driven builds read frame 2's visible set),
/// and the same tree built through the public API over the same triangles and visible set.
fn check(name: &str, method: BuildMethod, width: BvhWidth, order: &str) {
    let (scene, vertices, triangles) = flattened(name, 3);
    let shadow_order: ShadowOrder = order.parse().unwrap();
    let settings = RenderSettings {
        build: method.into(),
        width,
        shadow_order: shadow_order.into(),
        ..RenderSettings::baseline()
    };
    let mut renderer = Renderer::new();
    renderer
        .render(name, &flattened(name, 2).0, &settings)
        .unwrap();
    let frame = renderer.render(name, &scene, &settings).unwrap();
    let (geometry, camera_bvh, _) = renderer.current().unwrap();
    let space = geometry.space;

    // The renderer's visible set as the caller's per-triangle flags (one object: a triangle's
    // ref names its caller index).
    let visible = renderer.trees().unwrap().visible_input().map(|v| {
        let mut flags = vec![false; triangles.len()];
        for (r, seen) in geometry
            .camera
            .refs
            .iter()
            .zip(visibility_flags(&geometry.camera, v))
        {
            flags[r.primitive as usize] = seen;
        }
        flags
    });
    assert_eq!(
        visible.is_some(),
        method.uses_visibility(),
        "{name} {}: a visible set where the method reads one",
        method.name()
    );
    if let Some(v) = &visible {
        let seen = v.iter().filter(|s| **s).count();
        assert!(
            seen > 0 && seen < v.len(),
            "{name}: {seen} of {} triangles visible",
            v.len()
        );
    }
    let options = BuildOptions {
        method,
        width,
        settings: settings.build_settings,
        collapse: settings.collapse,
        visible,
        ..BuildOptions::default()
    };
    let public = Scene::build(&vertices, &triangles, &options).unwrap();
    assert_eq!(
        public.space(),
        space,
        "the same normalisation as FrameGeometry"
    );
    let trace = TraceOptions {
        order: shadow_order,
        ..TraceOptions::default()
    };
    let what = format!("{name} {} width {width} {order}", method.name());

    // Camera rays: the closest triangle of every pixel, in the caller's indices.
    let camera = PrimaryRays::new(&scene.camera, &scene.resolution, &space);
    let render_rays: Vec<RenderRay> = (0..camera.height)
        .flat_map(|y| (0..camera.width).map(move |x| (x, y)))
        .map(|(x, y)| camera.ray(x, y))
        .collect();
    let rays: Vec<Ray> = render_rays.iter().map(|r| world_ray(&space, r)).collect();
    assert_round_trip(&space, &render_rays, &rays);
    let hits = public.intersect(&rays, &trace).unwrap();
    let expected: Vec<u32> = frame
        .primary_hits
        .iter()
        .map(|r| r.primitive) // u32::MAX where the ray missed
        .collect();
    let got: Vec<u32> = hits
        .iter()
        .map(|h| h.map_or(u32::MAX, |h| h.triangle))
        .collect();
    assert_eq!(got, expected, "{what}: primary hits");
    let hit_pixels = got.iter().filter(|&&id| id != u32::MAX).count();
    assert!(
        hit_pixels > got.len() / 2,
        "{what}: {hit_pixels} pixels hit"
    );

    // Shadow rays of every shadow-casting light: each pixel's mask from the public answers.
    let never = CancelToken::new();
    let primary =
        PrimaryPass::trace::<TraversalStats>(&camera, camera_bvh, &geometry.camera, &never)
            .unwrap();
    let lights: Vec<_> = scene
        .lights
        .iter()
        .enumerate()
        .filter(|(_, l)| l.casts_shadow)
        .collect();
    assert_eq!(lights.len(), frame.masks.len());
    let mut occluded_somewhere = 0;
    for ((index, light), mask) in lights.into_iter().zip(&frame.masks) {
        let sampler = LightSampler::new(light, &space);
        let plan = SamplePlan {
            light_index: index as u32,
            samples: samples_for(&sampler, settings.spp),
            seed: settings.seed,
        };
        // Per pixel: its rays' range in the batch, or None where the light cannot reach it.
        let mut batch: Vec<RenderRay> = Vec::new();
        let mut pixels = Vec::new();
        let mut scratch = Vec::new();
        for (pixel, surface) in primary.surfaces.iter().enumerate() {
            let Some(s) = surface else {
                pixels.push(None);
                continue;
            };
            let start = batch.len();
            let reached = plan.for_each_ray(s, pixel, &sampler, &mut scratch, |r| batch.extend(r));
            pixels.push(reached.then_some(start..batch.len()));
        }
        let world: Vec<Ray> = batch.iter().map(|r| world_ray(&space, r)).collect();
        assert_round_trip(&space, &batch, &world);
        let blocked = public.occluded(&world, &trace).unwrap();
        occluded_somewhere += blocked.iter().filter(|&&b| b).count();
        let masks: Vec<f32> = primary
            .surfaces
            .iter()
            .zip(&pixels)
            .map(|(surface, range)| match (surface, range) {
                (None, _) => 1.0,
                (Some(_), None) => 0.0,
                (Some(_), Some(range)) => {
                    let lit = blocked[range.clone()].iter().filter(|&&b| !b).count();
                    lit as f32 / plan.samples as f32
                }
            })
            .collect();
        assert_eq!(masks, mask.data, "{what}: light {}", light.name);
    }
    assert!(occluded_somewhere > 0, "{what}: no shadow ray was blocked");
}

#[test]
fn binary_tree_front_to_back_as_rendered() {
    check("bedroom", BuildMethod::Sah, BvhWidth::Two, "fbto");
}

#[test]
fn wide_trees_and_prepared_orders_as_rendered() {
    check("city", BuildMethod::Sah, BvhWidth::Four, "sato");
    check(
        "indoors",
        BuildMethod::Sbvh,
        BvhWidth::Eight,
        "sorted:budget=0.1",
    );
    check("colonnade", BuildMethod::Sah, BvhWidth::Two, "rtsah");
}

#[test]
fn visibility_driven_builds_as_rendered() {
    check("bedroom", BuildMethod::Abvh, BvhWidth::Eight, "fbto");
    check("indoors", BuildMethod::Osah, BvhWidth::Two, "fbto");
    check("city", BuildMethod::Abvh, BvhWidth::Four, "sorted");
}
