//! The [`Policy`]: what a frame renders with, chosen before its passes run (the camera tree's
//! build, then each shadow-casting light's order, hence its tree and kernel), and what it learns
//! from the passes' measurements afterwards. A fixed setting passes through; `auto`
//! (`render/auto`, docs/auto.md) chooses from the work measured on earlier frames. The passes
//! read the plans, never the policy.

use super::auto::{self, BuildChoice, Choice, History, OrderChoice};
use super::frame_trees::{FrameTrees, GeometryKey};
use super::object_changes::ObjectChanges;
use super::scene_trees::SceneTrees;
use super::shadow::samples_for;
use super::{LightSampler, Pick, PrimaryPass, RenderSettings, SceneStructure, VisibilitySource};
use crate::build::BuildMethod;
use crate::bvh::BvhWidth;
use crate::order::ShadowOrder;
use crate::scene::{RenderSpace, Scene};
use crate::stats::StatsRow;
use crate::trace::{RayMode, TraversalStats};

/// The frame's camera tree: its builder, and whether last frame's trees are kept as they are.
#[derive(Clone, Copy)]
pub(super) struct BuildPlan {
    pub(super) method: BuildMethod,
    pub(super) keep: bool,
    /// `auto`'s choice behind it.
    pub(super) auto: Option<Choice<BuildChoice>>,
}

/// One shadow-casting light's order this frame, and `auto`'s choice behind it.
pub(super) struct LightPlan {
    pub(super) order: ShadowOrder,
    /// Single rays or packets for the light's pass.
    pub(super) rays: RayMode,
    pub(super) auto: Option<Choice<OrderChoice>>,
    /// An order `auto` measures on a sample of the light's rays.
    pub(super) sample: Option<OrderChoice>,
}

impl BuildPlan {
    /// A fixed build, nothing kept, no `auto` choice behind it.
    pub(super) fn fixed(method: BuildMethod) -> Self {
        BuildPlan {
            method,
            keep: false,
            auto: None,
        }
    }
}

impl LightPlan {
    /// Every order the light's pass traces (its own and its sample's).
    fn orders(&self) -> impl Iterator<Item = ShadowOrder> + '_ {
        std::iter::once(self.order).chain(self.sample.map(|s| s.order()))
    }
}

/// What one light's shadow pass measured for the policy.
pub(super) struct LightMeasurement {
    /// The light's key in `auto`'s history ([`SceneTrees::history_key`]), and its rays.
    pub(super) light: String,
    pub(super) rays: u64,
    /// The work of its rays.
    pub(super) work: TraversalStats,
    /// Whether it traced a tree of its own (SRDH).
    pub(super) own_tree: bool,
    /// The work and the rays of `auto`'s sample, if it took one.
    pub(super) sampled: Option<(TraversalStats, u64)>,
}

/// The renderer's policy: what `auto` remembers across frames (nothing is learned while the
/// settings fix both choices).
#[derive(Clone, Default)]
pub(super) struct Policy {
    history: History,
    /// Which objects have changed so far (two levels and `auto`'s structure read it).
    pub(super) changes: ObjectChanges,
    /// The rays of the last frame, rendered or warmed up ([`auto::frame_rays`]).
    last_rays: u64,
    /// The structure `auto` chose for the last frame.
    structure: Option<SceneStructure>,
}

impl Policy {
    /// The frame's structure: the setting, or `auto`'s rules ([`auto_structure`], then
    /// [`auto::choose_structure`]), after noting which objects changed since the last frame.
    pub(super) fn plan_structure(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
    ) -> SceneStructure {
        let change = self.changes.advance(scene);
        let chosen = match settings.structure {
            Pick::Fixed(s) => return s,
            Pick::Auto => match auto_structure(scene, settings) {
                SceneStructure::Flat if weighs_moving_parts(settings) => {
                    auto::choose_structure(&auto::StructureContext {
                        kept_triangles: change.kept_triangles,
                        moved: change.moved,
                        rays: self.last_rays,
                        current: self.structure,
                    })
                }
                s => s,
            },
        };
        self.structure = Some(chosen);
        chosen
    }

