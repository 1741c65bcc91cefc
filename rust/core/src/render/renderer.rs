//! One frame end to end, and what carries over between frames: the geometry and BVHs of a frame
//! whose geometry (and, for visibility-driven builds, visible-set input) did not change are
//! reused, and the visible set is kept for the next frame's OSAH/ABVH build. A warm-up
//! ([`Renderer::warm_up`]) advances that state as a render would, tracing no shadow ray.

use std::sync::Arc;
use std::time::Instant;

use super::auto::{self, BuildChoice, Choice, History};
use super::light_tracer::binary_order;
use super::passes::{
    combine, counted_timed, primary_pass, shadow_passes, trace_camera, LightOrder, Rows,
    ShadowPasses,
};
use super::shadow::samples_for;
use super::visibility::{trace_visible_set, visibility_flags, visible_set};
use super::wide_tree::WideTree;
use super::VisibilitySource;
use super::{LightSampler, PrimaryPass, RenderSettings};
use crate::build::{build_binned_sah, build_with_visibility, BuildMethod, CollapseSettings};
use crate::bvh::{Bvh, BvhWidth};
use crate::cancel::CancelToken;
use crate::image::ImagePlane;
use crate::order::{PreparedOrder, ShadowOrder, SortTables};
use crate::scene::{FrameGeometry, Mesh, Resolution, Scene, TriangleRef, TriangleSet};
use crate::stats::StatsRow;
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
pub(super) struct Cached {
    key: GeometryKey,
    /// Keeps the meshes alive so their addresses in the key cannot be reused.
    _meshes: Vec<Arc<Mesh>>,
    build: (crate::build::BuildMethod, crate::build::BuildSettings),
    /// Whether a finished frame has reported these trees' build (a cancelled render leaves
    /// the report to the next render that uses them, so it reads as a fresh render's).
    reported: bool,
    pub(super) geometry: Arc<FrameGeometry>,
    pub(super) camera_bvh: Arc<Bvh>,
    pub(super) shadow_bvh: Option<Arc<Bvh>>,
    /// The visible set the BVHs were built from (visibility-driven builds only).
    visible_input: Option<Vec<TriangleRef>>,
    /// Triangles flagged visible in the camera and shadow BVHs' sets, and distinct triangles
    /// in each structure.
    pub(super) camera_info: BvhInfo,
    pub(super) shadow_info: Option<BvhInfo>,
    pub(super) wide: Option<WideTrees>,
}

/// The collapsed trees of the cached BVHs for one width.
#[derive(Clone)]
pub(super) struct WideTrees {
    pub(super) width: BvhWidth,
    pub(super) collapse: CollapseSettings,
    pub(super) camera: Arc<WideTree>,
    /// `None`: the camera tree serves shadow rays too.
    pub(super) shadow: Option<Arc<WideTree>>,
    /// Made once per tree, on the first frame that sorts per light.
    pub(super) sort_tables: Option<SortTables>,
    /// A per-tree order (SATO, RTSAH, random) made once for the shadow tree and shared by the
    /// lights of every frame that reuses the tree.
    pub(super) per_tree_order: Option<PerTreeOrder>,
    /// Collapse time, counted into the build time of the frame that collapsed.
    pub(super) collapse_ms: Option<f64>,
}

#[derive(Clone)]
pub(super) struct PerTreeOrder {
    pub(super) order: ShadowOrder,
    pub(super) prepared: PreparedOrder,
    /// Preparation time, reported (as the first shadow row's `sort_ms`) only by the frame
    /// that prepared it.
    pub(super) ms: Option<f64>,
}

#[derive(Clone, Copy, Default)]
pub(super) struct BvhInfo {
    pub(super) visible: u64,
    pub(super) triangles: u64,
}

