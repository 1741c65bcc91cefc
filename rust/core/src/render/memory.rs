//! A frame's peak memory, estimated from its sizes alone before any work: image planes and
//! per-pixel buffers (the visibility prepass's too), triangle sets and trees, one light's
//! preparation. Callers check it against a budget so that a request too big for the machine is
//! refused instead of aborting the process.

use std::fmt;
use std::mem::size_of;

use super::policy::auto_structure;
use super::{
    Pick, RenderSettings, SceneStructure, ShadowRayOutcome, StatsMode, SurfacePoint,
    VisibilitySource,
};
use crate::build::BuildMethod;
use crate::bvh::BvhWidth;
use crate::geometry::Ray;
use crate::order::{RaySetSource, ShadowOrder};
use crate::scene::{Scene, TriangleRef};
use crate::trace::TraversalStats;

/// Peak bytes of one tree build per triangle reference: primitive references, partition
/// scratch, nodes, the leaf triangle list and the meshes' own arrays (calibrated against peak
/// RSS, measured 282 bytes per world triangle with the set; see `docs/daemon.md`).
const BUILD_BYTES_PER_REF: u64 = 224;
/// Of those, what the finished tree keeps until the next frame's replaces it (nodes, the leaf
/// triangle list); the rest is the build's scratch. Calibrated on comparisons of 200 methods
/// over three frames, each method holding two frames' trees: about 90 bytes per reference
/// measured beside the triangle set (see `docs/daemon.md`).
const TREE_BYTES_PER_REF: u64 = 128;
/// A collapsed wide tree, its triangle rows and per-light sorting tables, per reference.
const WIDE_BYTES_PER_REF: u64 = 128;
/// An instance of a two-level frame as its top level keeps it: the instance (56 bytes), its
/// share of the top level's nodes and leaf-order ids.
const INSTANCE_BYTES: u64 = 128;
/// An instance while its top level is built: its box and reference, the placed list.
const INSTANCE_BUILD_BYTES: u64 = 160;
/// The process itself: code, thread stacks, allocator caches.
const PROCESS_BYTES: u64 = 32 << 20;
/// A flagged triangle's alpha (`AlphaTriangles`): its material, three corner UVs of one set, and
/// its share of the flag bits and ranks.
const ALPHA_BYTES_PER_TRIANGLE: u64 = 4 + 24 + 1;
/// A representative ray of a light's preparation (SRDH, sorting): the ray, its hit list and
/// the logged nodes, beyond `size_of::<Ray>()`.
const PREP_BYTES_PER_RAY: u64 = 64;
/// A float plane: one f32 per pixel.
const PLANE: u64 = 4;
/// Heat-map planes: N_B, N_L, N_T of primary and of shadow rays.
const HEAT_PLANES: u64 = 6;

/// What a frame is estimated to need at its peak, in bytes, and the sizes it follows from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderMemory {
    pub width: u64,
    pub height: u64,
    /// Lights that cast shadows: one mask and one shadow pass each.
    pub lights: u64,
    /// Triangles in the frame's camera and shadow sets (every object times its mesh).
    pub world_triangles: u64,
    /// Triangles the trees hold: the world triangles of a flat frame, the unique meshes'
    /// triangles of a two-level one.
    pub held_triangles: u64,
    /// Objects placed as instances of mesh trees (two-level frames; 0 for flat ones).
    pub instances: u64,
    /// Planes the caller copies out after the render (a reply, image files).
    pub output_planes: u64,
    /// The planes of the result, the planes copied out and the process itself: what a render
    /// holds until its caller is done with it.
    pub image_bytes: u64,
    /// Per-pixel buffers of the passes and of the visibility prepass (at its own size), alive
    /// one pass at a time.
    pub pass_bytes: u64,
    /// Triangle sets and trees, as a renderer keeps them across frames.
    pub geometry_bytes: u64,
    /// What building them needs beside (scratch, a set's second copy while it is joined, the
    /// visibility prepass's own tree), freed once they are built.
    pub build_bytes: u64,
    /// One light's preparation (its representative rays, SRDH tree or sorting), freed per light.
    pub light_bytes: u64,
}