    /// Notes a frame's rays (rendered or warmed up) for the next frame's structure: counted
    /// from its primary pass alike, so a warm-up leaves what a render does.
    pub(super) fn note_frame(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        space: &RenderSpace,
        primary: &PrimaryPass,
    ) {
        if weighs_moving_parts(settings) {
            self.last_rays = auto::frame_rays(scene, space, primary, settings.spp);
        }
    }

    /// The frame's build: the settings' own, or `auto`'s choice from what earlier frames
    /// measured (`frames_rendered` of them, on `trees`).
    pub(super) fn plan_build(
        &self,
        scene: &Scene,
        settings: &RenderSettings,
        trees: Option<&FrameTrees>,
        frames_rendered: u64,
    ) -> BuildPlan {
        let method = match settings.build {
            Pick::Fixed(method) => return BuildPlan::fixed(method),
            Pick::Auto => self.choose_build(scene, settings, trees, frames_rendered),
        };
        BuildPlan {
            method: match method.choice {
                BuildChoice::Sah => BuildMethod::Sah,
                BuildChoice::Osah => BuildMethod::Osah,
                BuildChoice::Keep => trees.map_or(BuildMethod::Sah, |t| t.build.0),
            },
            keep: method.choice == BuildChoice::Keep,
            auto: Some(method),
        }
    }

    fn choose_build(
        &self,
        scene: &Scene,
        settings: &RenderSettings,
        trees: Option<&FrameTrees>,
        frames_rendered: u64,
    ) -> Choice<BuildChoice> {
        // Trees a cancelled render left are not an earlier frame's: auto chooses as a fresh
        // renderer would (and a build over the same key reuses them anyway).
        let trees = trees.filter(|t| t.reported);
        let (w, h) = scene.resolution.pixels();
        let context = auto::BuildContext {
            rays: w as u64 * h as u64,
            triangles: auto::scene_triangles(scene),
            unchanged: trees.is_some_and(|t| t.key == GeometryKey::of(scene)),
            current: trees.and_then(|t| match t.build.0 {
                BuildMethod::Sah => Some(BuildChoice::Sah),
                BuildMethod::Osah => Some(BuildChoice::Osah),
                _ => None,
            }),
            visible: frames_rendered > 0 || settings.visibility != VisibilitySource::Previous,
            wide: settings.width != BvhWidth::Two,
        };
        auto::choose_build(&self.history, &context, moment(settings, frames_rendered))
    }

    /// Each shadow-casting light's order this frame: the settings' own, or `auto`'s choice
    /// from the primary pass's surfaces and the frame's trees.
    pub(super) fn plan_lights(
        &self,
        scene: &Scene,
        primary: &PrimaryPass,
        settings: &RenderSettings,
        trees: &SceneTrees,
        frames_rendered: u64,
    ) -> Vec<LightPlan> {
        let lights = scene
            .lights
            .iter()
            .enumerate()
            .filter(|(_, l)| l.casts_shadow);
        if let Pick::Fixed(order) = settings.shadow_order {
            return lights
                .map(|_| LightPlan {
                    order,
                    rays: pass_rays(settings),
                    auto: None,
                    sample: None,
                })
                .collect();
        }
        let at = moment(settings, frames_rendered);
        let shadow = ShadowTreesSummary::of(trees, settings);
        let surfaces = primary.surfaces.iter().flatten().count() as u64;
        lights
            .map(|(index, light)| {
                let key = trees.history_key(&light.name);
                let sampler = LightSampler::new(light, trees.space());
                let rays = auto::light_rays(primary, &sampler, settings.spp);
                let samples = samples_for(&sampler, settings.spp) as u64;
                let (log_rays, srdh_rays) = auto::prep_rays(rays, surfaces, samples);
                let context = auto::LightContext {
                    name: &key,
                    index: index as u32,
                    rays,
                    wide: shadow.wide,
                    wide_nodes: shadow.wide_nodes,
                    triangles: shadow.srdh_primitives,
                    srdh_rays,
                    log_rays,
                    sato_ready: shadow.sato_ready,
                    tables_ready: shadow.tables_ready,
                };
                let plan = auto::choose_order(&self.history, &context, at);
                LightPlan {
                    order: plan.choice.choice.order(),
                    rays: pass_rays(settings),
                    auto: Some(plan.choice),
                    sample: plan.sample,
                }
            })
            .collect()
    }

