//! One frame end to end, and what carries over between frames: the geometry and BVHs of a frame
//! whose geometry (and, for visibility-driven builds, visible-set input) did not change are
//! reused, and the visible set is kept for the next frame's OSAH/ABVH build. A warm-up
//! ([`Renderer::warm_up`]) advances that state as a render would, tracing no shadow ray.

use std::sync::Arc;
use std::time::Instant;

use super::facing::face_shading_normals;
use super::light_tracer::{binary_order, light_tracing, LightRays, ShadowTrees};
use super::primary::heat_planes;
use super::shadow::{samples_for, SamplePlan};
use super::visibility::{trace_visible_set, visibility_flags, visible_set};
use super::wide_tree::WideTree;
use super::{Facing, VisibilitySource};
use super::{LightSampler, PrimaryPass, PrimaryRays, RenderSettings, ShadowPass, StatsMode};
use crate::build::{build_binned_sah, build_with_visibility, CollapseSettings};
use crate::bvh::{Bvh, BvhWidth};
use crate::cancel::CancelToken;
use crate::image::ImagePlane;
use crate::order::{PreparedOrder, ShadowOrder, SortTables};
use crate::scene::{FrameGeometry, Mesh, Resolution, Scene, TriangleRef, TriangleSet};
use crate::stats::StatsRow;
use crate::trace::{ClosestHitQuery, TraversalStats};
use crate::Result;

/// Heat maps of traversal work per pixel: N_B, N_L, N_T for primary rays and for all shadow
/// rays of a pixel (summed over lights and samples).
#[derive(Clone, Debug)]
pub struct HeatMaps {
    pub primary: [ImagePlane; 3],
    pub shadow: [ImagePlane; 3],
}

/// Everything one frame produces.
#[derive(Clone, Debug)]
pub struct FrameResult {
    pub frame: i32,
    pub width: u32,
    pub height: u32,
    /// One mask per shadow-casting light, named after the light.
    pub masks: Vec<ImagePlane>,
    /// The mean of the masks (1 where no light casts shadows).
    pub combined: ImagePlane,
    /// `None` in [`StatsMode::TimingOnly`].
    pub heat: Option<HeatMaps>,
    /// Camera-set triangles seen by a primary ray, sorted: V(t), which OSAH builds consume.
    pub visible: Vec<TriangleRef>,
    /// Closest-hit triangle id per pixel (u32::MAX where the ray missed).
    pub primary_ids: Vec<u32>,
    /// Index of the object hit per pixel, in the frame's object list (`Scene::objects`, the
    /// order of a frame update); u32::MAX where the ray missed. See [`FrameResult::object_plane`].
    pub primary_objects: Vec<u32>,
    pub stats: Vec<StatsRow>,
}

/// What a warm-up leaves besides the renderer's state: the frame's size and visible set.
#[derive(Clone, Debug, PartialEq)]
pub struct WarmUp {
    pub frame: i32,
    pub width: u32,
    pub height: u32,
    /// V(t), as [`FrameResult::visible`].
    pub visible: Vec<TriangleRef>,
}

/// The name of the object-id plane (the `object_ids` pass).
pub const OBJECT_PLANE: &str = "primary.object";

impl FrameResult {
    /// The object-id pass as an image: per pixel, the index of the object the primary ray hit
    /// (in the frame's object list), -1 where it missed. Exact in f32 up to 2^24 objects.
    pub fn object_plane(&self) -> ImagePlane {
        let mut plane = ImagePlane::new(OBJECT_PLANE, self.width, self.height);
        if self.primary_objects.len() == plane.data.len() {
            for (d, &o) in plane.data.iter_mut().zip(&self.primary_objects) {
                *d = if o == u32::MAX { -1.0 } else { o as f32 };
            }
        } else {
            plane.data.fill(-1.0);
        }
        plane
    }
}

/// What identifies a frame's geometry: mesh identities, transforms and visibility flags.
#[derive(Clone, PartialEq)]
struct GeometryKey {
    objects: Vec<(usize, [u64; 16], bool, bool)>,
}