/// What `prepare` did this frame.
#[derive(Clone, Copy)]
pub(super) struct Prepared {
    pub(super) rebuilt: bool,
    pub(super) visibility_ms: f64,
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
    /// What `auto` measured on the counted frames so far.
    auto: History,
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
        let at = self.moment(settings);
        let (build_choice, concrete, keep) = self.concrete_build(scene, settings, at);
        let prepared = self.prepare(scene, &concrete, keep, cancel)?;
        self.prepare_wide(&concrete, cancel)?;
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
        let (primary, mut primary_row) = primary_pass(cached, scene, settings, &rows, cancel)?;
        let orders = self.light_orders(scene, &primary, settings, at, cancel)?;
        let cached = self.cache.as_ref().expect("prepared above");
        let shadows = shadow_passes(cached, &primary, scene, settings, &orders, &rows, cancel)?;
        self.shadow_rays += shadows.rays;
        if let Some(c) = &build_choice {
            auto::mark_row(&mut primary_row, c, |b| b.name());
        }
        if counted_timed(settings).0 {
            self.learn(
                build_choice,
                &primary,
                &orders,
                &shadows,
                settings,
                at.frame,
            );
        }
        let cached = self.cache.as_ref().expect("prepared above");
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
        // `auto` chooses as a render would from what it learned; a warm-up teaches it nothing.
        let at = self.moment(settings);
        let (_, concrete, keep) = self.concrete_build(scene, settings, at);
        self.prepare(scene, &concrete, keep, cancel)?;
        self.prepare_wide(&concrete, cancel)?;
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

    fn moment(&self, settings: &RenderSettings) -> auto::Moment {
        auto::Moment {
            seed: settings.seed,
            frame: self.frames_rendered,
        }
    }

    /// The frame's build: `settings.build`, or what `auto` chooses (then with its choice, and
    /// whether it keeps last frame's trees).
    fn concrete_build(
        &self,
        scene: &Scene,
        settings: &RenderSettings,
        at: auto::Moment,
    ) -> (Option<Choice<BuildChoice>>, RenderSettings, bool) {
        let build_choice =
            (settings.build == BuildMethod::Auto).then(|| self.choose_build(scene, settings, at));
        let concrete = RenderSettings {
            build: match build_choice.map(|c| c.choice) {
                None => settings.build,
                Some(BuildChoice::Sah) => BuildMethod::Sah,
                Some(BuildChoice::Osah) => BuildMethod::Osah,
                Some(BuildChoice::Keep) => {
                    self.cache.as_ref().map_or(BuildMethod::Sah, |c| c.build.0)
                }
            },
            ..settings.clone()
        };
        let keep = build_choice.is_some_and(|c| c.choice == BuildChoice::Keep);
        (build_choice, concrete, keep)
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
        keep: bool,
        cancel: &CancelToken,
    ) -> Result<Prepared> {
        let key = key_of(scene);
        // `auto` keeps last frame's trees, whatever visible set the next build would read.
        if let Some(c) = self.cache.as_ref().filter(|c| keep && c.key == key) {
            return Ok(Prepared {
                rebuilt: !c.reported,
                visibility_ms: 0.0,
            });
        }
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
        // `auto` at width 2 picks among the binary tree's orders (front to back, SRDH).
        let srdh = matches!(
            settings.shadow_order,
            ShadowOrder::Srdh(_) | ShadowOrder::Auto
        );
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
        self.prepare_orders(std::slice::from_ref(&settings.shadow_order), cancel)
    }