    /// Records what a counted frame measured for `auto`'s next choices.
    pub(super) fn learn(
        &mut self,
        build: &BuildPlan,
        primary: &PrimaryPass,
        lights: &[LightPlan],
        measured: &[LightMeasurement],
        settings: &RenderSettings,
        frame: u64,
    ) {
        let wide = settings.width != BvhWidth::Two;
        if let Some(b) = build.auto {
            let kernel = auto::Traversal::camera(wide);
            let rays = primary.ray_count();
            if let Some(m) = auto::measured(kernel, &primary.totals, rays, frame, true) {
                self.history.record_build(b.choice, m);
            }
        }
        for (plan, m) in lights.iter().zip(measured) {
            let Some(choice) = plan.auto else { continue };
            let kernel = choice.choice.kernel(wide);
            if let Some(got) = auto::measured(kernel, &m.work, m.rays, frame, m.own_tree) {
                self.history.record_order(&m.light, choice.choice, got);
            }
            if let Some((order, (work, rays))) = plan.sample.zip(m.sampled) {
                let kernel = order.kernel(wide);
                if let Some(got) = auto::measured(kernel, &work, rays, frame, false) {
                    self.history.record_order(&m.light, order, got);
                }
            }
        }
    }
}

/// World triangles past which `auto` holds an instanced scene on two levels: a flat tree of
/// them takes about half a gigabyte (some 280 bytes a triangle, docs/daemon.md), while two
/// levels trace slower where instances overlap (BENCHMARKS.md, "Flat and two levels").
pub const TWO_LEVEL_WORLD_TRIANGLES: u64 = 2_000_000;

/// `auto`'s structure from the scene alone (docs/auto.md), where the settings leave two levels
/// possible: two levels where instancing holds at least half of more than
/// [`TWO_LEVEL_WORLD_TRIANGLES`] world triangles (the used meshes hold at most half of what a
/// flat tree would); else the flat tree. The memory estimate reads this; a frame's plan adds
/// the rule for moving parts ([`auto::choose_structure`]), which needs the frames before.
pub(super) fn auto_structure(scene: &Scene, settings: &RenderSettings) -> SceneStructure {
    if settings.two_level_conflict().is_some() {
        return SceneStructure::Flat;
    }
    let mut used = vec![false; scene.meshes.len()];
    let mut world = 0u64;
    for o in &scene.objects {
        used[o.mesh] = true;
        world += scene.meshes[o.mesh].triangles.len() as u64;
    }
    let unique: u64 = (scene.meshes.iter().zip(&used))
        .filter(|(_, u)| **u)
        .map(|(m, _)| m.triangles.len() as u64)
        .sum();
    let instanced = world > TWO_LEVEL_WORLD_TRIANGLES && world >= 2 * unique;
    if instanced {
        SceneStructure::TwoLevel
    } else {
        SceneStructure::Flat
    }
}

/// Whether `auto`'s structure weighs moving parts ([`auto::choose_structure`]): with the
/// structure and the build left to `auto` (keeping the static part's tree is a way of having
/// the frame's trees; a named build, or SRDH named as the order, is a method compared as
/// published, on the flat tree) and settings two levels can trace.
fn weighs_moving_parts(settings: &RenderSettings) -> bool {
    settings.structure.is_auto()
        && settings.build.is_auto()
        && !matches!(settings.shadow_order, Pick::Fixed(ShadowOrder::Srdh(_)))
        && settings.two_level_conflict().is_none()
}