#[derive(Clone)]
struct Cached {
    key: GeometryKey,
    /// Keeps the meshes alive so their addresses in the key cannot be reused.
    _meshes: Vec<Arc<Mesh>>,
    build: (crate::build::BuildMethod, crate::build::BuildSettings),
    /// Whether a finished frame has reported these trees' build (a cancelled render leaves
    /// the report to the next render that uses them, so it reads as a fresh render's).
    reported: bool,
    geometry: Arc<FrameGeometry>,
    camera_bvh: Arc<Bvh>,
    shadow_bvh: Option<Arc<Bvh>>,
    /// The visible set the BVHs were built from (visibility-driven builds only).
    visible_input: Option<Vec<TriangleRef>>,
    /// Triangles flagged visible in the camera and shadow BVHs' sets, and distinct triangles
    /// in each structure.
    camera_info: BvhInfo,
    shadow_info: Option<BvhInfo>,
    wide: Option<WideTrees>,
}

/// The collapsed trees of the cached BVHs for one width.
#[derive(Clone)]
struct WideTrees {
    width: BvhWidth,
    collapse: CollapseSettings,
    camera: Arc<WideTree>,
    /// `None`: the camera tree serves shadow rays too.
    shadow: Option<Arc<WideTree>>,
    /// Made once per tree, on the first frame that sorts per light.
    sort_tables: Option<SortTables>,
    /// A per-tree order (SATO, RTSAH, random) made once for the shadow tree and shared by the
    /// lights of every frame that reuses the tree.
    per_tree_order: Option<PerTreeOrder>,
    /// Collapse time, counted into the build time of the frame that collapsed.
    collapse_ms: Option<f64>,
}

#[derive(Clone)]
struct PerTreeOrder {
    order: ShadowOrder,
    prepared: PreparedOrder,
    /// Preparation time, reported (as the first shadow row's `sort_ms`) only by the frame
    /// that prepared it.
    ms: Option<f64>,
}

#[derive(Clone, Copy, Default)]
struct BvhInfo {
    visible: u64,
    triangles: u64,
}

/// What `prepare` did this frame.
#[derive(Clone, Copy)]
struct Prepared {
    rebuilt: bool,
    visibility_ms: f64,
}

/// Renders frames, keeping state across them.
/// Cloning copies the state (shared trees are reference counted): `compare` times a frame from
/// a copy of each method's state before it.
#[derive(Clone, Default)]
pub struct Renderer {
    cache: Option<Cached>,
    /// How many times a BVH was built.
    pub builds: u64,
    /// The visible set of the last rendered frame.
    pub previous_visible: Vec<TriangleRef>,
    /// Shadow rays traced by counted and timed passes so far (a warm-up traces none).
    pub shadow_rays: u64,
    /// Frames rendered (or warmed up) so far: the first has no previous visible set.
    frames_rendered: u64,
}

fn key_of(scene: &Scene) -> GeometryKey {
    GeometryKey {
        objects: scene
            .objects
            .iter()
            .map(|o| {
                (
                    Arc::as_ptr(&scene.meshes[o.mesh]) as usize,
                    o.world_from_object.to_cols_array().map(f64::to_bits),
                    o.visible_to_camera,
                    o.casts_shadow,
                )
            })
            .collect(),
    }
}

impl Renderer {
    pub fn new() -> Self {
        Self::default()
    }

    /// Renders one frame: geometry and trees, the primary pass, each light's shadow pass, and
    /// their combination. `scene_name` labels the statistics rows.
    pub fn render(
        &mut self,
        scene_name: &str,
        scene: &Scene,
        settings: &RenderSettings,
    ) -> Result<FrameResult> {
        self.render_cancellable(scene_name, scene, settings, &CancelToken::new())
    }

