//! One frame's passes over the renderer's trees: the primary pass, each light's shadow pass
//! with its tree and order, their statistics rows, and the frame's combined result.

use super::auto;
use super::facing::face_shading_normals;
use super::frame_alpha::{AlphaCamera, AlphaCameraTree, AlphaSets, AlphaShadowTracer, FrameAlpha};
use super::frame_trees::Prepared;
use super::light_tracer::{LightRays, ShadowTracer};
use super::policy::{pass_rays, LightMeasurement, LightPlan};
use super::primary::{heat_planes, HeatWork};
use super::renderer::{FrameResult, HeatMaps};
use super::scene_trees::SceneTrees;
use super::shadow::{samples_for, SamplePlan};
use super::two_level_trees::TreeColumns;
use super::visibility::visible_set;
use super::{
    Facing, HitGeometry, LightSampler, PrimaryPass, PrimaryRays, RenderSettings, ShadowPass,
    StatsMode,
};
use crate::cancel::CancelToken;
use crate::image::ImagePlane;
use crate::scene::{Scene, TriangleRef};
use crate::stats::StatsRow;
use crate::trace::{AlphaScenes, AlphaStats, NoStats, RayQuery, TraversalStats};
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
    /// A row for `pass` over the trees `columns` describe, work and timing still unset.
    fn row(&self, pass: &str, light: &str, columns: TreeColumns) -> StatsRow {
        StatsRow {
            scene: self.scene_name.to_string(),
            frame: self.scene.frame,
            method: self.method.clone(),
            pass: pass.to_string(),
            light: light.to_string(),
            rebuilt: columns.build_ms > 0.0 || self.prepared.rebuilt,
            build_ms: columns.build_ms,
            bvh_nodes: columns.nodes,
            bvh_bytes: columns.bytes,
            triangles: columns.triangles,
            references: columns.references,
            visible_input: columns.visible,
            visibility_ms: self.prepared.visibility_ms,
            trees_refit: columns.refit,
            ..StatsRow::default()
        }
    }
}

/// The primary pass (on the wide tree for widths 4 and 8), its statistics row and, when
/// counting, its heat maps; traced a second time without counters when the row wants both
/// counts and timing. The heat maps are made here and the pass's per-pixel work dropped: a
/// pixel's counters take 56 bytes, its three heat-map values 12, and the shadow passes after
/// this would otherwise hold them all.
pub(super) fn primary_pass(
    trees: &SceneTrees,
    scene: &Scene,
    settings: &RenderSettings,
    alpha: Option<&FrameAlpha>,
    rows: &Rows,
    cancel: &CancelToken,
) -> Result<(PrimaryPass, StatsRow, Option<[ImagePlane; 3]>)> {
    let (counted, timed) = counted_timed(settings);
    let trace = |counted: bool| trace_camera(trees, scene, settings, alpha, counted, cancel);
    let mut primary = trace(counted)?;
    let columns = trees.camera_columns(rows.prepared.rebuilt, rows.collapse_ms);
    let mut row = rows.row("primary", "", columns);
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
        let rays = PrimaryRays::new(&scene.camera, &scene.resolution, trees.space());
        face_shading_normals(&mut primary, &rays, scene, &trees.hit_geometry(scene));
    }
    let heat = counted.then(|| primary.heat_maps("primary"));
    primary.work = Vec::new();
    Ok((primary, row, heat))
}

/// The camera rays of a frame on the tree its primary pass reads, counted or timed.
/// With `alpha`, the camera's tree through [`AlphaCamera`] (counted in [`AlphaStats`]).
pub(super) fn trace_camera(
    trees: &SceneTrees,
    scene: &Scene,
    settings: &RenderSettings,
    alpha: Option<&FrameAlpha>,
    counted: bool,
    cancel: &CancelToken,
) -> Result<PrimaryPass> {
    let rays = PrimaryRays::new(&scene.camera, &scene.resolution, trees.space());
    let tree = trees.camera_query(pass_rays(settings));
    let hits = trees.hit_geometry(scene);
    let Some(alpha) = alpha else {
        return trace_primary(counted, &rays, &tree, hits, cancel);
    };
    let tree = AlphaCameraTree::of(&tree);
    match &alpha.sets {
        AlphaSets::Flat { camera, .. } => {
            alpha_primary(counted, &rays, &tree, camera, alpha.clip, hits, cancel)
        }
        AlphaSets::TwoLevel(instances) => {
            alpha_primary(counted, &rays, &tree, instances, alpha.clip, hits, cancel)
        }
    }
}

