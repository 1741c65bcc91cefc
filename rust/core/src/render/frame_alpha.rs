//! [`FrameAlpha`]: a frame's alpha as the passes read it: on a flat frame one [`AlphaScene`]
//! per triangle set the trees are built over (camera, and shadow where it differs), its
//! triangle ids those of the set; on two levels one per mesh tree and materials
//! ([`InstanceAlpha`]), its ids the mesh tree's. The images are shared with the scene.

use std::collections::HashMap;

use crate::alpha::{AlphaScene, AlphaTriangles, FlaggedTriangle};
use crate::bvh::Bvh;
use crate::geometry::Ray;
use std::sync::Arc;

use crate::alpha::AlphaImage;
use crate::scene::{AlphaMaterial, FrameGeometry, Scene, TriangleRef, TriangleSet};
use crate::srdh::SrdhBvh;
use crate::stats::StatsRow;
use crate::trace::RayQuery;
use crate::trace::{forward_alpha_query, AlphaQuery, AlphaScenes, Counters, Hit, OrderedBinary};
use crate::two_level::InstanceAlpha;
use crate::{Error, Result};

use super::frame_trees::CameraQuery;
use super::light_tracer::ShadowTracer;
use super::two_level_query::TwoLevelQuery;
use super::two_level_trees::TwoLevelTrees;
use super::wide_tree::OrderedWideTree;

/// A frame's alpha and the limits its passes trace it with.
#[derive(Clone, Debug)]
pub struct FrameAlpha {
    pub sets: AlphaSets,
    /// The hit limit of shadow rays ([`super::RenderSettings::shadow_max_hits`]).
    pub max_hits: u32,
    /// Camera rays' clip threshold.
    pub clip: f32,
}

/// The alpha scenes of a frame's trees.
#[derive(Clone, Debug)]
pub enum AlphaSets {
    /// A flat frame's, per triangle set.
    Flat {
        camera: AlphaScene,
        /// `None`: the camera set serves shadow rays too ([`FrameGeometry::shadow`]).
        shadow: Option<AlphaScene>,
    },
    /// A two-level frame's, per instance: the camera's and the shadow casters' top levels
    /// place the same mesh trees, so one serves both.
    TwoLevel(InstanceAlpha),
}

impl FrameAlpha {
    /// The alpha of `geometry`'s sets (made from `scene`, which the renderer validated).
    pub fn new(
        scene: &Scene,
        geometry: &FrameGeometry,
        max_hits: u32,
        clip: f32,
    ) -> Result<FrameAlpha> {
        let sets = AlphaSets::Flat {
            camera: alpha_scene(scene, &geometry.camera)?,
            shadow: (geometry.shadow.as_ref())
                .map(|s| alpha_scene(scene, s))
                .transpose()?,
        };
        Ok(FrameAlpha {
            sets,
            max_hits,
            clip,
        })
    }

    /// The alpha of a two-level frame's instances.
    pub fn two_level(
        scene: &Scene,
        trees: &TwoLevelTrees,
        max_hits: u32,
        clip: f32,
    ) -> Result<FrameAlpha> {
        Ok(FrameAlpha {
            sets: AlphaSets::TwoLevel(instance_alpha(scene, trees)?),
            max_hits,
            clip,
        })
    }

    /// Whether no triangle is flagged (a slot mapped to an alpha material that no triangle
    /// uses): the frame then traces as an opaque one.
    pub fn flags_nothing(&self) -> bool {
        let none = |a: &AlphaScene| a.triangles().flagged_count() == 0;
        match &self.sets {
            AlphaSets::Flat { camera, shadow } => none(camera) && shadow.as_ref().is_none_or(none),
            AlphaSets::TwoLevel(instances) => instances.flags_nothing(),
        }
    }
}

/// A frame's alpha lookups, from its counted passes (0 in timed-only frames), as totals
/// ([`super::Renderer::alpha_stats`]); the rows get them per ray (`alpha_lookups_per_ray`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AlphaFrameStats {
    pub frame: i32,
    /// Camera rays' alpha evaluations (candidate closest hits on flagged triangles).
    pub primary: u64,
    /// Per shadow-casting light, by name: its shadow rays' alpha evaluations.
    pub shadow: Vec<(String, u64)>,
}

impl AlphaFrameStats {
    /// Writes the lookups per ray into the frame's rows: the primary row's from the camera
    /// rays, each shadow row's from its light's rays.
    pub fn fill_rows(&self, rows: &mut [StatsRow]) {
        for row in rows {
            let lookups = if row.pass == "primary" {
                Some(self.primary)
            } else {
                (self.shadow.iter())
                    .find(|(light, _)| *light == row.light)
                    .map(|&(_, n)| n)
            };
            if let Some(n) = lookups {
                row.alpha_lookups_per_ray = n as f64 / row.rays.max(1) as f64;
            }
        }
    }
}

