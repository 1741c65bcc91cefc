//! The list of render settings: one entry per setting, in the order help and the panel show them.

use super::{Group, Kind, NamedSettings, Setting, SettingValue as V};
use crate::build::{BuildMethod, CollapseMethod, SpatialAxes};
use crate::bvh::BvhWidth;
use crate::order::ShadowOrder;
use crate::render::{Facing, Pick, RenderSettings, SceneStructure, StatsMode, VisibilitySource};
use crate::trace::RayMode;
use crate::{Error, Result};

const U32_MAX: i64 = u32::MAX as i64;

/// Parses a `Text`/`Choice` value with the type's own `FromStr`.
fn parsed<T: std::str::FromStr>(name: &str, v: &V) -> Result<T>
where
    T::Err: std::fmt::Display,
{
    v.as_text()
        .parse()
        .map_err(|e: T::Err| Error::invalid(name, e.to_string()))
}

pub static SCHEMA: &[Setting] = &[
    // Sampling.
    Setting {
        name: "spp",
        kind: Kind::Int {
            min: 1,
            max: crate::render::MAX_SPP as i64,
        },
        group: Group::Sampling,
        help: "Shadow samples per pixel of soft lights (hard lights take one ray: exact for them).",
        get: |s| s.spp.into(),
        set: |s, v| {
            s.spp = v.as_int() as u32;
            Ok(())
        },
    },
    Setting {
        name: "seed",
        kind: Kind::Int {
            min: 0,
            max: U32_MAX,
        },
        group: Group::Sampling,
        help: "Seed of the light-sample patterns.",
        get: |s| s.seed.into(),
        set: |s, v| {
            s.seed = v.as_int() as u32;
            Ok(())
        },
    },
    Setting {
        name: "timing",
        kind: Kind::Choice(&["off", "on", "only"]),
        group: Group::Sampling,
        help: "Time the passes with counters compiled out: off (counts only), on (counts, then \
               timed again) or only (timed only: no heat maps).",
        get: |s| {
            match s.stats {
                StatsMode::Counts => "off",
                StatsMode::CountsAndTiming => "on",
                StatsMode::TimingOnly => "only",
            }
            .into()
        },
        set: |s, v| {
            s.stats = match v.as_text() {
                "on" => StatsMode::CountsAndTiming,
                "only" => StatsMode::TimingOnly,
                _ => StatsMode::Counts,
            };
            Ok(())
        },
    },
    Setting {
        name: "facing",
        kind: Kind::Choice(&["geometric", "shading"]),
        group: Group::Sampling,
        help: "Which normal decides that a light sample is behind the surface (shadowed, no ray): \
               geometric (the triangle's plane) or shading (the mesh's interpolated normals, as \
               Cycles; docs/facing.md).",
        get: |s| s.facing.name().into(),
        set: |s, v| {
            s.facing = parsed::<Facing>("facing", v)?;
            Ok(())
        },
    },
    // Alpha.
    Setting {
        name: "alpha",
        kind: Kind::Bool,
        group: Group::Sampling,
        help: "Trace through alpha-textured materials as Cycles does: shadows through their \
               transparent parts, camera rays past clipped hits (docs/alpha.md); off: every \
               triangle is opaque.",
        get: |s| s.alpha.into(),
        set: |s, v| {
            s.alpha = v.as_bool();
            Ok(())
        },
    },
    Setting {
        name: "alpha_clip",
        kind: Kind::Float {
            min: 0.0,
            max: 1.0,
            open: false,
        },
        group: Group::Sampling,
        help: "Camera rays: a hit on an alpha material counts where its alpha is at least this \
               (EEVEE's alpha clip); below it the ray goes on.",
        get: |s| s.alpha_clip.into(),
        set: |s, v| {
            s.alpha_clip = v.as_float() as f32;
            Ok(())
        },
    },
    Setting {
        name: "transparent_bounces",
        kind: Kind::Int {
            min: 0,
            max: crate::render::MAX_TRANSPARENT_BOUNCES as i64,
        },
        group: Group::Sampling,
        help: "Cycles' Transparent max bounces: a shadow ray passes at most this minus one \
               transparent hits; more make it black.",
        get: |s| s.transparent_bounces.into(),
        set: |s, v| {
            s.transparent_bounces = v.as_int() as u32;
            Ok(())
        },
    },
    // Build.
    Setting {
        name: "build",
        kind: Kind::Choice(&["sah", "sbvh", "abvh", "osah", "vsah", "srdh", "auto"]),
        group: Group::Build,
        help: "BVH builder: sah; sbvh (spatial splits); abvh (spatial splits where visible \
               triangles are); osah (occlusion heuristic); vsah (SAH over visible triangles, a \
               reference); srdh (SAH for camera rays, an SRDH tree per light: order srdh); auto \
               (per frame SAH, OSAH or last frame's tree, from measured work: docs/auto.md).",
        get: |s| s.build.to_string().into(),
        set: |s, v| {
            // `srdh` is SAH plus the srdh order, settled with the order in `resolve_build_srdh`.
            s.build = match v.as_text() {
                "srdh" => Pick::Fixed(BuildMethod::Sah),
                _ => parsed("build", v)?,
            };
            Ok(())
        },
    },
    Setting {
        name: "visibility",
        kind: Kind::Text {
            syntax: "previous | exact | prepass:WxH",
        },
        group: Group::Build,
        help: "Visible set of abvh/osah/vsah builds: previous (frame t-1), exact (frame t, two \
               passes) or prepass:WxH (previous, with a WxH primary prepass on the first frame).",
        get: |s| s.visibility.name().into(),
        set: |s, v| {
            s.visibility = parsed::<VisibilitySource>("visibility", v)?;
            Ok(())
        },
    },
    Setting {
        name: "leaf_size",
        kind: Kind::Int { min: 1, max: 64 },
        group: Group::Build,
        help: "Largest leaf of the BVH, in triangles.",
        get: |s| s.build_settings.max_leaf_size.into(),
        set: |s, v| {
            s.build_settings.max_leaf_size = v.as_int() as usize;
            Ok(())
        },
    },
    Setting {
        name: "min_leaf_size",
        kind: Kind::Int { min: 1, max: 64 },
        group: Group::Build,
        help: "Nodes of at most this many triangles become leaves without a split search (1 to \
               leaf_size; Embree's minimum leaf size is 4): a faster build for larger leaves.",
        get: |s| s.build_settings.min_leaf_size.into(),
        set: |s, v| {
            s.build_settings.min_leaf_size = v.as_int() as usize;
            Ok(())
        },
    },
    Setting {
        name: "bins",
        kind: Kind::Int {
            min: 2,
            max: crate::build::MAX_BINS as i64,
        },
        group: Group::Build,
        help: "SAH bins per axis: more find better splits at a higher build cost.",
        get: |s| s.build_settings.bins.into(),
        set: |s, v| {
            s.build_settings.bins = v.as_int() as usize;
            Ok(())
        },
    },
    Setting {
        name: "traversal_cost",
        kind: Kind::Float {
            min: 0.0,
            max: 1e6,
            open: true,
        },
        group: Group::Build,
        help: "SAH cost of a traversal step, relative to intersection_cost.",
        get: |s| s.build_settings.traversal_cost.into(),
        set: |s, v| {
            s.build_settings.traversal_cost = v.as_float() as f32;
            Ok(())
        },
    },
    Setting {
        name: "intersection_cost",
        kind: Kind::Float {
            min: 0.0,
            max: 1e6,
            open: true,
        },
        group: Group::Build,
        help: "SAH cost of a ray/triangle test.",
        get: |s| s.build_settings.intersection_cost.into(),
        set: |s, v| {
            s.build_settings.intersection_cost = v.as_float() as f32;
            Ok(())
        },
    },
    // OSAH.
    Setting {
        name: "osah_w",
        kind: Kind::Float {
            min: 0.0,
            max: 1.0,
            open: true,
        },
        group: Group::Osah,
        help: "OSAH weight w of visible triangles (w = 1 would drop the area term that breaks \
               ties; w = 0 is plain SAH).",
        get: |s| s.build_settings.osah_weight.into(),
        set: |s, v| {
            s.build_settings.osah_weight = v.as_float() as f32;
            Ok(())
        },
    },
    Setting {
        name: "osah_viability",
        kind: Kind::Choice(&["strict", "paper"]),
        group: Group::Osah,
        help: "OSAH split viability: strict (the hidden child also holds no visible triangle) \
               or paper (the paper's condition (5) alone).",
        get: |s| {
            if s.build_settings.osah_strict_viability {
                "strict"
            } else {
                "paper"
            }
            .into()
        },
        set: |s, v| {
            s.build_settings.osah_strict_viability = v.as_text() == "strict";
            Ok(())
        },
    },
    // Spatial splits.
    Setting {
        name: "spatial_splits",
        kind: Kind::Bool,
        group: Group::SpatialSplits,
        help: "Spatial splits in sbvh/abvh/osah builds (off: object splits only).",
        get: |s| s.build_settings.spatial.enabled.into(),
        set: |s, v| {
            s.build_settings.spatial.enabled = v.as_bool();
            Ok(())
        },
    },
    Setting {
        name: "spatial_bins",
        kind: Kind::Int { min: 2, max: 256 },
        group: Group::SpatialSplits,
        help: "Spatial-split bins per axis.",
        get: |s| s.build_settings.spatial.bins.into(),
        set: |s, v| {
            s.build_settings.spatial.bins = v.as_int() as usize;
            Ok(())
        },
    },
    Setting {
        name: "spatial_axes",
        kind: Kind::Choice(&["object", "all"]),
        group: Group::SpatialSplits,
        help: "Axes spatial splits are binned on: object (the best object split's only) or all \
               (the SBVH as Stich et al.).",
        get: |s| s.build_settings.spatial.axes.to_string().into(),
        set: |s, v| {
            s.build_settings.spatial.axes = parsed::<SpatialAxes>("spatial_axes", v)?;
            Ok(())
        },
    },
    Setting {
        name: "split_alpha",
        kind: Kind::Float {
            min: 0.0,
            max: 1.0,
            open: false,
        },
        group: Group::SpatialSplits,
        help: "Spatial splits only where object-split children overlap by more than this \
               fraction of the root's area (Stich et al.'s alpha; 1 disables).",
        get: |s| s.build_settings.spatial.alpha.into(),
        set: |s, v| {
            s.build_settings.spatial.alpha = v.as_float() as f32;
            Ok(())
        },
    },
    Setting {
        name: "split_node_overlap",
        kind: Kind::Float {
            min: 0.0,
            max: 1.0,
            open: false,
        },
        group: Group::SpatialSplits,
        help: "Spatial splits only where object-split children overlap by at least this \
               fraction of the node's own area (Embree's gate; 0 tries every node).",
        get: |s| s.build_settings.spatial.node_overlap.into(),
        set: |s, v| {
            s.build_settings.spatial.node_overlap = v.as_float() as f32;
            Ok(())
        },
    },
    Setting {
        name: "split_min_refs",
        kind: Kind::Int {
            min: 0,
            max: U32_MAX,
        },
        group: Group::SpatialSplits,
        help: "Nodes with fewer references than this never try spatial splits (0 tries all).",
        get: |s| s.build_settings.spatial.min_refs.into(),
        set: |s, v| {
            s.build_settings.spatial.min_refs = v.as_int() as usize;
            Ok(())
        },
    },
    Setting {
        name: "clip_min_refs",
        kind: Kind::Int {
            min: 0,
            max: U32_MAX,
        },
        group: Group::SpatialSplits,
        help: "Nodes with fewer references than this bin spatial candidates with cut reference \
               boxes instead of clipped triangles (0 clips everywhere, as Stich et al.).",
        get: |s| s.build_settings.spatial.clip_min_refs.into(),
        set: |s, v| {
            s.build_settings.spatial.clip_min_refs = v.as_int() as usize;
            Ok(())
        },
    },
    Setting {
        name: "max_growth",
        kind: Kind::Float {
            min: 0.0,
            max: 16.0,
            open: false,
        },
        group: Group::SpatialSplits,
        help: "References may grow to (1 + this) x triangles through spatial splits.",
        get: |s| s.build_settings.spatial.max_growth.into(),
        set: |s, v| {
            s.build_settings.spatial.max_growth = v.as_float() as f32;
            Ok(())
        },
    },
    // Wide BVH.
    Setting {
        name: "width",
        kind: Kind::IntChoice(&[2, 4, 8]),
        group: Group::WideBvh,
        help: "Children per BVH node: 2 (binary), 4 or 8 (collapsed, SIMD traversal).",
        get: |s| s.width.get().into(),
        set: |s, v| {
            s.width = BvhWidth::try_from(v.as_int() as u32)?;
            Ok(())
        },
    },
    Setting {
        name: "collapse",
        kind: Kind::Choice(&["sah", "greedy"]),
        group: Group::WideBvh,
        help: "How widths 4 and 8 collapse the binary tree: sah (the SAH-optimal slots and \
               leaves) or greedy (open the largest child).",
        get: |s| s.collapse.method.name().into(),
        set: |s, v| {
            s.collapse.method = parsed::<CollapseMethod>("collapse", v)?;
            Ok(())
        },
    },
    Setting {
        name: "collapse_max_leaf",
        kind: Kind::Int { min: 1, max: 64 },
        group: Group::WideBvh,
        help: "Largest leaf the sah collapse makes by merging binary leaves.",
        get: |s| s.collapse.cost.max_leaf.into(),
        set: |s, v| {
            s.collapse.cost.max_leaf = v.as_int() as u32;
            Ok(())
        },
    },
    Setting {
        name: "rays",
        kind: Kind::Choice(&["single", "packet", "auto"]),
        group: Group::WideBvh,
        help: "How widths 4 and 8 trace a tile's rays: one at a time, in packets of 16 \
               neighbouring rays (SIMD across rays), or auto (packets where they pay: \
               docs/auto.md). Same answers either way.",
        get: |s| s.rays.to_string().into(),
        set: |s, v| {
            s.rays = parsed::<Pick<RayMode>>("rays", v)?;
            Ok(())
        },
    },
    Setting {
        name: "scene_structure",
        kind: Kind::Choice(&["flat", "two-level", "auto"]),
        group: Group::Build,
        help: "One tree over every object's triangles (flat), a tree per unique mesh shared by \
               the objects that place it under a top level over the objects (two-level: \
               instances held once, unchanged meshes keep their trees), or auto (two levels \
               for heavy instancing or moving parts: docs/auto.md). Two levels build with sah; \
               srdh builds a light's tree over the instances.",
        get: |s| s.structure.to_string().into(),
        set: |s, v| {
            s.structure = parsed::<Pick<SceneStructure>>("scene_structure", v)?;
            Ok(())
        },
    },
    // Shadow order: after `build`, which it may complete.
    Setting {
        name: "order",
        kind: Kind::Text {
            syntax: "stored | fbto | sato | rtsah | random[:seed=S] | \
                     sorted[:logging=sato|fbto][:p=1|area][:depth=K][:budget=F] | \
                     srdh[:rays=WxH|all|F][:bins=B][:leaf=K][:kernels=all|constant|directional]\
                     [:min_occluded=F] | auto",
        },
        group: Group::ShadowOrder,
        help: "Child order of shadow-ray traversal: fbto (front to back), a static order (sato, \
               rtsah, random), sorted per light from a budget share of its shadow rays, or srdh \
               (an SRDH tree with kernels per mostly occluded light); auto picks one per light and \
               frame from measured work (docs/auto.md).",
        get: |s| s.shadow_order.to_string().into(),
        set: |s, v| {
            s.shadow_order = parsed::<Pick<ShadowOrder>>("order", v)?;
            Ok(())
        },
    },
];