/// The camera rays through alpha (`counted` in [`AlphaStats`]), each hit read in `scenes`.
fn alpha_primary(
    counted: bool,
    rays: &PrimaryRays,
    tree: &AlphaCameraTree,
    scenes: &(impl AlphaScenes + ?Sized),
    clip: f32,
    hits: HitGeometry,
    cancel: &CancelToken,
) -> Result<PrimaryPass> {
    let camera = AlphaCamera {
        tree,
        alpha: scenes,
        clip,
    };
    if counted {
        PrimaryPass::trace::<AlphaStats>(rays, &camera, hits, cancel)
    } else {
        PrimaryPass::trace::<NoStats>(rays, &camera, hits, cancel)
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
    /// Per pixel, N_B, N_L and N_T summed over the lights (empty unless counting).
    pub(super) work: Vec<HeatWork>,
    /// Per light, what the policy learns from.
    pub(super) measured: Vec<LightMeasurement>,
    /// Shadow rays traced, over every pass (counted and timed).
    pub(super) rays: u64,
    /// Per light, the alpha lookups of its counted pass (empty without alpha).
    pub(super) alpha_lookups: Vec<(String, u64)>,
}

/// Each shadow-casting light in turn: its tree and order ([`FrameTrees::for_light`]), its
/// shadow pass and its row.
#[allow(clippy::too_many_arguments)]
pub(super) fn shadow_passes(
    trees: &SceneTrees,
    primary: &PrimaryPass,
    scene: &Scene,
    settings: &RenderSettings,
    plans: &[LightPlan],
    alpha: Option<&FrameAlpha>,
    rows: &Rows,
    cancel: &CancelToken,
) -> Result<ShadowPasses> {
    let (counted, timed) = counted_timed(settings);
    let mut out = ShadowPasses {
        masks: Vec::new(),
        rows: Vec::new(),
        work: vec![HeatWork::default(); if counted { primary.surfaces.len() } else { 0 }],
        measured: Vec::new(),
        rays: 0,
        alpha_lookups: Vec::new(),
    };
    let shadow_lights = scene
        .lights
        .iter()
        .enumerate()
        .filter(|(_, l)| l.casts_shadow);
    // A per-tree order's preparation is reported on the row of the first light that uses it.
    let mut per_tree_unreported = true;
    for ((index, light), order) in shadow_lights.zip(plans) {
        cancel.check()?;
        let sampler = LightSampler::new(light, trees.space());
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
            objects: &scene.objects,
            first: per_tree_unreported && order.order.is_per_tree(),
        };
        per_tree_unreported &= !order.order.is_per_tree();
        let tracing = trees.for_light(&order.order, settings.width, &light_rays);
        cancel.check()?;
        let tracer = tracing.tracer(order.rays);
        // Chosen per pass: an opaque frame calls today's pass as it was. A counted pass adds
        // its pixels' work into `sums` (the frame's, over lights), a timed one takes none.
        let pass_of = |sums: Option<&mut [HeatWork]>| match (alpha, sums) {
            (None, Some(sums)) => ShadowPass::trace_adding::<TraversalStats>(
                primary, &tracer, &sampler, plan, cancel, sums,
            ),
            (None, None) => ShadowPass::trace::<NoStats>(primary, &tracer, &sampler, plan, cancel),
            (Some(a), sums) => alpha_shadow_pass(sums, primary, &tracer, a, &sampler, plan, cancel),
        };
        let pass = pass_of(counted.then_some(&mut out.work[..]))?;
        out.rays += pass.outcome.rays;
        let columns = trees.shadow_columns(&tracing, rows.prepared.rebuilt, rows.collapse_ms);
        let mut r = rows.row("shadow", &light.name, columns);
        r.prepare_ms = tracing.prepare_ms;
        if let Some(c) = &order.auto {
            auto::mark_row(&mut r, c, |o| o.name());
            if let Some(o) = order.sample {
                r.auto_choice += &format!(";sample={}", o.name());
            }
        }
        r.rays = pass.outcome.rays;
        r.occluded_fraction = pass.outcome.occluded as f64 / r.rays.max(1) as f64;
        r.back_facing = pass.outcome.back_facing;
        r.unreached = pass.outcome.unreached;
        r.set_work(&pass.totals);
        if counted && timed {
            let t = pass_of(None)?;
            out.rays += t.outcome.rays;
            debug_assert_eq!(t.mask, pass.mask);
            r.set_timing(t.trace_ms, true);
        } else {
            r.set_timing(pass.trace_ms, !counted);
        }
        // `auto`'s sample: the same in counted and timed frames, so timing includes it.
        let sampled = order.sample.map(|o| {
            let s = trees.for_light(&o.order(), settings.width, &light_rays);
            auto::sample_work(primary, &sampler, plan, &s.tracer(order.rays))
        });
        out.measured.push(LightMeasurement {
            light: trees.history_key(&light.name),
            rays: r.rays,
            work: pass.totals,
            own_tree: tracing.own_tree().is_some(),
            sampled,
        });
        if alpha.is_some() {
            out.alpha_lookups
                .push((light.name.clone(), pass.alpha_lookups));
        }
        out.rows.push(r);
        out.masks.push(pass.mask);
    }
    Ok(out)
}