/// What `auto`'s order choice reads of a frame's shadow trees, flat or two-level.
struct ShadowTreesSummary {
    /// Wide trees to order (width 4 or 8).
    wide: bool,
    /// Nodes of the wide trees a light's preparation reads.
    wide_nodes: u64,
    /// Primitives an SRDH tree would be built over: triangles, or instances on two levels.
    srdh_primitives: u64,
    /// What a finished frame left prepared: SATO, the sorting tables. A cancelled render's
    /// preparations do not count, so auto chooses after it as a fresh renderer would.
    sato_ready: bool,
    tables_ready: bool,
}

impl ShadowTreesSummary {
    fn of(trees: &SceneTrees, settings: &RenderSettings) -> Self {
        let width_wide = settings.width != BvhWidth::Two;
        match trees {
            SceneTrees::Flat(t) => {
                let wide = t.wide.as_ref().filter(|_| width_wide);
                let prepared = wide.filter(|_| t.reported);
                ShadowTreesSummary {
                    wide: wide.is_some(),
                    wide_nodes: wide.map_or(0, |w| w.shadow_tree().node_count() as u64),
                    srdh_primitives: t.geometry().shadow_set().len() as u64,
                    sato_ready: prepared
                        .and_then(|w| w.per_tree_order.as_ref())
                        .is_some_and(|p| p.order == ShadowOrder::Sato),
                    tables_ready: prepared.is_some_and(|w| w.sort_tables.is_some()),
                }
            }
            // Two levels take SATO from the mesh trees' sorting tables.
            SceneTrees::TwoLevel(t) => {
                let wide_nodes = t.wide_nodes().filter(|_| width_wide);
                let ready = t.reported && t.sort_tables_ready();
                ShadowTreesSummary {
                    wide: wide_nodes.is_some(),
                    wide_nodes: wide_nodes.unwrap_or(0),
                    srdh_primitives: t.shadow_instances() as u64,
                    sato_ready: ready,
                    tables_ready: ready,
                }
            }
        }
    }
}

/// Every order the lights' plans trace, for the trees to prepare once.
pub(super) fn planned_orders(lights: &[LightPlan]) -> Vec<ShadowOrder> {
    lights.iter().flat_map(LightPlan::orders).collect()
}

/// Marks the primary row of a frame `auto` put on two levels with the structure (each light's
/// row carries its own order choice).
pub(super) fn mark_two_level_rows(rows: &mut [StatsRow], settings: &RenderSettings) {
    if !settings.structure.is_auto() {
        return;
    }
    for row in rows.iter_mut().filter(|r| r.auto_choice.is_empty()) {
        if row.pass == "primary" {
            row.auto_choice = SceneStructure::TwoLevel.name().to_string();
        }
    }
}

/// Marks a statistics row with `auto`'s choice behind it.
pub(super) fn mark_build_row(row: &mut StatsRow, build: &BuildPlan) {
    if let Some(c) = &build.auto {
        auto::mark_row(row, c, |b| b.name());
    }
}

/// Where in the run `auto` stands: the seed of its exploration and the frame's index.
fn moment(settings: &RenderSettings, frames_rendered: u64) -> auto::Moment {
    auto::Moment {
        seed: settings.seed,
        frame: frames_rendered,
    }
}

/// How a pass traces its tiles on a wide tree, the camera's and every light's: the setting, or
/// `auto`'s rule (docs/auto.md): packets, faster than single rays on the camera and shadow rays
/// of the built-in scenes (BENCHMARKS.md, "Single rays and packets").
pub fn pass_rays(settings: &RenderSettings) -> RayMode {
    match settings.rays {
        Pick::Fixed(m) => m,
        Pick::Auto => RayMode::Packet,
    }
}