    /// As [`render`](Self::render), stopping with [`crate::Error::Cancelled`] soon after
    /// `cancel` is set: it is read per tile of every pass, between lights and between build
    /// stages. A cancelled render keeps only whole trees it finished, so the next render gives
    /// what a fresh renderer gives.
    pub fn render_cancellable(
        &mut self,
        scene_name: &str,
        scene: &Scene,
        settings: &RenderSettings,
        cancel: &CancelToken,
    ) -> Result<FrameResult> {
        settings.validate()?;
        scene.validate()?;
        cancel.check()?;
        let prepared = self.prepare(scene, settings, cancel)?;
        self.prepare_wide(settings, cancel)?;
        let cached = self.cache.as_ref().expect("prepared above");
        let rows = Rows {
            scene_name,
            scene,
            method: settings.method_name(),
            prepared,
            collapse_ms: cached
                .wide
                .as_ref()
                .and_then(|w| w.collapse_ms)
                .unwrap_or(0.0),
        };
        let (primary, primary_row) = primary_pass(cached, scene, settings, &rows, cancel)?;
        let shadows = shadow_passes(cached, &primary, scene, settings, &rows, cancel)?;
        self.shadow_rays += shadows.rays;
        let result = combine(scene, cached, primary, primary_row, shadows, settings);
        self.finish_frame(result.visible.clone());
        Ok(result)
    }

    /// Advances the state as [`render`](Self::render) would for this frame, for the frames
    /// after it only: the trees (built or reused, collapsed, per-tree orders prepared) and the
    /// visible set from an uncounted primary pass; no shadow ray, image or statistics row. A
    /// chunk of an animation warms up on the frames before its first, so its frames render
    /// what one run over the animation renders.
    pub fn warm_up(&mut self, scene: &Scene, settings: &RenderSettings) -> Result<WarmUp> {
        self.warm_up_cancellable(scene, settings, &CancelToken::new())
    }

    /// As [`warm_up`](Self::warm_up), stopping as [`render_cancellable`](Self::render_cancellable) does.
    pub fn warm_up_cancellable(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        cancel: &CancelToken,
    ) -> Result<WarmUp> {
        settings.validate()?;
        scene.validate()?;
        cancel.check()?;
        self.prepare(scene, settings, cancel)?;
        self.prepare_wide(settings, cancel)?;
        let cached = self.cache.as_ref().expect("prepared above");
        let primary = trace_camera(cached, scene, false, cancel)?;
        let ids: Vec<u32> = primary
            .surfaces
            .iter()
            .map(|s| s.map_or(u32::MAX, |s| s.triangle))
            .collect();
        let visible = visible_set(&ids, &cached.geometry.camera);
        self.finish_frame(visible.clone());
        Ok(WarmUp {
            frame: scene.frame,
            width: primary.width,
            height: primary.height,
            visible,
        })
    }

    /// What every finished frame (rendered or warmed up) hands to the next.
    fn finish_frame(&mut self, visible: Vec<TriangleRef>) {
        self.previous_visible = visible;
        self.frames_rendered += 1;
        self.mark_reported();
    }

    /// After a finished frame: the trees' build, collapse and per-tree order times have been
    /// reported, so frames that reuse them report none.
    fn mark_reported(&mut self) {
        let Some(c) = self.cache.as_mut() else { return };
        c.reported = true;
        if let Some(w) = &mut c.wide {
            w.collapse_ms = None;
            if let Some(p) = &mut w.per_tree_order {
                p.ms = None;
            }
        }
    }

