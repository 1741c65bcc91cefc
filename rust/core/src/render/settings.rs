use serde::{Deserialize, Serialize};

use super::{Facing, Pick, VisibilitySource};
use crate::build::{BuildMethod, BuildSettings, CollapseMethod, CollapseSettings};
use crate::bvh::BvhWidth;
use crate::order::ShadowOrder;
use crate::trace::RayMode;

/// What the passes measure.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum StatsMode {
    /// Exact work counters and heat maps (the counted traversal).
    #[default]
    Counts,
    /// Counters and heat maps, then each pass again with counters compiled out, for Mrays/s.
    CountsAndTiming,
    /// Only the uncounted traversal: images and timings, no heat maps.
    TimingOnly,
}

/// How a frame's objects become trees.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SceneStructure {
    /// Every object's triangles in one render-space set under one tree: the papers' form.
    #[default]
    Flat,
    /// One tree per unique mesh, shared by the objects that place it and kept across frames
    /// while the mesh is unchanged, under a top level over the objects (`crate::two_level`).
    TwoLevel,
}

impl SceneStructure {
    pub const ALL: [SceneStructure; 2] = [SceneStructure::Flat, SceneStructure::TwoLevel];

    pub fn name(self) -> &'static str {
        match self {
            SceneStructure::Flat => "flat",
            SceneStructure::TwoLevel => "two-level",
        }
    }
}

impl std::fmt::Display for SceneStructure {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for SceneStructure {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<Self> {
        SceneStructure::ALL
            .into_iter()
            .find(|m| m.name() == s.trim())
            .ok_or_else(|| {
                crate::Error::invalid(
                    "scene_structure",
                    format!("must be flat, two-level or auto, got '{s}'"),
                )
            })
    }
}

/// Settings of one frame's render.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderSettings {
    /// Shadow samples per pixel for soft lights (point/spot with radius, sun with angle, area).
    /// Hard lights always take one ray: it is exact for them.
    pub spp: u32,
    /// Seed of the light-sample patterns.
    pub seed: u32,
    /// The camera tree's builder, or `auto` (per frame SAH, OSAH or last frame's tree).
    pub build: Pick<BuildMethod>,
    pub build_settings: BuildSettings,
    /// Child order of the occlusion traversal (per light for the sorted order), or `auto` (per
    /// light and frame).
    pub shadow_order: Pick<ShadowOrder>,
    /// Children per BVH node: the binary tree (2) or its 4- or 8-wide collapse.
    #[serde(default)]
    pub width: BvhWidth,
    /// How the binary tree is collapsed into the wide one (widths 4 and 8).
    #[serde(default)]
    pub collapse: CollapseSettings,
    pub stats: StatsMode,
    /// Where ABVH, OSAH and VSAH builds take their visible-triangle set from.
    #[serde(default)]
    pub visibility: VisibilitySource,
    /// Which normal decides that a light sample is behind the surface.
    #[serde(default)]
    pub facing: Facing,
    /// How the wide trees trace a tile's rays: one at a time, in packets of neighbouring rays,
    /// or `auto` (the policy's rule per pass, docs/auto.md). Same answers either way.
    #[serde(default = "auto_rays")]
    pub rays: Pick<RayMode>,
    /// One flat tree, two levels (a tree per unique mesh under a top level over the objects),
    /// or `auto` (the policy's rule per frame, docs/auto.md).
    #[serde(default = "auto_structure")]
    pub structure: Pick<SceneStructure>,
    /// Trace through alpha-textured materials as Cycles does (transparent shadows, camera
    /// rays past clipped hits; docs/alpha.md); off: every triangle is opaque.
    #[serde(default = "alpha_on")]
    pub alpha: bool,
    /// Camera rays: a hit on an alpha material counts when its alpha is at least this.
    #[serde(default = "default_alpha_clip")]
    pub alpha_clip: f32,
    /// Cycles' Light Paths > Transparent max bounces: a shadow ray from a camera ray's first
    /// hit passes at most `transparent_bounces - 1` transparent hits, more make it black.
    #[serde(default = "default_transparent_bounces")]
    pub transparent_bounces: u32,
}

fn alpha_on() -> bool {
    true
}

fn default_alpha_clip() -> f32 {
    0.5
}

/// Blender's default Transparent bounces.
fn default_transparent_bounces() -> u32 {
    8
}

/// Upper bound on `transparent_bounces`: Cycles' own record of a shadow ray's hits holds 1024
/// on the CPU; more would only make a runaway shadow ray cheaper to ask for.
pub const MAX_TRANSPARENT_BOUNCES: u32 = 1024;

fn auto_rays() -> Pick<RayMode> {
    Pick::Auto
}

fn auto_structure() -> Pick<SceneStructure> {
    Pick::Auto
}