/// The frame's result: the masks and their mean, heat maps when counting, the primary hits
/// and the visible set.
pub(super) fn combine(
    scene: &Scene,
    trees: &SceneTrees,
    primary: PrimaryPass,
    primary_row: StatsRow,
    primary_heat: Option<[ImagePlane; 3]>,
    shadows: ShadowPasses,
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
    let heat = primary_heat.map(|primary| HeatMaps {
        primary,
        shadow: heat_planes("shadow", w, h, &shadows.work),
    });
    let visible = visible_set(
        &primary.surfaces,
        trees.flat().map(|t| &t.geometry().camera),
    );
    let primary_hits: Vec<TriangleRef> = primary
        .surfaces
        .iter()
        .map(|s| s.map_or(TriangleRef::MISS, |s| s.reference))
        .collect();
    let mut stats = vec![primary_row];
    stats.extend(shadows.rows);
    FrameResult {
        frame: scene.frame,
        width: w,
        height: h,
        masks,
        combined,
        heat,
        visible,
        primary_objects: primary_hits.iter().map(|r| r.object).collect(),
        primary_hits,
        structure: trees.structure(),
        stats,
    }
}

/// One light's pass through alpha on its tree and order: counted in [`AlphaStats`] (each
/// pixel's work added into `sums`) or, without `sums`, timed.
fn alpha_shadow_pass(
    sums: Option<&mut [HeatWork]>,
    primary: &PrimaryPass,
    tracer: &ShadowTracer,
    alpha: &FrameAlpha,
    sampler: &LightSampler,
    plan: SamplePlan,
    cancel: &CancelToken,
) -> Result<ShadowPass> {
    let tracer = AlphaShadowTracer::of(tracer);
    let max_hits = alpha.max_hits;
    let t = &tracer;
    match &alpha.sets {
        AlphaSets::Flat { camera, shadow } => {
            let scene = shadow.as_ref().unwrap_or(camera);
            alpha_light_pass(sums, primary, t, scene, max_hits, sampler, plan, cancel)
        }
        AlphaSets::TwoLevel(instances) => {
            alpha_light_pass(sums, primary, t, instances, max_hits, sampler, plan, cancel)
        }
    }
}

/// One light's pass through alpha with each hit read in `scene`, counted (into `sums`) or
/// timed.
#[allow(clippy::too_many_arguments)]
fn alpha_light_pass(
    sums: Option<&mut [HeatWork]>,
    primary: &PrimaryPass,
    tracer: &AlphaShadowTracer,
    scene: &(impl AlphaScenes + ?Sized),
    max_hits: u32,
    sampler: &LightSampler,
    plan: SamplePlan,
    cancel: &CancelToken,
) -> Result<ShadowPass> {
    match sums {
        Some(sums) => ShadowPass::trace_alpha_adding::<AlphaStats>(
            primary, tracer, scene, max_hits, sampler, plan, cancel, sums,
        ),
        None => ShadowPass::trace_alpha::<NoStats>(
            primary, tracer, scene, max_hits, sampler, plan, cancel,
        ),
    }
}

/// The primary pass on any tree, with counters or timed.
fn trace_primary(
    counted: bool,
    rays: &PrimaryRays,
    tree: &impl RayQuery,
    triangles: HitGeometry,
    cancel: &CancelToken,
) -> Result<PrimaryPass> {
    if counted {
        PrimaryPass::trace::<TraversalStats>(rays, tree, triangles, cancel)
    } else {
        PrimaryPass::trace::<NoStats>(rays, tree, triangles, cancel)
    }
}