    /// Builds geometry and BVHs unless the cached ones still hold: same geometry, same build
    /// settings and, for visibility-driven builds, the same visible-set input.
    fn prepare(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        cancel: &CancelToken,
    ) -> Result<Prepared> {
        let key = key_of(scene);
        let build_key = (settings.build, settings.build_settings);
        let reusable = self.cache.as_ref().filter(|c| c.key == key);
        // `render` validated the scene already.
        let geometry = match reusable {
            Some(c) => c.geometry.clone(),
            None => Arc::new(FrameGeometry::from_validated_scene(scene)),
        };
        let started = Instant::now();
        let visible_input = settings
            .build
            .uses_visibility()
            .then(|| self.visibility_input(scene, &geometry, settings));
        let visibility_ms = match &visible_input {
            Some(_) => started.elapsed().as_secs_f64() * 1e3,
            None => 0.0,
        };
        if let Some(c) = &self.cache {
            if c.key == key && c.build == build_key && c.visible_input == visible_input {
                return Ok(Prepared {
                    rebuilt: !c.reported,
                    visibility_ms,
                });
            }
        }
        cancel.check()?;
        let method = settings.build;
        let build_for = |set: &TriangleSet| {
            let flags = visible_input.as_ref().map(|v| visibility_flags(set, v));
            let bvh = build_with_visibility(
                method,
                &set.vertices,
                flags.as_deref(),
                &settings.build_settings,
            );
            let info = BvhInfo {
                visible: flags.map_or(0, |f| f.iter().filter(|v| **v).count() as u64),
                triangles: if method.is_complete() {
                    set.len() as u64
                } else {
                    bvh.triangles.len() as u64
                },
            };
            (bvh, info)
        };
        let (camera_bvh, camera_info) = build_for(&geometry.camera);
        cancel.check()?;
        // VSAH answers only the camera rays it was built for: shadow rays get a complete tree.
        let complete = |set: &TriangleSet| {
            let info = BvhInfo {
                visible: 0,
                triangles: set.len() as u64,
            };
            (
                build_binned_sah(&set.vertices, &settings.build_settings),
                info,
            )
        };
        let shadow = match (&geometry.shadow, method.is_complete()) {
            (Some(s), true) => Some(build_for(s)),
            (Some(s), false) => Some(complete(s)),
            (None, true) => None,
            (None, false) => Some(complete(&geometry.camera)),
        };
        let (shadow_bvh, shadow_info) = match shadow {
            Some((bvh, info)) => (Some(Arc::new(bvh)), Some(info)),
            None => (None, None),
        };
        self.builds += 1;
        self.cache = Some(Cached {
            key,
            _meshes: scene.meshes.clone(),
            build: build_key,
            reported: false,
            geometry,
            camera_bvh: Arc::new(camera_bvh),
            shadow_bvh,
            wide: None,
            visible_input,
            camera_info,
            shadow_info,
        });
        Ok(Prepared {
            rebuilt: true,
            visibility_ms,
        })
    }

    /// The visible set this frame's build reads: V(t-1) after the first frame; on the first,
    /// none or a low-resolution prepass; in exact mode this frame's own V(t).
    fn visibility_input(
        &self,
        scene: &Scene,
        geometry: &FrameGeometry,
        settings: &RenderSettings,
    ) -> Vec<TriangleRef> {
        let trace_at = |resolution: &Resolution| {
            // Any complete tree gives the same set; reuse this geometry's tree if there is one.
            let cached = self
                .cache
                .as_ref()
                .filter(|c| std::ptr::eq(&*c.geometry, geometry) && c.build.0.is_complete());
            match cached {
                Some(c) => trace_visible_set(scene, resolution, geometry, &c.camera_bvh),
                None => {
                    let bvh = build_binned_sah(&geometry.camera.vertices, &settings.build_settings);
                    trace_visible_set(scene, resolution, geometry, &bvh)
                }
            }
        };
        match settings.visibility {
            VisibilitySource::Exact => trace_at(&scene.resolution),
            _ if self.frames_rendered > 0 => self.previous_visible.clone(),
            VisibilitySource::Previous => Vec::new(),
            VisibilitySource::Prepass { width, height } => {
                trace_at(&Resolution::new(width, height))
            }
        }
    }