impl RenderMemory {
    pub fn total(&self) -> u64 {
        self.image_bytes
            .saturating_add(self.pass_bytes)
            .saturating_add(self.geometry_bytes)
            .saturating_add(self.build_bytes)
            .saturating_add(self.light_bytes)
    }
}

/// Bytes as GiB or MiB with one decimal, for messages.
pub fn format_bytes(bytes: u64) -> String {
    const MIB: f64 = (1u64 << 20) as f64;
    let mib = bytes as f64 / MIB;
    if mib >= 1024.0 {
        format!("{:.1} GiB", mib / 1024.0)
    } else {
        format!("{mib:.1} MiB")
    }
}

impl fmt::Display for RenderMemory {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "about {} ({}x{} pixels with {} shadow light(s) and {} output plane(s): {}, and {} \
             for the passes' buffers; {} world triangles held as {}: {} of geometry and trees, \
             and {} while building them; {} for one light's preparation)",
            format_bytes(self.total()),
            self.width,
            self.height,
            self.lights,
            self.output_planes,
            format_bytes(self.image_bytes),
            format_bytes(self.pass_bytes),
            self.world_triangles,
            if self.instances > 0 {
                format!(
                    "{} unique triangles and {} instances",
                    self.held_triangles, self.instances
                )
            } else {
                "a flat set".to_string()
            },
            format_bytes(self.geometry_bytes),
            format_bytes(self.build_bytes),
            format_bytes(self.light_bytes),
        )
    }
}

/// Bytes per pixel of the passes at their peak (the shadow pass of the last light, while the
/// primary pass and the summed work are alive), and of the result's own planes.
fn pass_bytes_per_pixel(settings: &RenderSettings, lights: u64) -> (u64, u64) {
    let s = size_of::<Option<SurfacePoint>>() as u64;
    let t = size_of::<TraversalStats>() as u64;
    let counted = settings.stats != StatsMode::TimingOnly;
    // The result: masks, combined, primary ids and objects, and heat maps when counting.
    let result = PLANE.saturating_mul(lights.saturating_add(3))
        + if counted { PLANE * HEAT_PLANES } else { 0 };
    let passes = if counted {
        // Primary hits and work, the summed shadow work, one light's per-pixel results and work.
        s + 3 * t + size_of::<(f32, ShadowRayOutcome, TraversalStats)>() as u64
    } else {
        s + size_of::<(f32, ShadowRayOutcome)>() as u64
    };
    (passes, result)
}

/// Representative rays one light's preparation traces (the largest over the frame's lights).
fn prep_rays(settings: &RenderSettings, pixels: u64) -> u64 {
    let spp = settings.spp.max(1) as u64;
    let share = |f: f32| (pixels as f64 * f.clamp(0.0, 1.0) as f64).ceil() as u64;
    let srdh = |s: &crate::order::SrdhSettings| match s.rays {
        RaySetSource::All => pixels.saturating_mul(spp),
        RaySetSource::Budget(f) => share(f).saturating_mul(spp),
        RaySetSource::Prepass { width, height } => (width as u64 * height as u64)
            .min(pixels)
            .saturating_mul(spp),
    };
    match &settings.shadow_order {
        Pick::Fixed(ShadowOrder::Sorted(s)) => share(s.budget).saturating_mul(spp),
        Pick::Fixed(ShadowOrder::Srdh(s)) => srdh(s),
        // Auto prepares a light with the sorted or the SRDH order at their defaults.
        Pick::Auto => share(crate::order::SortSettings::default().budget)
            .saturating_mul(spp)
            .max(srdh(&Default::default())),
        _ => 0,
    }
}