impl Default for RenderSettings {
    /// What a user gets without choosing: `auto` (it picks each frame's build and each light's
    /// order from the work it measured, docs/auto.md) on the 8-wide tree, the fastest sensible
    /// method on every built-in scene (BENCHMARKS.md). [`RenderSettings::baseline`] is the
    /// papers' reference.
    fn default() -> Self {
        RenderSettings {
            build: Pick::Auto,
            shadow_order: Pick::Auto,
            width: BvhWidth::Eight,
            rays: Pick::Auto,
            structure: Pick::Auto,
            ..Self::baseline()
        }
    }
}

/// Upper bound on shadow samples per pixel; more gives no visible gain and risks runaway work.
pub const MAX_SPP: u32 = 4096;

impl RenderSettings {
    /// The binary SAH tree traced front to back: the form the papers publish their figures
    /// against, compare's baseline, and what tests that pin one method start from.
    pub fn baseline() -> Self {
        RenderSettings {
            spp: 4,
            seed: 0,
            build: Pick::Fixed(BuildMethod::Sah),
            build_settings: BuildSettings::default(),
            shadow_order: Pick::Fixed(ShadowOrder::Fbto),
            width: BvhWidth::Two,
            collapse: CollapseSettings::default(),
            stats: StatsMode::Counts,
            visibility: VisibilitySource::Previous,
            facing: Facing::Geometric,
            rays: Pick::Fixed(RayMode::Single),
            structure: Pick::Fixed(SceneStructure::Flat),
            alpha: alpha_on(),
            alpha_clip: default_alpha_clip(),
            transparent_bounces: default_transparent_bounces(),
        }
    }

    /// The hit limit of a shadow ray from a camera ray's first hit: Cycles'
    /// `max(transparent_max_bounce - transparent_bounce - 1, 0)` at bounce 0.
    pub fn shadow_max_hits(&self) -> u32 {
        self.transparent_bounces.saturating_sub(1)
    }

    /// Whether a frame of `scene` traces through alpha: the setting is on and some object gives
    /// a slot an alpha material.
    pub fn alpha_active(&self, scene: &crate::scene::Scene) -> bool {
        self.alpha && scene.has_alpha()
    }

    /// Why two levels cannot render with these settings, naming the setting: they build each
    /// mesh's tree with SAH (no visible set or spatial splits across objects).
    pub fn two_level_conflict(&self) -> Option<crate::Error> {
        match self.build {
            Pick::Fixed(b) if b != BuildMethod::Sah => Some(crate::Error::invalid(
                "scene_structure",
                format!("two-level builds every mesh tree with sah, not '{b}' (set build to sah or auto, or scene_structure to flat)"),
            )),
            _ => None,
        }
    }

    /// Whether `auto` chooses the build or the shadow order as the frames go (else the method
    /// is fixed).
    pub fn chooses(&self) -> bool {
        self.build.is_auto() || self.shadow_order.is_auto()
    }

    /// The method's name as it appears in statistics: builder, BVH width and shadow-ray child
    /// order, e.g. `sah/bin8/sorted:logging=sato:p=1:budget=0.05`; a smallest leaf other than 1
    /// is named with the builder (`osah-previous:leaf8/bin2/fbto`).
    pub fn method_name(&self) -> String {
        // `auto` reads the previous frame's visible set unless told otherwise.
        let auto_previous = self.build.is_auto() && self.visibility == VisibilitySource::Previous;
        let mut build = if self.build.uses_visibility() && !auto_previous {
            format!("{}-{}", self.build, self.visibility.name())
        } else {
            self.build.to_string()
        };
        if self.build_settings.min_leaf_size > 1 {
            build += &format!(":leaf{}", self.build_settings.min_leaf_size);
        }
        // A non-default collapse of a wide tree is named, as `bench` does: sah/bin8:greedy/sato.
        let collapse = if self.width.get() > 2 && self.collapse.method != CollapseMethod::default()
        {
            format!(":{}", self.collapse.method)
        } else {
            String::new()
        };
        // Packets are named when fixed (`auto` and single rays are the unnamed default).
        let rays = match self.rays {
            Pick::Fixed(RayMode::Packet) => "/packet",
            _ => "",
        };
        // Two levels are named when fixed, as packets are.
        let structure = match self.structure {
            Pick::Fixed(SceneStructure::TwoLevel) => "/two-level",
            _ => "",
        };
        format!(
            "{build}/bin{}{collapse}/{}{rays}{structure}",
            self.width, self.shadow_order
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn method_names_say_a_non_default_collapse() {
        let mut s = RenderSettings {
            width: BvhWidth::Eight,
            ..RenderSettings::baseline()
        };
        assert!(
            s.method_name().starts_with("sah/bin8/"),
            "{}",
            s.method_name()
        );
        s.collapse = CollapseSettings::new(CollapseMethod::Greedy);
        assert!(
            s.method_name().starts_with("sah/bin8:greedy/"),
            "{}",
            s.method_name()
        );
        s.width = BvhWidth::Two;
        assert!(
            s.method_name().starts_with("sah/bin2/"),
            "{}",
            s.method_name()
        );
        s.build_settings.min_leaf_size = 4;
        assert!(
            s.method_name().starts_with("sah:leaf4/bin2/"),
            "{}",
            s.method_name()
        );
    }
}