/// The last frame's alpha, kept while what it was made from holds: the same geometry (so the
/// same triangle ids and meshes), object slots, materials, images and limits.
#[derive(Clone)]
pub(super) struct AlphaCache {
    geometry: Arc<FrameGeometry>,
    slots: Vec<Vec<Option<u32>>>,
    materials: Vec<AlphaMaterial>,
    /// Compared by identity: an image is the same `Arc` while it is unchanged.
    images: Vec<Arc<AlphaImage>>,
    limits: (u32, u32),
    pub(super) alpha: Arc<FrameAlpha>,
}

impl AlphaCache {
    /// The alpha of `scene` over `geometry`, kept or made.
    pub(super) fn get(
        cache: &mut Option<AlphaCache>,
        scene: &Scene,
        geometry: &Arc<FrameGeometry>,
        max_hits: u32,
        clip: f32,
    ) -> Result<Arc<FrameAlpha>> {
        let limits = (max_hits, clip.to_bits());
        let holds = |c: &&AlphaCache| {
            Arc::ptr_eq(&c.geometry, geometry)
                && c.limits == limits
                && c.materials == scene.alpha.materials
                && c.images.len() == scene.alpha.images.len()
                && c.images
                    .iter()
                    .zip(&scene.alpha.images)
                    .all(|(a, b)| Arc::ptr_eq(a, b))
                && c.slots.len() == scene.objects.len()
                && c.slots
                    .iter()
                    .zip(&scene.objects)
                    .all(|(s, o)| *s == o.materials)
        };
        if let Some(c) = cache.as_ref().filter(holds) {
            return Ok(c.alpha.clone());
        }
        let alpha = Arc::new(FrameAlpha::new(scene, geometry, max_hits, clip)?);
        *cache = Some(AlphaCache {
            geometry: geometry.clone(),
            slots: scene.objects.iter().map(|o| o.materials.clone()).collect(),
            materials: scene.alpha.materials.clone(),
            images: scene.alpha.images.clone(),
            limits,
            alpha: alpha.clone(),
        });
        Ok(alpha)
    }
}

/// One set's alpha: a triangle is flagged when its object's slot has an alpha material; its
/// UVs come from the mesh's map the material names (UV (0, 0) at every corner without it, as
/// Cycles reads a missing attribute). One UV set: the materials' programs read set 0.
pub fn alpha_scene(scene: &Scene, set: &TriangleSet) -> Result<AlphaScene> {
    alpha_scene_of(scene, &set.refs)
}

/// The alpha of the triangles `refs` names, their ids the indices in `refs`.
fn alpha_scene_of(scene: &Scene, refs: &[TriangleRef]) -> Result<AlphaScene> {
    let mut flagged = Vec::new();
    for (id, r) in refs.iter().enumerate() {
        let object = scene.objects.get(r.object as usize).ok_or_else(|| {
            Error::invalid(
                format!("alpha triangle {id}"),
                format!("object {} is not in the frame", r.object),
            )
        })?;
        if object.materials.is_empty() {
            continue;
        }
        let mesh = scene
            .meshes
            .get(object.mesh)
            .ok_or_else(|| Error::UnknownMesh {
                object: object.name.clone(),
                mesh: object.mesh,
                mesh_count: scene.meshes.len(),
            })?;
        let primitive = r.primitive as usize;
        let Some(m) = object.alpha_material(mesh.material_slot(primitive)) else {
            continue;
        };
        let material = scene.alpha.materials.get(m as usize).ok_or_else(|| {
            Error::invalid(
                format!("object '{}'.materials", object.name),
                format!(
                    "alpha material {m}, but the frame has {}",
                    scene.alpha.materials.len()
                ),
            )
        })?;
        let corners = match material.program.uv_set() {
            Some(_) => mesh
                .uv_map(&material.uv_map)
                .and_then(|map| map.corners.get(primitive).copied())
                .unwrap_or([[0.0; 2]; 3]),
            None => [[0.0; 2]; 3],
        };
        flagged.push(FlaggedTriangle {
            triangle: id as u32,
            material: m,
            uvs: vec![corners],
        });
    }
    let triangles = AlphaTriangles::new(refs.len() as u32, 1, flagged)?;
    let programs = scene
        .alpha
        .materials
        .iter()
        .map(|m| m.program.clone())
        .collect();
    AlphaScene::shared(scene.alpha.images.clone(), programs, triangles)
}

