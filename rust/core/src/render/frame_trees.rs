//! [`FrameTrees`]: a frame's trees as named state: the camera tree, the shadow tree (where the
//! shadow casters differ from what the camera sees), their wide collapse, the orders made once
//! per tree, and what they were built from. The renderer keeps them across frames while their
//! key holds; the passes read them only through [`FrameTrees::camera`], [`FrameTrees::shadow`]
//! and [`FrameTrees::for_light`].

use std::sync::Arc;
use std::time::Instant;

use xxhash_rust::xxh3::Xxh3;

use super::light_tracer::{binary_order, light_tracing, LightRays, LightTracing, ShadowTrees};
use super::object_changes::object_state;
use super::two_level_query::TwoLevelQuery;
use super::wide_tree::{OrderedWideTree, WideTree};
use super::RenderSettings;
use crate::build::{BuildMethod, BuildSettings, CollapseSettings};
use crate::bvh::{Bvh, BvhWidth};
use crate::cancel::CancelToken;
use crate::order::{OrderView, PreparedOrder, ShadowOrder, SortTables};
use crate::scene::{FrameGeometry, Mesh, Scene, TriangleRef};
use crate::trace::{forward_ray_query, RayMode};
use crate::Result;

/// What identifies a frame's geometry: mesh identities, transforms and visibility flags, as a
/// 128-bit XXH3 of them (16 bytes whatever the object count, where a copy of the list took 144
/// bytes an object). Any change rebuilds a flat frame's trees and a two-level frame's top levels.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) struct GeometryKey(u128);

impl GeometryKey {
    pub(super) fn of(scene: &Scene) -> Self {
        let mut h = Xxh3::new();
        h.update(&(scene.objects.len() as u64).to_le_bytes());
        // One update per object: the hasher's per-call cost dominates for small pieces.
        for o in &scene.objects {
            h.update(&object_state(scene, o));
        }
        GeometryKey(h.digest128())
    }
}

/// A frame's trees, shared (reference counted) by the renderer's copies: `compare` times each
/// method from a copy of its state.
#[derive(Clone)]
pub struct FrameTrees {
    pub(super) key: GeometryKey,
    /// Keeps the meshes alive so their addresses in the key cannot be reused.
    _meshes: Vec<Arc<Mesh>>,
    pub(super) build: (BuildMethod, BuildSettings),
    /// Whether a finished frame has reported these trees' build (a cancelled render leaves
    /// the report to the next render that uses them, so it reads as a fresh render's).
    pub(super) reported: bool,
    pub(super) geometry: Arc<FrameGeometry>,
    pub(super) camera_bvh: Arc<Bvh>,
    /// `None`: the camera tree serves shadow rays too.
    pub(super) shadow_bvh: Option<Arc<Bvh>>,
    /// The visible set the trees were built from (visibility-driven builds only).
    pub(super) visible_input: Option<Vec<TriangleRef>>,
    pub(super) camera_info: BvhInfo,
    pub(super) shadow_info: Option<BvhInfo>,
    pub(super) wide: Option<WideTrees>,
}

/// The collapsed trees of a frame's binary trees for one width.
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

impl WideTrees {
    /// The wide tree shadow rays trace.
    pub(super) fn shadow_tree(&self) -> &WideTree {
        self.shadow.as_deref().unwrap_or(&self.camera)
    }
}

#[derive(Clone)]
pub(super) struct PerTreeOrder {
    pub(super) order: ShadowOrder,
    pub(super) prepared: PreparedOrder,
    /// Preparation time, reported (as the first shadow row's `prepare_ms`) only by the frame
    /// that prepared it.
    pub(super) ms: Option<f64>,
}

/// Triangles flagged visible in a tree's set, and distinct triangles in the tree.
#[derive(Clone, Copy, Default)]
pub(super) struct BvhInfo {
    pub(super) visible: u64,
    pub(super) triangles: u64,
}

/// What making the frame's trees did this frame.
#[derive(Clone, Copy)]
pub(super) struct Prepared {
    pub(super) rebuilt: bool,
    pub(super) visibility_ms: f64,
}

/// The tree the camera rays trace.
#[derive(Clone, Copy)]
pub enum CameraTree<'a> {
    Binary(&'a Bvh),
    /// The collapse, at widths 4 and 8.
    Wide(&'a WideTree),
}

impl<'a> CameraTree<'a> {
    /// The tree as the primary pass traces it: the wide tree's batches as `rays` (closest hits
    /// read no order), the binary tree's one ray at a time.
    pub fn traced_as(self, rays: RayMode) -> CameraQuery<'a> {
        match self {
            CameraTree::Binary(b) => CameraQuery::Binary(b),
            CameraTree::Wide(w) => {
                CameraQuery::Wide(w.ordered(OrderView::FrontToBack).with_rays(rays))
            }
        }
    }
}