/// Estimates the peak memory of rendering `scene` with `settings` when the caller then copies
/// `output_planes` planes out of the result (each copied and encoded once). An upper bound
/// within about 2x of the measured peak for frames whose images or triangles dominate.
pub fn estimate_render_bytes(
    scene: &Scene,
    settings: &RenderSettings,
    output_planes: u64,
) -> RenderMemory {
    let (w, h) = (
        scene.resolution.x as u64 * scene.resolution.percentage as u64 / 100,
        scene.resolution.y as u64 * scene.resolution.percentage as u64 / 100,
    );
    let (width, height) = (w.max(1), h.max(1));
    let pixels = width.saturating_mul(height);
    let lights = scene.lights.iter().filter(|l| l.casts_shadow).count() as u64;

    let (passes, result) = pass_bytes_per_pixel(settings, lights);
    // Planes are copied out after the passes end, but the allocator does not hand the passes'
    // freed buffers to those copies (measured), so the two add up.
    let kept = result.saturating_add(output_planes.saturating_mul(2 * PLANE));
    let image_bytes = with_slack(pixels.saturating_mul(kept)).saturating_add(PROCESS_BYTES);
    let pass_bytes = with_slack(
        pixels
            .saturating_mul(passes)
            .saturating_add(prepass_bytes(settings, pixels)),
    );

    let triangles = |pick: fn(&crate::scene::Object) -> bool| -> u64 {
        scene
            .objects
            .iter()
            .filter(|o| pick(o))
            .map(|o| {
                scene
                    .meshes
                    .get(o.mesh)
                    .map_or(0, |m| m.triangles.len() as u64)
            })
            .sum()
    };
    let camera = triangles(|o| o.visible_to_camera);
    let separate_shadow_set = scene
        .objects
        .iter()
        .any(|o| o.visible_to_camera != o.casts_shadow);
    let shadow = if separate_shadow_set {
        triangles(|o| o.casts_shadow)
    } else {
        0
    };
    let world_triangles = camera + shadow;
    // Two levels hold each used mesh once (its tree shared by both sets) and an instance per
    // object of each set; a flat frame holds every world triangle.
    let two_level = match settings.structure {
        Pick::Fixed(s) => s,
        Pick::Auto => auto_structure(scene, settings),
    } == SceneStructure::TwoLevel;
    let (held_triangles, instances) = if two_level {
        let mut used = vec![false; scene.meshes.len()];
        let mut instances = 0u64;
        for o in &scene.objects {
            if let Some(u) = used.get_mut(o.mesh) {
                *u = true;
            }
            instances += o.visible_to_camera as u64;
            instances += (separate_shadow_set && o.casts_shadow) as u64;
        }
        let held = scene
            .meshes
            .iter()
            .zip(&used)
            .filter(|(_, u)| **u)
            .map(|(m, _)| m.triangles.len() as u64)
            .sum();
        (held, instances)
    } else {
        (world_triangles, 0)
    };
    // Per triangle of a set: its render-space vertices and reference, gathered per object and
    // then joined (twice at the peak, once kept).
    let set_bytes = (size_of::<[glam::Vec3; 3]>() + size_of::<TriangleRef>()) as u64;
    // Spatial splits add up to `max_growth` references; visibility-driven builds trace their
    // visible set with one more tree.
    let splits = matches!(
        settings.build,
        Pick::Fixed(BuildMethod::Sbvh | BuildMethod::Abvh | BuildMethod::Osah) | Pick::Auto
    ) && settings.build_settings.spatial.enabled;
    let growth = if splits {
        1.0 + settings.build_settings.spatial.max_growth.clamp(0.0, 64.0) as f64
    } else {
        1.0
    };
    let refs = |n: u64| (n as f64 * growth).ceil() as u64;
    // Exact and prepass visible sets are traced through one more (SAH) tree.
    let visibility_tree = settings.build.uses_visibility()
        && matches!(
            settings.visibility,
            VisibilitySource::Exact | VisibilitySource::Prepass { .. }
        );
    let wide = settings.width != BvhWidth::Two
        || settings
            .shadow_order
            .fixed()
            .is_some_and(|o| o.binary().is_none() && !matches!(o, ShadowOrder::Srdh(_)));
    let kept_per_ref = TREE_BYTES_PER_REF + if wide { WIDE_BYTES_PER_REF } else { 0 };
    let extra_tree = if visibility_tree {
        camera.saturating_mul(BUILD_BYTES_PER_REF)
    } else {
        0
    };
    let geometry_bytes = held_triangles
        .saturating_mul(set_bytes)
        .saturating_add(refs(held_triangles).saturating_mul(kept_per_ref))
        .saturating_add(instances.saturating_mul(INSTANCE_BYTES))
        .saturating_add(alpha_bytes(scene, settings, two_level));
    let build_bytes = held_triangles
        .saturating_mul(set_bytes)
        .saturating_add(
            refs(held_triangles).saturating_mul(BUILD_BYTES_PER_REF - TREE_BYTES_PER_REF),
        )
        .saturating_add(instances.saturating_mul(INSTANCE_BUILD_BYTES))
        .saturating_add(extra_tree);

    let rays = prep_rays(settings, pixels);
    let light_bytes = if lights == 0 || rays == 0 {
        0
    } else {
        let per_ray = size_of::<Ray>() as u64 + PREP_BYTES_PER_RAY;
        // A light's own SRDH tree is built over the shadow set, on two levels over the
        // instances.
        let own_tree = match settings.shadow_order.may_trace_srdh() {
            false => 0,
            true if two_level => instances.saturating_mul(BUILD_BYTES_PER_REF),
            true => (if separate_shadow_set { shadow } else { camera })
                .saturating_mul(BUILD_BYTES_PER_REF),
        };
        rays.saturating_mul(per_ray).saturating_add(own_tree)
    };
    RenderMemory {
        width,
        height,
        lights,
        world_triangles,
        held_triangles,
        instances,
        output_planes,
        image_bytes,
        pass_bytes,
        geometry_bytes,
        build_bytes,
        light_bytes,
    }
}