/// `build=srdh` is the SAH tree with the srdh order for shadow rays: the order may be left out
/// (the default srdh options) or be an `srdh[:...]` order, nothing else.
pub(super) fn resolve_build_srdh(s: &mut RenderSettings, named: &NamedSettings) -> Result<()> {
    if named.get("build").map(V::as_text) != Some("srdh") {
        return Ok(());
    }
    match (named.get("order"), s.shadow_order) {
        (None, _) => s.shadow_order = Pick::Fixed(ShadowOrder::Srdh(Default::default())),
        (Some(_), Pick::Fixed(ShadowOrder::Srdh(_))) => {}
        (Some(_), other) => {
            return Err(Error::invalid(
                "build",
                format!(
                    "'srdh' traces shadow rays with an SRDH tree per light, so the order cannot \
                     also be '{other}' (leave it out, or give srdh[:...] options)"
                ),
            ))
        }
    }
    Ok(())
}

/// Rules between settings, and the checks of the parsed `Text` settings' own parameters.
pub(super) fn check_relations(s: &RenderSettings) -> Result<()> {
    let b = &s.build_settings;
    if b.min_leaf_size > b.max_leaf_size {
        return Err(Error::invalid(
            "min_leaf_size",
            format!(
                "must be at most leaf_size ({}), got {}",
                b.max_leaf_size, b.min_leaf_size
            ),
        ));
    }
    if let Some(o) = s.shadow_order.fixed() {
        o.validate()?;
    }
    if s.structure == Pick::Fixed(SceneStructure::TwoLevel) {
        if let Some(e) = s.two_level_conflict() {
            return Err(e);
        }
    }
    s.visibility.validate()
}
