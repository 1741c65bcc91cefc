//! One frame's passes over the renderer's trees: the primary pass, each light's shadow pass
//! with its tree and order, their statistics rows, and the frame's combined result.

use super::auto::{self, Choice, OrderChoice};
use super::facing::face_shading_normals;
use super::light_tracer::{light_tracing, LightRays, ShadowTrees};
use super::primary::heat_planes;
use super::renderer::{BvhInfo, Cached, FrameResult, HeatMaps, Prepared};
use super::shadow::{samples_for, SamplePlan};
use super::visibility::visible_set;
use super::wide_tree::WideTree;
use super::{
    Facing, LightSampler, PrimaryPass, PrimaryRays, RenderSettings, ShadowPass, StatsMode,
};
use crate::bvh::{Bvh, BvhWidth};
use crate::cancel::CancelToken;
use crate::image::ImagePlane;
use crate::order::ShadowOrder;
use crate::scene::Scene;
use crate::stats::StatsRow;
use crate::trace::{NoStats, RayQuery, TraversalStats};
use crate::Result;

/// What every statistics row of a frame shares.
pub(super) struct Rows<'a> {
    pub(super) scene_name: &'a str,
    pub(super) scene: &'a Scene,
    pub(super) method: String,
    pub(super) prepared: Prepared,
    pub(super) collapse_ms: f64,
}

impl Rows<'_> {
    /// A row for `pass` over `bvh` (or its collapse `tree`), work and timing still unset.
    fn row(
        &self,
        pass: &str,
        light: &str,
        bvh: &Bvh,
        info: BvhInfo,
        tree: Option<&WideTree>,
    ) -> StatsRow {
        let rebuilt = self.prepared.rebuilt;
        StatsRow {
            scene: self.scene_name.to_string(),
            frame: self.scene.frame,
            method: self.method.clone(),
            pass: pass.to_string(),
            light: light.to_string(),
            rebuilt: rebuilt || self.collapse_ms > 0.0,
            build_ms: if rebuilt { bvh.build_ms } else { 0.0 } + self.collapse_ms,
            bvh_nodes: tree.map_or(bvh.nodes.len(), |t| t.node_count()) as u64,
            bvh_bytes: tree.map_or(bvh.bytes(), |t| t.bytes()) as u64,
            triangles: info.triangles,
            references: bvh.triangles.len() as u64,
            visible_input: info.visible,
            visibility_ms: self.prepared.visibility_ms,
            ..StatsRow::default()
        }
    }
}

/// The primary pass (on the wide tree for widths 4 and 8) and its statistics row; traced a
/// second time without counters when the row wants both counts and timing.
pub(super) fn primary_pass(
    cached: &Cached,
    scene: &Scene,
    settings: &RenderSettings,
    rows: &Rows,
    cancel: &CancelToken,
) -> Result<(PrimaryPass, StatsRow)> {
    let (counted, timed) = counted_timed(settings);
    let trace = |counted: bool| trace_camera(cached, scene, counted, cancel);
    let mut primary = trace(counted)?;
    let mut row = rows.row(
        "primary",
        "",
        &cached.camera_bvh,
        cached.camera_info,
        wide_camera(cached),
    );
    row.rays = primary.ray_count();
    row.occluded_fraction =
        primary.surfaces.iter().filter(|s| s.is_some()).count() as f64 / row.rays.max(1) as f64;
    row.set_work(&primary.totals);
    if counted && timed {
        let t = trace(false)?;
        debug_assert_eq!(t.surfaces, primary.surfaces);
        row.set_timing(t.trace_ms, true);
    } else {
        row.set_timing(primary.trace_ms, !counted);
    }
    // After the timed pass's check: that pass's surfaces keep their geometric facing.
    if settings.facing == Facing::Shading {
        let geometry = &cached.geometry;
        let rays = PrimaryRays::new(&scene.camera, &scene.resolution, &geometry.space);
        face_shading_normals(&mut primary, &rays, scene, &geometry.camera);
    }
    Ok((primary, row))
}

/// The wide camera tree the primary pass traces (widths 4 and 8), else none (the binary one).
fn wide_camera(cached: &Cached) -> Option<&WideTree> {
    let wide = cached.wide.as_ref().filter(|w| w.width != BvhWidth::Two);
    wide.map(|w| &*w.camera)
}