/// A two-level frame's alpha: a scene per (mesh tree, object materials) pair, made once for
/// the objects that share it, over the mesh tree's ids; the group tree's over its own ids.
/// Objects without an alpha material stay opaque (no scene).
fn instance_alpha(scene: &Scene, trees: &TwoLevelTrees) -> Result<InstanceAlpha> {
    let mut scenes = Vec::new();
    let mut made: HashMap<(u32, &[Option<u32>]), Option<u32>> = HashMap::new();
    let keep = |scene_alpha: AlphaScene, scenes: &mut Vec<AlphaScene>| {
        (scene_alpha.triangles().flagged_count() > 0).then(|| {
            scenes.push(scene_alpha);
            scenes.len() as u32 - 1
        })
    };
    let mut by_object = vec![None; scene.objects.len()];
    for (i, o) in scene.objects.iter().enumerate() {
        if o.materials.is_empty() {
            continue;
        }
        let Some((tree_index, tree)) = trees.object_tree(o) else {
            continue; // in the group, or placing nothing
        };
        let key = (tree_index, o.materials.as_slice());
        by_object[i] = match made.get(&key) {
            Some(&s) => s,
            None => {
                let refs: Vec<TriangleRef> = (tree.primitives.iter())
                    .map(|&primitive| TriangleRef {
                        object: i as u32,
                        primitive,
                    })
                    .collect();
                let s = keep(alpha_scene_of(scene, &refs)?, &mut scenes);
                made.insert(key, s);
                s
            }
        };
    }
    let group = match trees.group_tree() {
        Some(tree) => {
            let refs: Vec<TriangleRef> = (tree.objects.iter().zip(&tree.primitives))
                .map(|(&object, &primitive)| TriangleRef { object, primitive })
                .collect();
            keep(alpha_scene_of(scene, &refs)?, &mut scenes)
        }
        None => None,
    };
    Ok(InstanceAlpha::new(scenes, &by_object, group))
}

/// Camera rays through alpha as the primary pass traces them: a [`RayQuery`] whose closest
/// hit is [`AlphaQuery::closest_hit_alpha`] (single rays: packets have no alpha kernel).
pub struct AlphaCamera<'a, Q, S: ?Sized = AlphaScene> {
    pub tree: &'a Q,
    pub alpha: &'a S,
    pub clip: f32,
}

impl<Q: AlphaQuery, S: AlphaScenes + ?Sized> RayQuery for AlphaCamera<'_, Q, S> {
    /// Whether a hit that is not clipped away lies on the ray (the pass asks only for closest
    /// hits; this keeps the face whole).
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, stats: &mut C) -> bool {
        self.closest_hit(ray, stats).is_some()
    }
    #[inline]
    fn closest_hit<C: Counters>(&self, ray: &Ray, stats: &mut C) -> Option<Hit> {
        self.tree
            .closest_hit_alpha(ray, self.alpha, self.clip, stats)
    }
}

/// The camera trees with an alpha face (packets fall back to single rays).
pub enum AlphaCameraTree<'a> {
    Binary(&'a Bvh),
    Wide(&'a OrderedWideTree<'a>),
    TwoLevel(&'a TwoLevelQuery<'a>),
}

impl<'a> AlphaCameraTree<'a> {
    /// The camera query's tree.
    pub fn of(query: &'a CameraQuery<'a>) -> Self {
        match query {
            CameraQuery::Binary(b) => AlphaCameraTree::Binary(b),
            CameraQuery::Wide(w) => AlphaCameraTree::Wide(w),
            CameraQuery::TwoLevel(q) => AlphaCameraTree::TwoLevel(q),
        }
    }
}

macro_rules! with_camera_tree {
    ($tree:expr, $q:ident => $f:expr) => {
        match $tree {
            AlphaCameraTree::Binary($q) => $f,
            AlphaCameraTree::Wide($q) => $f,
            AlphaCameraTree::TwoLevel($q) => $f,
        }
    };
}
forward_alpha_query!(AlphaCameraTree<'_>, with_camera_tree);

/// A light's tree and order with an alpha face (packets fall back to single rays).
pub enum AlphaShadowTracer<'a> {
    Binary(OrderedBinary<'a>),
    Wide(&'a OrderedWideTree<'a>),
    Srdh(&'a SrdhBvh),
    TwoLevel(&'a TwoLevelQuery<'a>),
}

impl<'a> AlphaShadowTracer<'a> {
    /// The shadow tracer's tree and order.
    pub fn of(tracer: &'a ShadowTracer<'a>) -> Self {
        match tracer {
            ShadowTracer::Binary(b) => AlphaShadowTracer::Binary(*b),
            ShadowTracer::Wide(w) => AlphaShadowTracer::Wide(w),
            ShadowTracer::Srdh(t) => AlphaShadowTracer::Srdh(t),
            ShadowTracer::TwoLevel(q) => AlphaShadowTracer::TwoLevel(q),
        }
    }
}

macro_rules! with_shadow_tracer {
    ($tracer:expr, $q:ident => $f:expr) => {
        match $tracer {
            AlphaShadowTracer::Binary($q) => $f,
            AlphaShadowTracer::Wide($q) => $f,
            AlphaShadowTracer::Srdh($q) => $f,
            AlphaShadowTracer::TwoLevel($q) => $f,
        }
    };
}
forward_alpha_query!(AlphaShadowTracer<'_>, with_shadow_tracer);
