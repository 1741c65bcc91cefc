//! [`SceneTrees`]: a frame's trees, flat ([`FrameTrees`]) or two-level ([`TwoLevelTrees`]), as
//! the passes read them: the render space, the camera's tree, where hits lie, each light's tree
//! and order, and the statistics columns of what was traced.

use super::frame_trees::{CameraQuery, CameraTree, FrameTrees};
use super::light_tracer::{LightRays, LightTracing};
use super::two_level_trees::{TreeColumns, TwoLevelTrees};
use super::wide_tree::WideTree;
use super::HitGeometry;
use crate::bvh::{Bvh, BvhWidth};
use crate::order::ShadowOrder;
use crate::scene::{RenderSpace, Scene};
use crate::trace::RayMode;

use super::SceneStructure;

/// The frame's trees in the structure the policy chose (one per renderer: the size
/// difference of the variants costs nothing worth a box).
#[derive(Clone)]
#[allow(clippy::large_enum_variant)]
pub enum SceneTrees {
    Flat(FrameTrees),
    TwoLevel(TwoLevelTrees),
}

impl SceneTrees {
    /// The structure these trees have.
    pub fn structure(&self) -> SceneStructure {
        match self {
            SceneTrees::Flat(_) => SceneStructure::Flat,
            SceneTrees::TwoLevel(_) => SceneStructure::TwoLevel,
        }
    }

    /// The key of a light's orders in `auto`'s history: its name on a flat frame, its name and
    /// the structure on two levels, whose cost per ray an order measured on the flat tree is
    /// not (the top level and each instance's set-up add to every order's).
    pub(super) fn history_key(&self, light: &str) -> String {
        match self {
            SceneTrees::Flat(_) => light.to_string(),
            SceneTrees::TwoLevel(_) => format!("{light} (two-level)"),
        }
    }

    /// The render space the frame traces in.
    pub fn space(&self) -> &RenderSpace {
        match self {
            SceneTrees::Flat(t) => &t.geometry().space,
            SceneTrees::TwoLevel(t) => &t.space,
        }
    }

    /// What camera rays trace, batches as `rays` on a flat wide tree and on two levels.
    pub fn camera_query(&self, rays: RayMode) -> CameraQuery<'_> {
        match self {
            SceneTrees::Flat(t) => t.camera().traced_as(rays),
            SceneTrees::TwoLevel(t) => CameraQuery::TwoLevel(t.camera_query(rays)),
        }
    }

    /// Where the camera tree's hits lie.
    pub fn hit_geometry<'a>(&'a self, scene: &'a Scene) -> HitGeometry<'a> {
        match self {
            SceneTrees::Flat(t) => HitGeometry::Flat(&t.geometry().camera),
            SceneTrees::TwoLevel(trees) => HitGeometry::TwoLevel {
                trees,
                objects: &scene.objects,
            },
        }
    }

    /// One light's tree and order (on two levels: `order` on every mesh tree, sorted per light
    /// where it is the sorted order, the top level near child first; the ray mode is the
    /// tracer's).
    pub fn for_light(
        &self,
        order: &ShadowOrder,
        width: BvhWidth,
        light: &LightRays,
    ) -> LightTracing<'_> {
        match self {
            SceneTrees::Flat(t) => t.for_light(order, width, light),
            SceneTrees::TwoLevel(t) => LightTracing::two_level(t, order, light),
        }
    }

    /// The flat trees, if the frame is flat.
    pub fn flat(&self) -> Option<&FrameTrees> {
        match self {
            SceneTrees::Flat(t) => Some(t),
            SceneTrees::TwoLevel(_) => None,
        }
    }

    /// The two-level trees, if the frame has two levels.
    pub fn two_level(&self) -> Option<&TwoLevelTrees> {
        match self {
            SceneTrees::Flat(_) => None,
            SceneTrees::TwoLevel(t) => Some(t),
        }
    }

    /// After a finished frame: its build times have been reported.
    pub(super) fn mark_reported(&mut self) {
        match self {
            SceneTrees::Flat(t) => t.mark_reported(),
            SceneTrees::TwoLevel(t) => t.reported = true,
        }
    }

    /// The statistics columns of the camera's trees.
    pub(super) fn camera_columns(&self, rebuilt: bool, collapse_ms: f64) -> TreeColumns {
        match self {
            SceneTrees::Flat(t) => {
                let wide = match t.camera() {
                    CameraTree::Wide(w) => Some(w),
                    _ => None,
                };
                flat_columns(t.camera_bvh(), t.camera_info, wide, rebuilt, collapse_ms)
            }
            SceneTrees::TwoLevel(t) => t.camera_columns(),
        }
    }

    /// The statistics columns of the trees a light's rays traced.
    pub(super) fn shadow_columns(
        &self,
        tracing: &LightTracing,
        rebuilt: bool,
        collapse_ms: f64,
    ) -> TreeColumns {
        match self {
            SceneTrees::Flat(t) => {
                let mut c = flat_columns(
                    t.shadow_bvh(),
                    t.shadow_info(),
                    tracing.wide_tree(),
                    rebuilt,
                    collapse_ms,
                );
                if let Some(own) = tracing.own_tree() {
                    c.nodes = own.bvh.nodes.len() as u64;
                    c.bytes = own.bytes() as u64;
                }
                c
            }
            SceneTrees::TwoLevel(t) => t.shadow_columns(tracing.own_tree()),
        }
    }
}

/// A flat tree's columns: `bvh` (or its collapse `tree`) and what it was built over.
fn flat_columns(
    bvh: &Bvh,
    info: super::frame_trees::BvhInfo,
    tree: Option<&WideTree>,
    rebuilt: bool,
    collapse_ms: f64,
) -> TreeColumns {
    TreeColumns {
        build_ms: if rebuilt { bvh.build_ms } else { 0.0 } + collapse_ms,
        nodes: tree.map_or(bvh.nodes.len(), |t| t.node_count()) as u64,
        bytes: tree.map_or(bvh.bytes(), |t| t.bytes()) as u64,
        triangles: info.triangles,
        references: bvh.triangles.len() as u64,
        visible: info.visible,
        refit: 0,
    }
}