/// The camera rays of a frame on the tree its primary pass reads, counted or timed.
pub(super) fn trace_camera(
    cached: &Cached,
    scene: &Scene,
    counted: bool,
    cancel: &CancelToken,
) -> Result<PrimaryPass> {
    let geometry = &cached.geometry;
    let rays = PrimaryRays::new(&scene.camera, &scene.resolution, &geometry.space);
    match wide_camera(cached) {
        Some(t) => trace_primary(counted, &rays, t, &geometry.camera, cancel),
        None => trace_primary(
            counted,
            &rays,
            &*cached.camera_bvh,
            &geometry.camera,
            cancel,
        ),
    }
}

/// Whether a frame's passes count work, and whether they are timed without counters.
pub(super) fn counted_timed(settings: &RenderSettings) -> (bool, bool) {
    (
        settings.stats != StatsMode::TimingOnly,
        settings.stats != StatsMode::Counts,
    )
}

/// The shadow passes of a frame: per light, a mask and a statistics row; the summed work per
/// pixel over lights when counting.
pub(super) struct ShadowPasses {
    pub(super) masks: Vec<ImagePlane>,
    pub(super) rows: Vec<StatsRow>,
    pub(super) work: Vec<TraversalStats>,
    /// Per light: the work of its rays, whether it traced a tree of its own (SRDH), and the
    /// work and rays of `auto`'s sample, if it took one.
    pub(super) measured: Vec<(TraversalStats, bool, Option<Sampled>)>,
    /// Shadow rays traced, over every pass (counted and timed).
    pub(super) rays: u64,
}

/// The work and the rays of `auto`'s sample of a light.
pub(super) type Sampled = (TraversalStats, u64);

/// One shadow-casting light's order this frame, and `auto`'s choice behind it.
pub(super) struct LightOrder {
    pub(super) order: ShadowOrder,
    pub(super) auto: Option<Choice<OrderChoice>>,
    /// An order `auto` measures on a sample of the light's rays.
    pub(super) sample: Option<OrderChoice>,
}