/// The frame's alpha (`FrameAlpha`): per triangle of an object with an alpha material, as the
/// flat sets hold it (camera and shadow set alike, at most), or once per mesh and materials on
/// two levels. The images are the scene's, shared, and counted by the limits that admit them.
fn alpha_bytes(scene: &Scene, settings: &RenderSettings, two_level: bool) -> u64 {
    if !settings.alpha_active(scene) {
        return 0;
    }
    let mut shared = std::collections::HashSet::new();
    let triangles: u64 = (scene.objects.iter())
        .filter(|o| o.materials.iter().any(Option::is_some))
        .filter(|o| !two_level || shared.insert((o.mesh, o.materials.clone())))
        .map(|o| {
            scene
                .meshes
                .get(o.mesh)
                .map_or(0, |m| m.triangles.len() as u64)
        })
        .sum();
    let sets = if two_level { 1 } else { 2 };
    triangles.saturating_mul(sets * ALPHA_BYTES_PER_TRIANGLE)
}

/// `bytes` and an eighth more for what the per-pixel sizes leave out (parallel collection,
/// allocator rounding).
fn with_slack(bytes: u64) -> u64 {
    bytes.saturating_add(bytes / 8)
}

/// The visibility prepass of a visibility-driven build (`exact` at the frame's size, or
/// `prepass:WxH` at its own): a closest hit and a triangle id per pixel of its size. Measured
/// 828 MB at 4096x4096 on a 64x48 frame, which the frame's own sizes said nothing of.
fn prepass_bytes(settings: &RenderSettings, pixels: u64) -> u64 {
    if !settings.build.uses_visibility() {
        return 0;
    }
    let prepass_pixels = match settings.visibility {
        VisibilitySource::Previous => return 0,
        VisibilitySource::Exact => pixels,
        VisibilitySource::Prepass { width, height } => width as u64 * height as u64,
    };
    prepass_pixels.saturating_mul((size_of::<Option<SurfacePoint>>() + size_of::<u32>()) as u64)
}