    /// Makes, once per wide tree, what the lights' `orders` read: the sorting tables and a
    /// per-tree order (one per tree: the lights' orders hold at most one kind).
    fn prepare_orders(&mut self, orders: &[ShadowOrder], cancel: &CancelToken) -> Result<()> {
        let Some(w) = self.cache.as_mut().and_then(|c| c.wide.as_mut()) else {
            return Ok(());
        };
        let tree = w.shadow.as_ref().unwrap_or(&w.camera);
        let sorted = orders.iter().any(|o| matches!(o, ShadowOrder::Sorted(_)));
        if sorted && w.sort_tables.is_none() {
            w.sort_tables = Some(tree.sort_tables());
        }
        let per_tree = orders.iter().find(|o| o.is_per_tree());
        if let Some(order) =
            per_tree.filter(|o| w.per_tree_order.as_ref().map(|p| &p.order) != Some(*o))
        {
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

    /// `auto`'s camera tree for this frame, from what earlier frames measured.
    fn choose_build(
        &self,
        scene: &Scene,
        settings: &RenderSettings,
        at: auto::Moment,
    ) -> Choice<BuildChoice> {
        let (w, h) = scene.resolution.pixels();
        let cached = self.cache.as_ref();
        let context = auto::BuildContext {
            rays: w as u64 * h as u64,
            triangles: auto::scene_triangles(scene),
            unchanged: cached.is_some_and(|c| c.key == key_of(scene)),
            current: cached.and_then(|c| match c.build.0 {
                BuildMethod::Sah => Some(BuildChoice::Sah),
                BuildMethod::Osah => Some(BuildChoice::Osah),
                _ => None,
            }),
            visible: self.frames_rendered > 0 || settings.visibility != VisibilitySource::Previous,
            wide: settings.width != BvhWidth::Two,
        };
        auto::choose_build(&self.auto, &context, at)
    }

    /// Each shadow-casting light's order this frame: the settings' own, or `auto`'s choice
    /// (with what that choice needs of the wide tree made).
    fn light_orders(
        &mut self,
        scene: &Scene,
        primary: &PrimaryPass,
        settings: &RenderSettings,
        at: auto::Moment,
        cancel: &CancelToken,
    ) -> Result<Vec<LightOrder>> {
        let lights = scene.lights.iter().filter(|l| l.casts_shadow);
        if settings.shadow_order != ShadowOrder::Auto {
            return Ok(lights
                .map(|_| LightOrder {
                    order: settings.shadow_order,
                    auto: None,
                    sample: None,
                })
                .collect());
        }
        let c = self.cache.as_ref().expect("prepared before the passes");
        let geometry = &c.geometry;
        let wide = c.wide.as_ref().filter(|_| settings.width != BvhWidth::Two);
        let surfaces = primary.surfaces.iter().flatten().count() as u64;
        let mut out = Vec::new();
        for (index, light) in scene
            .lights
            .iter()
            .enumerate()
            .filter(|(_, l)| l.casts_shadow)
        {
            let sampler = LightSampler::new(light, &geometry.space);
            let rays = auto::light_rays(primary, &sampler, settings.spp);
            let samples = samples_for(&sampler, settings.spp) as u64;
            let (log_rays, srdh_rays) = auto::prep_rays(rays, surfaces, samples);
            let context = auto::LightContext {
                name: &light.name,
                index: index as u32,
                rays,
                wide: wide.is_some(),
                wide_nodes: wide.map_or(0, |w| {
                    w.shadow.as_ref().unwrap_or(&w.camera).node_count() as u64
                }),
                triangles: geometry.shadow.as_ref().unwrap_or(&geometry.camera).len() as u64,
                srdh_rays,
                log_rays,
                sato_ready: wide
                    .and_then(|w| w.per_tree_order.as_ref())
                    .is_some_and(|p| p.order == ShadowOrder::Sato),
                tables_ready: wide.is_some_and(|w| w.sort_tables.is_some()),
            };
            let plan = auto::choose_order(&self.auto, &context, at);
            out.push(LightOrder {
                order: plan.choice.choice.order(),
                auto: Some(plan.choice),
                sample: plan.sample,
            });
        }
        let orders: Vec<ShadowOrder> = out
            .iter()
            .flat_map(|o| std::iter::once(o.order).chain(o.sample.map(|s| s.order())))
            .collect();
        self.prepare_orders(&orders, cancel)?;
        Ok(out)
    }

    /// Records what a counted frame measured for `auto`'s next choices.
    fn learn(
        &mut self,
        build: Option<Choice<BuildChoice>>,
        primary: &PrimaryPass,
        orders: &[LightOrder],
        shadows: &ShadowPasses,
        settings: &RenderSettings,
        frame: u64,
    ) {
        let wide = settings.width != BvhWidth::Two;
        if let Some(b) = build {
            let kernel = auto::Kernel::camera(wide);
            let rays = primary.ray_count();
            if let Some(m) = auto::measured(kernel, &primary.totals, rays, frame, true) {
                self.auto.record_build(b.choice, m);
            }
        }
        for ((o, row), (totals, own_tree, sampled)) in
            orders.iter().zip(&shadows.rows).zip(&shadows.measured)
        {
            let Some(choice) = o.auto else { continue };
            let kernel = choice.choice.kernel(wide);
            if let Some(m) = auto::measured(kernel, totals, row.rays, frame, *own_tree) {
                self.auto.record_order(&row.light, choice.choice, m);
            }
            let sample = o.sample.zip(*sampled);
            if let Some((order, (work, rays))) = sample {
                let kernel = order.kernel(wide);
                if let Some(m) = auto::measured(kernel, &work, rays, frame, false) {
                    self.auto.record_order(&row.light, order, m);
                }
            }
        }
    }

    /// The geometry and BVHs of the last frame (for tests and tools that trace their own rays).
    pub fn current(&self) -> Option<(&FrameGeometry, &Bvh, &Bvh)> {
        self.cache.as_ref().map(|c| {
            let shadow = c.shadow_bvh.as_deref().unwrap_or(&c.camera_bvh);
            (&*c.geometry, &*c.camera_bvh, shadow)
        })
    }
}