/// Each shadow-casting light in turn: its tree and order ([`light_tracing`]), its shadow pass
/// and its row.
pub(super) fn shadow_passes(
    cached: &Cached,
    primary: &PrimaryPass,
    scene: &Scene,
    settings: &RenderSettings,
    orders: &[LightOrder],
    rows: &Rows,
    cancel: &CancelToken,
) -> Result<ShadowPasses> {
    let geometry = &cached.geometry;
    let wide = cached.wide.as_ref();
    let shadow_bvh = cached.shadow_bvh.as_ref().unwrap_or(&cached.camera_bvh);
    let shadow_info = cached.shadow_info.unwrap_or(cached.camera_info);
    let trees = ShadowTrees {
        bvh: shadow_bvh,
        triangles: &geometry
            .shadow
            .as_ref()
            .unwrap_or(&geometry.camera)
            .vertices,
        wide: wide.map(|w| w.shadow.as_deref().unwrap_or(&w.camera)),
        sort_tables: wide.and_then(|w| w.sort_tables.as_ref()),
        per_tree: wide
            .and_then(|w| w.per_tree_order.as_ref())
            .map(|p| (&p.order, &p.prepared, p.ms)),
    };
    let (counted, timed) = counted_timed(settings);
    let mut out = ShadowPasses {
        masks: Vec::new(),
        rows: Vec::new(),
        work: vec![TraversalStats::default(); if counted { primary.surfaces.len() } else { 0 }],
        measured: Vec::new(),
        rays: 0,
    };
    let shadow_lights = scene
        .lights
        .iter()
        .enumerate()
        .filter(|(_, l)| l.casts_shadow);
    // A per-tree order's preparation is reported on the row of the first light that uses it.
    let mut per_tree_unreported = true;
    for ((index, light), order) in shadow_lights.zip(orders) {
        cancel.check()?;
        let sampler = LightSampler::new(light, &geometry.space);
        let plan = SamplePlan {
            light_index: index as u32,
            samples: samples_for(&sampler, settings.spp),
            seed: settings.seed,
        };
        let light_rays = LightRays {
            primary,
            sampler: &sampler,
            plan,
            sah: &settings.build_settings,
            first: per_tree_unreported && order.order.is_per_tree(),
        };
        per_tree_unreported &= !order.order.is_per_tree();
        let tracing = light_tracing(&trees, &order.order, settings.width, &light_rays);
        cancel.check()?;
        let tracer = tracing.tracer();
        let pass_of = |counted: bool| {
            if counted {
                ShadowPass::trace::<TraversalStats>(primary, &tracer, &sampler, plan, cancel)
            } else {
                ShadowPass::trace::<NoStats>(primary, &tracer, &sampler, plan, cancel)
            }
        };
        let pass = pass_of(counted)?;
        out.rays += pass.outcome.rays;
        let mut r = rows.row(
            "shadow",
            &light.name,
            shadow_bvh,
            shadow_info,
            tracing.wide_tree(),
        );
        r.sort_ms = tracing.sort_ms;
        if let Some(c) = &order.auto {
            auto::mark_row(&mut r, c, |o| o.name());
            if let Some(o) = order.sample {
                r.auto_choice += &format!(";sample={}", o.name());
            }
        }
        if let Some(t) = tracing.own_tree() {
            r.bvh_nodes = t.bvh.nodes.len() as u64;
            r.bvh_bytes = t.bytes() as u64;
        }
        r.rays = pass.outcome.rays;
        r.occluded_fraction = pass.outcome.occluded as f64 / r.rays.max(1) as f64;
        r.back_facing = pass.outcome.back_facing;
        r.unreached = pass.outcome.unreached;
        r.set_work(&pass.totals);
        if counted && timed {
            let t = pass_of(false)?;
            out.rays += t.outcome.rays;
            debug_assert_eq!(t.mask, pass.mask);
            r.set_timing(t.trace_ms, true);
        } else {
            r.set_timing(pass.trace_ms, !counted);
        }
        for (acc, wk) in out.work.iter_mut().zip(&pass.work) {
            *acc += *wk;
        }
        // `auto`'s sample: the same in counted and timed frames, so timing includes it.
        let sampled = order.sample.map(|o| {
            let s = light_tracing(&trees, &o.order(), settings.width, &light_rays);
            auto::sample_work(primary, &sampler, plan, &s.tracer())
        });
        out.measured
            .push((pass.totals, tracing.own_tree().is_some(), sampled));
        out.rows.push(r);
        out.masks.push(pass.mask);
    }
    Ok(out)
}

/// The frame's result: the masks and their mean, heat maps when counting, the primary hits
/// and the visible set.
pub(super) fn combine(
    scene: &Scene,
    cached: &Cached,
    primary: PrimaryPass,
    primary_row: StatsRow,
    shadows: ShadowPasses,
    settings: &RenderSettings,
) -> FrameResult {
    let (w, h) = (primary.width, primary.height);
    let masks = shadows.masks;
    let mut combined = ImagePlane::new("combined", w, h);
    if masks.is_empty() {
        combined.data.fill(1.0);
    } else {
        let k = 1.0 / masks.len() as f32;
        for m in &masks {
            for (c, v) in combined.data.iter_mut().zip(&m.data) {
                *c += v * k;
            }
        }
    }
    let (counted, _) = counted_timed(settings);
    let heat = counted.then(|| HeatMaps {
        primary: primary.heat_maps("primary"),
        shadow: heat_planes("shadow", w, h, &shadows.work),
    });
    let primary_ids: Vec<u32> = primary
        .surfaces
        .iter()
        .map(|s| s.map_or(u32::MAX, |s| s.triangle))
        .collect();
    let camera = &cached.geometry.camera;
    let mut stats = vec![primary_row];
    stats.extend(shadows.rows);
    FrameResult {
        frame: scene.frame,
        width: w,
        height: h,
        masks,
        combined,
        heat,
        visible: visible_set(&primary_ids, camera),
        primary_objects: camera.objects_of(&primary_ids),
        primary_ids,
        stats,
    }
}

/// The primary pass on any tree, with counters or timed.
fn trace_primary(
    counted: bool,
    rays: &PrimaryRays,
    tree: &impl RayQuery,
    triangles: &crate::scene::TriangleSet,
    cancel: &CancelToken,
) -> Result<PrimaryPass> {
    if counted {
        PrimaryPass::trace::<TraversalStats>(rays, tree, triangles, cancel)
    } else {
        PrimaryPass::trace::<NoStats>(rays, tree, triangles, cancel)
    }
}