/// The camera tree with how its batches are traced ([`CameraTree::traced_as`], or a two-level
/// frame's top level).
pub enum CameraQuery<'a> {
    Binary(&'a Bvh),
    Wide(OrderedWideTree<'a>),
    TwoLevel(TwoLevelQuery<'a>),
}

/// Calls `$f` with the query `$camera` holds.
macro_rules! with_camera_query {
    ($camera:expr, $q:ident => $f:expr) => {
        match $camera {
            CameraQuery::Binary($q) => $f,
            CameraQuery::Wide($q) => $f,
            CameraQuery::TwoLevel($q) => $f,
        }
    };
}
forward_ray_query!(CameraQuery<'_>, with_camera_query);

impl FrameTrees {
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        scene: &Scene,
        key: GeometryKey,
        build: (BuildMethod, BuildSettings),
        geometry: Arc<FrameGeometry>,
        camera: (Bvh, BvhInfo),
        shadow: Option<(Bvh, BvhInfo)>,
        visible_input: Option<Vec<TriangleRef>>,
    ) -> Self {
        let (shadow_bvh, shadow_info) = match shadow {
            Some((bvh, info)) => (Some(Arc::new(bvh)), Some(info)),
            None => (None, None),
        };
        FrameTrees {
            key,
            _meshes: scene.meshes.clone(),
            build,
            reported: false,
            geometry,
            camera_bvh: Arc::new(camera.0),
            camera_info: camera.1,
            shadow_bvh,
            shadow_info,
            visible_input,
            wide: None,
        }
    }

    pub fn geometry(&self) -> &FrameGeometry {
        &self.geometry
    }

    /// The binary camera tree (the one the wide camera tree was collapsed from).
    pub fn camera_bvh(&self) -> &Bvh {
        &self.camera_bvh
    }

    /// The visible set the trees were built from (the previous frame's, or a prepass's), for
    /// visibility-driven builds (ABVH, OSAH, VSAH); `None` for the others.
    pub fn visible_input(&self) -> Option<&[TriangleRef]> {
        self.visible_input.as_deref()
    }

    /// The binary tree of the shadow casters.
    pub fn shadow_bvh(&self) -> &Bvh {
        self.shadow_bvh.as_deref().unwrap_or(&self.camera_bvh)
    }

    pub(super) fn shadow_info(&self) -> BvhInfo {
        self.shadow_info.unwrap_or(self.camera_info)
    }

    /// The tree the primary pass traces: the wide collapse at widths 4 and 8, else the binary one.
    pub fn camera(&self) -> CameraTree<'_> {
        match self.wide.as_ref().filter(|w| w.width != BvhWidth::Two) {
            Some(w) => CameraTree::Wide(&w.camera),
            None => CameraTree::Binary(&self.camera_bvh),
        }
    }

    /// The trees shadow rays may trace, and the orders made once per tree.
    pub fn shadow(&self) -> ShadowTrees<'_> {
        let wide = self.wide.as_ref();
        ShadowTrees {
            bvh: self.shadow_bvh(),
            triangles: &self.geometry.shadow_set().vertices,
            wide: wide.map(WideTrees::shadow_tree),
            sort_tables: wide.and_then(|w| w.sort_tables.as_ref()),
            per_tree: wide
                .and_then(|w| w.per_tree_order.as_ref())
                .map(|p| (&p.order, &p.prepared, p.ms)),
        }
    }

    /// One light's tree and order: `order` chosen for it, prepared from its rays.
    pub fn for_light(
        &self,
        order: &ShadowOrder,
        width: BvhWidth,
        light: &LightRays,
    ) -> LightTracing<'_> {
        light_tracing(&self.shadow(), order, width, light)
    }

    /// The collapse's time when this frame collapsed.
    pub(super) fn collapse_ms(&self) -> f64 {
        self.wide
            .as_ref()
            .and_then(|w| w.collapse_ms)
            .unwrap_or(0.0)
    }

    /// Collapses the binary trees to the settings' width when a pass will read a wide tree
    /// (kept while width and collapse are unchanged), and makes what the settings' fixed order
    /// reads once per tree. Each piece is stored whole, so a cancel between them leaves the
    /// trees consistent.
    pub(super) fn collapse(
        &mut self,
        settings: &RenderSettings,
        cancel: &CancelToken,
    ) -> Result<()> {
        // `auto` at width 2 picks among the binary tree's orders (front to back, SRDH).
        let needed = settings.width != BvhWidth::Two
            || settings.shadow_order.fixed().is_some_and(|o| {
                binary_order(settings.width, o).is_none() && !matches!(o, ShadowOrder::Srdh(_))
            });
        if !needed {
            return Ok(());
        }
        if self.wide.as_ref().map(|w| (w.width, w.collapse))
            != Some((settings.width, settings.collapse))
        {
            let camera = WideTree::collapse(&self.camera_bvh, settings.width, &settings.collapse);
            let shadow = self
                .shadow_bvh
                .as_ref()
                .map(|b| WideTree::collapse(b, settings.width, &settings.collapse));
            let collapse_ms =
                camera.collapse_ms() + shadow.as_ref().map_or(0.0, |s| s.collapse_ms());
            self.wide = Some(WideTrees {
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
        let fixed: Vec<ShadowOrder> = settings.shadow_order.fixed().copied().into_iter().collect();
        self.prepare_orders(&fixed, cancel)
    }

    /// Makes, once per wide tree, what the lights' `orders` read: the sorting tables and a
    /// per-tree order (one per tree: the lights' orders hold at most one kind).
    pub(super) fn prepare_orders(
        &mut self,
        orders: &[ShadowOrder],
        cancel: &CancelToken,
    ) -> Result<()> {
        let Some(w) = self.wide.as_mut() else {
            return Ok(());
        };
        // Field by field (not `shadow_tree()`): the tables and the order are set below.
        let tree = w.shadow.as_deref().unwrap_or(&w.camera);
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

    /// After a finished frame: the trees' build, collapse and per-tree order times have been
    /// reported, so frames that reuse them report none.
    pub(super) fn mark_reported(&mut self) {
        self.reported = true;
        if let Some(w) = &mut self.wide {
            w.collapse_ms = None;
            if let Some(p) = &mut w.per_tree_order {
                p.ms = None;
            }
        }
    }
}
