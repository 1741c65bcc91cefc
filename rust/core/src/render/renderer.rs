//! One frame end to end, and what carries over between frames: the geometry and BVHs of a frame
//! whose geometry (and, for visibility-driven builds, visible-set input) did not change are
//! reused, and the visible set is kept for the next frame's OSAH/ABVH build. A warm-up
//! ([`Renderer::warm_up`]) advances that state as a render would, tracing no shadow ray.

use std::sync::Arc;
use std::time::Instant;

use super::frame_alpha::{AlphaCache, AlphaFrameStats, FrameAlpha};
use super::frame_trees::{BvhInfo, FrameTrees, GeometryKey, Prepared};
use super::passes::{combine, counted_timed, primary_pass, shadow_passes, trace_camera, Rows};
use super::policy::{mark_build_row, mark_two_level_rows, planned_orders, BuildPlan, Policy};
use super::scene_trees::SceneTrees;
use super::two_level_trees::TwoLevelTrees;
use super::visibility::{trace_visible_set, visibility_flags, visible_set};
use super::VisibilitySource;
use super::{RenderSettings, SceneStructure};
use crate::build::{build_binned_sah, build_with_visibility, BuildMethod};
use crate::bvh::Bvh;
use crate::cancel::CancelToken;
use crate::image::ImagePlane;
use crate::scene::{FrameGeometry, Resolution, Scene, TriangleRef, TriangleSet};
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
    /// The object and mesh triangle each pixel's primary ray hit ([`TriangleRef::MISS`] where it
    /// missed): the same on every tree and structure.
    pub primary_hits: Vec<TriangleRef>,
    /// The scene structure the frame traced.
    pub structure: SceneStructure,
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