/// Estimates the peak memory of a comparison rendering `scene` with each of `methods` (see
/// `compare::Comparison`), each method copying `output_planes` planes out of its result (a
/// `Compare`'s heat plane per method). Every method keeps its own trees across frames, and a
/// frame starts from a copy of each method's state, which holds the previous frame's trees
/// while the new ones are built, so the kept trees count twice per method, plus those of the
/// one timed pass that runs at a time and its build. Every method's counted result lives until the frame ends;
/// one pass's buffers (or prepass), one timed pass's result and one light's preparation are
/// alive at a time. Linear in the methods: each term is a sum or a largest one.
pub fn estimate_comparison_bytes(
    scene: &Scene,
    methods: &[&RenderSettings],
    output_planes: u64,
) -> RenderMemory {
    let each: Vec<RenderMemory> = methods
        .iter()
        .map(|s| estimate_render_bytes(scene, s, output_planes))
        .collect();
    let Some(first) = each.first().copied() else {
        return estimate_render_bytes(scene, &RenderSettings::default(), output_planes);
    };
    let n = each.len() as u64;
    let sum = |f: fn(&RenderMemory) -> u64| each.iter().map(f).fold(0u64, u64::saturating_add);
    let max = |f: fn(&RenderMemory) -> u64| each.iter().map(f).max().unwrap_or(0);
    // The process once.
    let image_bytes = sum(|m| m.image_bytes).saturating_sub((n - 1).saturating_mul(PROCESS_BYTES));
    let timed_result = max(|m| m.image_bytes.saturating_sub(PROCESS_BYTES));
    let geometry_bytes = sum(|m| m.geometry_bytes).saturating_mul(2);
    let build_bytes = max(|m| m.geometry_bytes.saturating_add(m.build_bytes));
    RenderMemory {
        output_planes: output_planes.saturating_mul(n),
        image_bytes,
        pass_bytes: max(|m| m.pass_bytes).saturating_add(timed_result),
        geometry_bytes,
        build_bytes,
        light_bytes: max(|m| m.light_bytes),
        ..first
    }
}