    /// Collapses the cached BVHs to the settings' width when a pass will read a wide tree, and
    /// makes the sorting tables when the order sorts per light. Reuses what the cache holds;
    /// each piece is stored whole, so a cancel between them leaves the cache consistent.
    fn prepare_wide(&mut self, settings: &RenderSettings, cancel: &CancelToken) -> Result<()> {
        let Some(c) = self.cache.as_mut() else {
            return Ok(());
        };
        let srdh = matches!(settings.shadow_order, ShadowOrder::Srdh(_));
        let needed = settings.width != BvhWidth::Two
            || (binary_order(settings.width, &settings.shadow_order).is_none() && !srdh);
        if !needed {
            return Ok(());
        }
        if c.wide.as_ref().map(|w| (w.width, w.collapse))
            != Some((settings.width, settings.collapse))
        {
            let camera = WideTree::collapse(&c.camera_bvh, settings.width, &settings.collapse);
            let shadow = c
                .shadow_bvh
                .as_ref()
                .map(|b| WideTree::collapse(b, settings.width, &settings.collapse));
            let collapse_ms =
                camera.collapse_ms() + shadow.as_ref().map_or(0.0, |s| s.collapse_ms());
            c.wide = Some(WideTrees {
                width: settings.width,
                collapse: settings.collapse,
                camera: Arc::new(camera),
                shadow: shadow.map(Arc::new),
                sort_tables: None,
                per_tree_order: None,
                collapse_ms: Some(collapse_ms),
            });
            cancel.check()?;
        }
        let w = c.wide.as_mut().expect("collapsed above");
        let tree = w.shadow.as_ref().unwrap_or(&w.camera);
        if matches!(settings.shadow_order, ShadowOrder::Sorted(_)) && w.sort_tables.is_none() {
            w.sort_tables = Some(tree.sort_tables());
        }
        let order = &settings.shadow_order;
        if order.is_per_tree() && w.per_tree_order.as_ref().map(|p| &p.order) != Some(order) {
            cancel.check()?;
            let start = Instant::now();
            let prepared = tree.prepare(order, None, &[]);
            w.per_tree_order = Some(PerTreeOrder {
                order: *order,
                prepared,
                ms: Some(start.elapsed().as_secs_f64() * 1e3),
            });
        }
        Ok(())
    }

    /// The geometry and BVHs of the last frame (for tests and tools that trace their own rays).
    pub fn current(&self) -> Option<(&FrameGeometry, &Bvh, &Bvh)> {
        self.cache.as_ref().map(|c| {
            let shadow = c.shadow_bvh.as_deref().unwrap_or(&c.camera_bvh);
            (&*c.geometry, &*c.camera_bvh, shadow)
        })
    }
}

/// What every statistics row of a frame shares.
struct Rows<'a> {
    scene_name: &'a str,
    scene: &'a Scene,
    method: String,
    prepared: Prepared,
    collapse_ms: f64,
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
fn primary_pass(
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
fn trace_camera(
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
fn counted_timed(settings: &RenderSettings) -> (bool, bool) {
    (
        settings.stats != StatsMode::TimingOnly,
        settings.stats != StatsMode::Counts,
    )
}

/// The shadow passes of a frame: per light, a mask and a statistics row; the summed work per
/// pixel over lights when counting.
struct ShadowPasses {
    masks: Vec<ImagePlane>,
    rows: Vec<StatsRow>,
    work: Vec<TraversalStats>,
    /// Shadow rays traced, over every pass (counted and timed).
    rays: u64,
}

/// Each shadow-casting light in turn: its tree and order ([`light_tracing`]), its shadow pass
/// and its row.
fn shadow_passes(
    cached: &Cached,
    primary: &PrimaryPass,
    scene: &Scene,
    settings: &RenderSettings,
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
        rays: 0,
    };
    for (index, light) in scene.lights.iter().enumerate() {
        if !light.casts_shadow {
            continue;
        }
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
            first: out.rows.is_empty(),
        };
        let tracing = light_tracing(&trees, &settings.shadow_order, settings.width, &light_rays);
        cancel.check()?;
        let tracer = tracing.tracer();
        let pass_of = |counted: bool| {
            let (i, spp, seed) = (plan.light_index, plan.samples, plan.seed);
            if counted {
                ShadowPass::counted_cancellable(primary, &tracer, &sampler, i, spp, seed, cancel)
            } else {
                ShadowPass::timed_cancellable(primary, &tracer, &sampler, i, spp, seed, cancel)
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
        out.rows.push(r);
        out.masks.push(pass.mask);
    }
    Ok(out)
}

/// The frame's result: the masks and their mean, heat maps when counting, the primary hits
/// and the visible set.
fn combine(
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
    tree: &impl ClosestHitQuery,
    triangles: &crate::scene::TriangleSet,
    cancel: &CancelToken,
) -> Result<PrimaryPass> {
    if counted {
        PrimaryPass::counted_cancellable(rays, tree, triangles, cancel)
    } else {
        PrimaryPass::timed_cancellable(rays, tree, triangles, cancel)
    }
}