/// Renders frames, keeping state across them: the frame's trees while their key holds, the
/// visible set for the next frame's build, and what the policy learned.
/// Cloning copies the state (shared trees are reference counted): `compare` times a frame from
/// a copy of each method's state before it.
#[derive(Clone, Default)]
pub struct Renderer {
    trees: Option<SceneTrees>,
    /// How many times a BVH was built.
    pub builds: u64,
    /// The visible set of the last rendered frame.
    pub previous_visible: Vec<TriangleRef>,
    /// Shadow rays traced by counted and timed passes so far (a warm-up traces none).
    pub shadow_rays: u64,
    /// Frames rendered (or warmed up) so far: the first has no previous visible set.
    frames_rendered: u64,
    /// Chooses the build and the lights' orders (fixed, or `auto` from measured work).
    policy: Policy,
    /// The last frame's alpha and what it was made from.
    alpha_cache: Option<AlphaCache>,
    /// The last rendered frame's alpha lookups.
    alpha_stats: Option<AlphaFrameStats>,
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
        let frame = self.frames_rendered;
        let (build, prepared) = self.prepare_trees(scene, settings, cancel)?;
        let alpha = self.frame_alpha(scene, settings)?;
        let alpha = alpha.as_deref();
        let trees = self
            .trees
            .as_mut()
            .expect("prepare leaves the frame's trees");
        let rows = Rows {
            scene_name,
            scene,
            method: settings.method_name(),
            prepared,
            collapse_ms: trees.flat().map_or(0.0, FrameTrees::collapse_ms),
        };
        let (primary, mut primary_row, primary_heat) =
            primary_pass(trees, scene, settings, alpha, &rows, cancel)?;
        self.policy
            .note_frame(scene, settings, trees.space(), &primary);
        let lights = self
            .policy
            .plan_lights(scene, &primary, settings, trees, frame);
        if let SceneTrees::Flat(t) = trees {
            t.prepare_orders(&planned_orders(&lights), cancel)?;
        }
        let shadows = shadow_passes(
            trees, &primary, scene, settings, &lights, alpha, &rows, cancel,
        )?;
        self.alpha_stats = alpha.map(|_| AlphaFrameStats {
            frame: scene.frame,
            primary: primary.alpha_lookups,
            shadow: shadows.alpha_lookups.clone(),
        });
        mark_build_row(&mut primary_row, &build);
        if counted_timed(settings).0 {
            let measured = &shadows.measured;
            (self.policy).learn(&build, &primary, &lights, measured, settings, frame);
        }
        self.shadow_rays += shadows.rays;
        let mut result = combine(scene, trees, primary, primary_row, primary_heat, shadows);
        if let Some(stats) = &self.alpha_stats {
            stats.fill_rows(&mut result.stats);
        }
        if result.structure == SceneStructure::TwoLevel {
            mark_two_level_rows(&mut result.stats, settings);
        }
        self.finish_frame(result.visible.clone());
        Ok(result)
    }

    /// The frame's alpha when it traces through alpha, on the trees just prepared (a flat
    /// frame's kept while its inputs hold); `None` when nothing is flagged.
    fn frame_alpha(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
    ) -> Result<Option<Arc<FrameAlpha>>> {
        if !settings.alpha_active(scene) {
            return Ok(None);
        }
        let (max_hits, clip) = (settings.shadow_max_hits(), settings.alpha_clip);
        let alpha = match self.trees.as_ref() {
            Some(SceneTrees::Flat(t)) => {
                AlphaCache::get(&mut self.alpha_cache, scene, &t.geometry, max_hits, clip)?
            }
            Some(SceneTrees::TwoLevel(t)) => {
                Arc::new(FrameAlpha::two_level(scene, t, max_hits, clip)?)
            }
            None => unreachable!("the frame's trees are prepared before its alpha"),
        };
        // Without a flagged triangle the passes call the opaque code, as for an opaque scene.
        Ok((!alpha.flags_nothing()).then_some(alpha))
    }

    /// The alpha lookups of the last rendered frame, `None` when it traced no alpha (alpha
    /// off, or no triangle with an alpha material).
    pub fn alpha_stats(&self) -> Option<&AlphaFrameStats> {
        self.alpha_stats.as_ref()
    }

    /// The frame's trees in the structure the policy picks: a flat frame's built with the
    /// planned method (or kept), collapsed and with its per-tree orders; a two-level frame's
    /// mesh trees kept or built and its top levels.
    fn prepare_trees(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        cancel: &CancelToken,
    ) -> Result<(BuildPlan, Prepared)> {
        match self.policy.plan_structure(scene, settings) {
            SceneStructure::Flat => {
                let flat = self.trees.as_ref().and_then(SceneTrees::flat);
                let build = (self.policy).plan_build(scene, settings, flat, self.frames_rendered);
                let prepared = self.prepare(scene, settings, &build, cancel)?;
                if let Some(SceneTrees::Flat(t)) = self.trees.as_mut() {
                    t.collapse(settings, cancel)?;
                }
                Ok((build, prepared))
            }
            SceneStructure::TwoLevel => {
                let previous = self.trees.as_ref().and_then(SceneTrees::two_level);
                let changes = &self.policy.changes;
                let trees = TwoLevelTrees::prepare(previous, scene, settings, changes, cancel)?;
                if trees.meshes_built() > 0 || previous.is_none_or(|p| !p.same_tops(&trees)) {
                    self.builds += 1;
                }
                let prepared = Prepared {
                    rebuilt: !trees.reported,
                    visibility_ms: 0.0,
                };
                self.trees = Some(SceneTrees::TwoLevel(trees));
                Ok((BuildPlan::fixed(BuildMethod::Sah), prepared))
            }
        }
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
        self.prepare_trees(scene, settings, cancel)?;
        let alpha = self.frame_alpha(scene, settings)?;
        let trees = self
            .trees
            .as_ref()
            .expect("prepare leaves the frame's trees");
        let primary = trace_camera(trees, scene, settings, alpha.as_deref(), false, cancel)?;
        self.policy
            .note_frame(scene, settings, trees.space(), &primary);
        let visible = visible_set(
            &primary.surfaces,
            trees.flat().map(|t| &t.geometry().camera),
        );
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
        // The trees' build, collapse and per-tree order times have been reported, so frames
        // that reuse them report none.
        if let Some(t) = self.trees.as_mut() {
            t.mark_reported();
        }
    }

    /// Builds geometry and BVHs with the plan's method unless the kept ones still hold: same
    /// geometry, same build settings and, for visibility-driven builds, the same visible-set
    /// input (or `auto` keeps last frame's trees whatever visible set a build would read).
    fn prepare(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        build: &BuildPlan,
        cancel: &CancelToken,
    ) -> Result<Prepared> {
        let key = GeometryKey::of(scene);
        let flat = self.trees.as_ref().and_then(SceneTrees::flat);
        if let Some(t) = flat.filter(|t| build.keep && t.key == key) {
            return Ok(Prepared {
                rebuilt: !t.reported,
                visibility_ms: 0.0,
            });
        }
        let method = build.method;
        let build_key = (method, settings.build_settings);
        let reusable = flat.filter(|t| t.key == key);
        // `render` validated the scene already.
        let geometry = match reusable {
            Some(t) => t.geometry.clone(),
            None => Arc::new(FrameGeometry::from_validated_scene(scene)),
        };
        let started = Instant::now();
        let visible_input = method
            .uses_visibility()
            .then(|| self.visibility_input(scene, &geometry, settings));
        let visibility_ms = match &visible_input {
            Some(_) => started.elapsed().as_secs_f64() * 1e3,
            None => 0.0,
        };
        if let Some(t) = self.trees.as_ref().and_then(SceneTrees::flat) {
            if t.key == key && t.build == build_key && t.visible_input == visible_input {
                return Ok(Prepared {
                    rebuilt: !t.reported,
                    visibility_ms,
                });
            }
        }
        cancel.check()?;
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
        let camera = build_for(&geometry.camera);
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
        self.builds += 1;
        self.trees = Some(SceneTrees::Flat(FrameTrees::new(
            scene,
            key,
            build_key,
            geometry,
            camera,
            shadow,
            visible_input,
        )));
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
            let kept = self
                .trees
                .as_ref()
                .and_then(SceneTrees::flat)
                .filter(|t| std::ptr::eq(&*t.geometry, geometry) && t.build.0.is_complete());
            match kept {
                Some(t) => trace_visible_set(scene, resolution, geometry, &t.camera_bvh),
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

    /// The flat trees of the last frame, if it was flat (for tests and tools that trace
    /// their own rays).
    pub fn trees(&self) -> Option<&FrameTrees> {
        self.trees.as_ref().and_then(SceneTrees::flat)
    }

    /// The last frame's trees, flat or two-level.
    pub fn scene_trees(&self) -> Option<&SceneTrees> {
        self.trees.as_ref()
    }

    /// The geometry and BVHs of the last frame, if it was flat (for tests and tools that trace
    /// their own rays).
    pub fn current(&self) -> Option<(&FrameGeometry, &Bvh, &Bvh)> {
        self.trees()
            .map(|t| (t.geometry(), t.camera_bvh(), t.shadow_bvh()))
    }
}