/// The planes a frame's files or a full reply hold: every mask, the combined image, the heat
/// maps when counting and the object ids.
pub fn all_output_planes(scene: &Scene, settings: &RenderSettings) -> u64 {
    let lights = scene.lights.iter().filter(|l| l.casts_shadow).count() as u64;
    let heat = if settings.stats != StatsMode::TimingOnly {
        HEAT_PLANES
    } else {
        0
    };
    lights + 2 + heat
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use glam::{DMat4, DVec3};

    use super::*;
    use crate::scene::{Camera, Light, LightKind, Mesh, Object, Resolution};

    fn scene(objects: usize, width: u32, height: u32) -> Scene {
        let mesh = Mesh::new(
            "tri",
            vec![
                [0.0, 0.0, 0.0].into(),
                [1.0, 0.0, 0.0].into(),
                [0.0, 1.0, 0.0].into(),
            ],
            vec![[0, 1, 2]],
        );
        Scene {
            frame: 3,
            meshes: vec![Arc::new(mesh)],
            objects: (0..objects)
                .map(|i| Object::new(format!("o{i}"), 0, DMat4::IDENTITY))
                .collect(),
            camera: Camera::look_at(DVec3::new(0.0, -5.0, 2.0), DVec3::ZERO, DVec3::Z),
            lights: vec![Light::new(
                "sun",
                DMat4::IDENTITY,
                LightKind::Sun { angle: 0.0 },
            )],
            resolution: Resolution::new(width, height),
            alpha: Default::default(),
        }
    }

    #[test]
    fn the_estimate_follows_pixels_instances_and_splits() {
        let s = RenderSettings::baseline();
        let small = estimate_render_bytes(&scene(1, 64, 64), &s, 1);
        let big = estimate_render_bytes(&scene(1, 8192, 8192), &s, 1);
        assert_eq!((big.width, big.height, big.lights), (8192, 8192, 1));
        // 8192x8192 with counters needs well over the default 8 GiB budget (issue 24).
        assert!(big.total() > 8 << 30, "{big}");
        assert!(small.total() < 64 << 20, "{small}");
        // Every instance of a mesh is a world triangle of its own.
        let many = estimate_render_bytes(&scene(1000, 64, 64), &s, 1);
        assert_eq!(many.world_triangles, 1000);
        assert!(many.geometry_bytes >= 1000 * small.geometry_bytes);
        assert!(many.build_bytes >= 1000 * small.build_bytes);
        let sbvh = RenderSettings {
            build: Pick::Fixed(BuildMethod::Sbvh),
            ..s.clone()
        };
        assert!(
            estimate_render_bytes(&scene(1000, 64, 64), &sbvh, 1).geometry_bytes
                > many.geometry_bytes
        );
        // Huge inputs saturate rather than overflow.
        let mut huge = scene(1, u32::MAX, u32::MAX);
        huge.resolution.percentage = u32::MAX;
        assert!(estimate_render_bytes(&huge, &s, u64::MAX).total() > 1 << 60);
        assert!(big.to_string().contains("8192x8192 pixels"), "{big}");
    }

    #[test]
    fn alpha_materials_count_per_flagged_triangle() {
        let s = RenderSettings::baseline();
        let mut with = scene(1000, 64, 64);
        for o in &mut with.objects[..500] {
            o.materials = vec![Some(0)];
        }
        let opaque = estimate_render_bytes(&scene(1000, 64, 64), &s, 1);
        let flat = estimate_render_bytes(&with, &s, 1);
        let alpha = flat.geometry_bytes - opaque.geometry_bytes;
        assert_eq!(alpha, 500 * 2 * ALPHA_BYTES_PER_TRIANGLE);
        // Two levels hold one mesh's alpha per materials, however many objects share it.
        let two = RenderSettings {
            structure: Pick::Fixed(SceneStructure::TwoLevel),
            ..s.clone()
        };
        let opaque_two = estimate_render_bytes(&scene(1000, 64, 64), &two, 1);
        let shared = estimate_render_bytes(&with, &two, 1);
        assert_eq!(
            shared.geometry_bytes - opaque_two.geometry_bytes,
            ALPHA_BYTES_PER_TRIANGLE
        );
        let off = RenderSettings { alpha: false, ..s };
        assert_eq!(
            estimate_render_bytes(&with, &off, 1).geometry_bytes,
            estimate_render_bytes(&scene(1000, 64, 64), &off, 1).geometry_bytes
        );
    }

    #[test]
    fn the_visibility_prepass_counts_at_its_own_size() {
        // Issue 33: a 64x48 frame with an OSAH build whose first visible set comes from a
        // 4096x4096 prepass peaked at 828 MB and was estimated at 41 MiB.
        let sc = scene(1000, 64, 48);
        let osah = |visibility: VisibilitySource| RenderSettings {
            build: Pick::Fixed(BuildMethod::Osah),
            visibility,
            ..RenderSettings::baseline()
        };
        let prepass = osah(VisibilitySource::Prepass {
            width: 4096,
            height: 4096,
        });
        let big = estimate_render_bytes(&sc, &prepass, 1).total();
        assert!(big > 828_000_000, "{}", format_bytes(big));
        assert!(big < 2 * 828_000_000, "{}", format_bytes(big));
        let previous = estimate_render_bytes(&sc, &osah(VisibilitySource::Previous), 1).total();
        assert!(previous < 64 << 20, "{}", format_bytes(previous));
        // A comparison holds one prepass at a time: eight such methods need about one.
        let many = estimate_comparison_bytes(&sc, &[&prepass; 8], 0).total();
        assert!(
            many > 883_000_000 && many < 2 * 883_000_000,
            "{}",
            format_bytes(many)
        );
    }

    #[test]
    fn a_comparison_bounds_every_method_together() {
        let sc = scene(1000, 64, 64);
        let sah = RenderSettings::baseline();
        let sbvh = RenderSettings {
            build: Pick::Fixed(BuildMethod::Sbvh),
            ..sah.clone()
        };
        let one = estimate_render_bytes(&sc, &sbvh, 0);
        let alone = estimate_comparison_bytes(&sc, &[&sbvh], 0);
        // One method: its trees and the previous frame's, plus a timed pass's and its build.
        assert_eq!(alone.geometry_bytes, 2 * one.geometry_bytes);
        assert_eq!(alone.build_bytes, one.geometry_bytes + one.build_bytes);
        assert_eq!(alone.image_bytes, one.image_bytes);
        let both = estimate_comparison_bytes(&sc, &[&sah, &sbvh], 0);
        let two = estimate_render_bytes(&sc, &sah, 0);
        assert_eq!(
            both.geometry_bytes,
            2 * (one.geometry_bytes + two.geometry_bytes)
        );
        assert_eq!(both.build_bytes, one.geometry_bytes + one.build_bytes);
        assert_eq!(
            both.image_bytes,
            one.image_bytes + two.image_bytes - PROCESS_BYTES
        );
        assert!(both.total() > one.total().max(two.total()));
    }
}
