//! [`TwoLevelTrees`]: a two-level frame's trees as named state: a tree per mesh that several
//! objects share or that changes (kept across frames while the mesh is the same `Arc` and the
//! tree settings hold; a mesh no object uses any more is dropped), one group tree over the
//! static objects of meshes used once (as Cycles flattens single-user meshes into its top
//! level; kept while those objects stay as they are), and the frame's top levels over the
//! camera's objects and over the shadow casters (kept while no object changed).
//!
//! An object is dynamic from the first frame it changes (mesh, matrix or flags) on: its mesh
//! gets a tree of its own, so a character moving in a room rebuilds its own tree and the top
//! level, not the room's. A deforming mesh (a new `Arc`, the same triangle list) refits last
//! frame's tree of the same scene mesh while it holds its quality, and is rebuilt after.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

use glam::{DAffine3, Vec3};
use rayon::prelude::*;
use xxhash_rust::xxh3::Xxh3;

use super::frame_trees::GeometryKey;
use super::mesh_entry::{MeshEntry, TreeSettings, TwoLevelSorted};
use super::object_changes::ObjectChanges;
use super::two_level_query::{MeshQuery, TwoLevelQuery};
use super::wide_tree::WideTree;
use super::RenderSettings;
use crate::build::BuildSettings;
use crate::cancel::CancelToken;
use crate::geometry::{Aabb, Ray};
use crate::order::{OrderView, ShadowOrder, SortSettings, SortTables, SrdhSettings};
use crate::scene::{collect, scene_bounds, Object, RenderSpace, Scene, TriangleRef};
use crate::srdh::SrdhBvh;
use crate::trace::RayMode;
use crate::two_level::{
    instance_box, render_from_mesh, Instance, MeshTree, SrdhTop, TopLevel, TopOrdered, TopOrders,
    TwoLevel, GROUP,
};
use crate::Result;

/// The statistics columns of the trees a pass traces.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct TreeColumns {
    pub(super) build_ms: f64,
    pub(super) nodes: u64,
    pub(super) bytes: u64,
    /// Distinct triangles held (unique mesh triangles on two levels).
    pub(super) triangles: u64,
    pub(super) references: u64,
    pub(super) visible: u64,
    /// Mesh trees refit this frame (reported once, as `build_ms`).
    pub(super) refit: u64,
}

/// A two-level frame's trees. Cloning shares them (reference counted), as `compare` needs.
#[derive(Clone)]
pub struct TwoLevelTrees {
    /// This frame's mesh trees, by their index in the top levels' instances (the group's
    /// last).
    meshes: Vec<Arc<MeshEntry>>,
    /// The index in `meshes` of the static group's tree, if there is one.
    group: Option<u32>,
    /// The index in `meshes` of each of the scene's meshes (`u32::MAX`: no object uses it).
    by_scene_mesh: Vec<u32>,
    pub(super) space: RenderSpace,
    camera: Arc<TopLevel>,
    /// `None`: the camera's top level serves shadow rays too.
    shadow: Option<Arc<TopLevel>>,
    /// The shadow top level's orders (its per-tree order, its sorting tables), kept with it.
    shadow_orders: Arc<TopOrders>,
    key: GeometryKey,
    /// What the top levels were built with.
    top_settings: BuildSettings,
    /// Whether a finished frame reported these trees' build.
    pub(super) reported: bool,
    /// The build of this frame's new mesh trees and its top levels, ms.
    build_ms: f64,
    /// Mesh trees built this frame.
    meshes_built: usize,
    /// Mesh trees refit this frame.
    meshes_refit: usize,
}

/// How a mesh tree of this frame was made.
#[derive(Clone, Copy)]
enum Made {
    Built,
    Refit,
}

impl TwoLevelTrees {
    /// The frame's trees: last frame's mesh trees where the mesh and the tree settings are
    /// unchanged, new ones for the rest; the top levels kept when no object changed.
    pub(super) fn prepare(
        previous: Option<&TwoLevelTrees>,
        scene: &Scene,
        settings: &RenderSettings,
        changes: &ObjectChanges,
        cancel: &CancelToken,
    ) -> Result<Self> {
        let key = GeometryKey::of(scene);
        let tree_settings = TreeSettings::of(settings);
        if let Some(p) = previous.filter(|p| {
            p.key == key
                && p.top_settings == settings.build_settings
                && p.meshes.iter().all(|m| m.settings == tree_settings)
        }) {
            return Ok(TwoLevelTrees {
                meshes_built: 0,
                meshes_refit: 0,
                ..p.clone()
            });
        }
        let start = Instant::now();
        let kept: HashMap<usize, &Arc<MeshEntry>> = previous
            .map(|p| {
                p.meshes
                    .iter()
                    .filter(|m| m.settings == tree_settings)
                    .filter_map(|m| Some((Arc::as_ptr(m.mesh.as_ref()?) as usize, m)))
                    .collect()
            })
            .unwrap_or_default();
        let mut uses = vec![0u32; scene.meshes.len()];
        for o in &scene.objects {
            uses[o.mesh] = uses[o.mesh].saturating_add(1);
        }
        // The group: static objects of meshes used once, in both sets.
        let grouped: Vec<bool> = (scene.objects.iter().enumerate())
            .map(|(i, o)| {
                uses[o.mesh] == 1 && !changes.is_dynamic(i) && o.visible_to_camera && o.casts_shadow
            })
            .collect();
        // Last frame's render space while the scene still fits it at the same scale: an
        // object moving a little past the others' bounds does not move every group triangle.
        let (min, max) = scene_bounds(scene);
        let fitted = RenderSpace::fit(min, max);
        let fits = |s: &RenderSpace| {
            let (a, b) = (s.point(min), s.point(max));
            s.scale == fitted.scale && a.min_element() >= -1.0 && b.max_element() <= 1.0
        };
        let space = match previous {
            Some(p) if fits(&p.space) => p.space,
            _ => fitted,
        };
        let group_key = group_key(&space, changes, &grouped);
        let kept_group = previous
            .and_then(|p| p.group.map(|g| &p.meshes[g as usize]))
            .filter(|g| g.group_key == Some(group_key) && g.settings == tree_settings);
        let mut used = vec![false; scene.meshes.len()];
        for (o, g) in scene.objects.iter().zip(&grouped) {
            used[o.mesh] |= !g;
        }
        // Last frame's tree of each scene mesh, which a deformed mesh (a new `Arc`) refits: the
        // tree of the mesh of the same name where the name is unique in both frames (a
        // reordered mesh list keeps its pairs), otherwise of the mesh at the same index.
        let named_before = previous.map(|p| {
            unique_names(
                p.meshes
                    .iter()
                    .enumerate()
                    .filter_map(|(j, e)| e.mesh.as_deref().map(|m| (m.name.as_str(), j))),
            )
        });
        let named_now = unique_names(
            scene
                .meshes
                .iter()
                .map(|m| m.name.as_str())
                .enumerate()
                .map(|(i, n)| (n, i)),
        );
        let before = |i: usize| -> Option<&MeshEntry> {
            let p = previous?;
            let name = scene.meshes[i].name.as_str();
            let by_name = named_now
                .contains_key(name)
                .then(|| named_before.as_ref()?.get(name))
                .flatten();
            let j = match by_name {
                Some(&j) => j,
                None => *p.by_scene_mesh.get(i).filter(|&&j| j != u32::MAX)? as usize,
            };
            Some(&p.meshes[j])
        };
        // New mesh trees in parallel (many small meshes), each build parallel inside.
        let (built, group) = rayon::join(
            || -> Vec<Option<(Arc<MeshEntry>, Made)>> {
                (scene.meshes.par_iter().zip(&used).enumerate())
                    .map(|(i, (mesh, &used))| {
                        if !used || kept.contains_key(&(Arc::as_ptr(mesh) as usize)) {
                            return None;
                        }
                        let made = match before(i).and_then(|e| e.refit(mesh, &tree_settings)) {
                            Some(e) => (e, Made::Refit),
                            None => (MeshEntry::build(mesh, &tree_settings), Made::Built),
                        };
                        Some((Arc::new(made.0), made.1))
                    })
                    .collect()
            },
            || match kept_group {
                _ if !grouped.contains(&true) => None,
                Some(g) => Some((g.clone(), false)),
                None => {
                    let set = collect(scene, &space, |i, _| grouped[i]);
                    let entry = MeshEntry::group(set, group_key, &tree_settings);
                    Some((Arc::new(entry), true))
                }
            },
        );
        cancel.check()?;
        let mut meshes = Vec::new();
        let mut by_scene_mesh = vec![u32::MAX; scene.meshes.len()];
        let (mut meshes_built, mut meshes_refit) = (0, 0);
        for (i, (mesh, new)) in scene.meshes.iter().zip(built).enumerate() {
            if !used[i] {
                continue;
            }
            let entry = match new {
                Some((e, made)) => {
                    match made {
                        Made::Built => meshes_built += 1,
                        Made::Refit => meshes_refit += 1,
                    }
                    e
                }
                None => kept[&(Arc::as_ptr(mesh) as usize)].clone(),
            };
            by_scene_mesh[i] = meshes.len() as u32;
            meshes.push(entry);
        }
        let group = group.map(|(entry, built)| {
            meshes_built += built as usize;
            meshes.push(entry);
            meshes.len() as u32 - 1
        });
        let same = scene
            .objects
            .iter()
            .all(|o| o.visible_to_camera == o.casts_shadow);
        let placing = Placing {
            scene,
            space: &space,
            meshes: &meshes,
            by_scene_mesh: &by_scene_mesh,
            grouped: &grouped,
            group,
            settings: &settings.build_settings,
        };
        let camera = Arc::new(placing.top_level(|o| o.visible_to_camera));
        let shadow = (!same).then(|| Arc::new(placing.top_level(|o| o.casts_shadow)));
        let estimates: Vec<_> = meshes.iter().map(|m| m.rtsah_root).collect();
        let shadow_top = shadow.as_deref().unwrap_or(&camera);
        let shadow_orders = Arc::new(TopOrders::prepare(
            shadow_top,
            tree_settings.per_tree.as_ref(),
            &estimates,
        ));
        cancel.check()?;
        Ok(TwoLevelTrees {
            meshes,
            group,
            by_scene_mesh,
            space,
            camera,
            shadow,
            shadow_orders,
            key,
            top_settings: settings.build_settings,
            reported: false,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
            meshes_built,
            meshes_refit,
        })
    }

    /// The mesh tree an object outside the group places, and its index in the top levels'
    /// instances (`None` for a grouped object).
    pub(super) fn object_tree(&self, object: &Object) -> Option<(u32, &MeshTree)> {
        let index = *self.by_scene_mesh.get(object.mesh)?;
        Some((index, &self.meshes.get(index as usize)?.tree))
    }

    /// The static group's tree, if the frame has one.
    pub(super) fn group_tree(&self) -> Option<&MeshTree> {
        self.group.map(|g| &self.meshes[g as usize].tree)
    }

    /// Mesh trees this frame built (the others were refit or kept from the frame before).
    pub fn meshes_built(&self) -> usize {
        self.meshes_built
    }

    /// Mesh trees this frame refit: last frame's trees of deformed meshes, new boxes only.
    pub fn meshes_refit(&self) -> usize {
        self.meshes_refit
    }

    /// Whether `other` kept these top levels (no object changed).
    pub(super) fn same_tops(&self, other: &TwoLevelTrees) -> bool {
        Arc::ptr_eq(&self.camera, &other.camera)
    }

    fn shadow_top(&self) -> &TopLevel {
        self.shadow.as_deref().unwrap_or(&self.camera)
    }

    fn query<'a>(
        &'a self,
        top: &'a TopLevel,
        top_order: OrderView<'a>,
        order: &ShadowOrder,
        rays: RayMode,
    ) -> TwoLevelQuery<'a> {
        TwoLevelQuery {
            top,
            meshes: self.meshes.iter().map(|m| m.query(order, rays)).collect(),
            top_order,
            rays,
            srdh: None,
        }
    }

    /// What camera rays trace (closest hits read no order), batches as `rays`.
    pub fn camera_query(&self, rays: RayMode) -> TwoLevelQuery<'_> {
        self.query(
            &self.camera,
            OrderView::FrontToBack,
            &ShadowOrder::Fbto,
            rays,
        )
    }

    /// Nodes of the mesh trees' wide collapses and of the shadow top level, if every mesh
    /// tree has a collapse: what a light's sorting reads (`auto`'s estimate of its preparation).
    pub fn wide_nodes(&self) -> Option<u64> {
        let meshes: Option<u64> = (self.meshes.iter())
            .map(|m| m.wide.as_ref().map(|w| w.node_count() as u64))
            .sum();
        Some(meshes? + self.shadow_top().bvh.nodes.len() as u64)
    }

    /// Makes the sorting tables whose SATO `auto`'s SATO traces, in every mesh tree and the
    /// shadow top level without a fixed per-tree SATO; whether any were made now.
    pub fn prepare_sato(&self) -> bool {
        let meshes = (self.meshes.par_iter())
            .filter(|m| m.settings.per_tree != Some(ShadowOrder::Sato))
            .map(|m| m.sort_tables.get().is_none() && m.sortable().is_some())
            .reduce(|| false, |a, b| a | b);
        // The top level's SATO too, from its sorting tables.
        let top = self.shadow_orders.prepare_sato(self.shadow_top());
        meshes | top
    }

    /// Whether every mesh tree and the shadow top level have their sorting tables (and so
    /// SATO) made.
    pub fn sort_tables_ready(&self) -> bool {
        self.meshes.iter().all(|m| m.sort_tables.get().is_some())
            && self.shadow_orders.tables_ready()
    }

    /// What a light's shadow rays trace with `order` (fbto, stored, SATO or the per-tree
    /// order, on the top level as on the mesh trees), batches as `rays`.
    pub fn shadow_query(&self, order: &ShadowOrder, rays: RayMode) -> TwoLevelQuery<'_> {
        let top_order = self.shadow_orders.view(order);
        self.query(self.shadow_top(), top_order, order, rays)
    }

    /// Sorts the children of every mesh tree and of the shadow top level for one light (Ogaki
    /// & Derouet-Jourdan per tree): its representative `rays` are traced through both levels
    /// once, the top level and each mesh tree in the logging order; each mesh's stoppers, from
    /// whichever of its instances, sort that mesh's tree, and the instances that stopped the
    /// rays sort the top level. `None` when the mesh trees have no wide collapse to permute
    /// (the settings did not ask for sorting).
    pub fn sort_for_light(&self, rays: &[Ray], settings: &SortSettings) -> Option<TwoLevelSorted> {
        let sortable: Vec<(&WideTree, &SortTables)> = self
            .meshes
            .par_iter()
            .map(|m| m.sortable())
            .collect::<Option<_>>()?;
        let logging: Vec<(&WideTree, OrderView)> = (sortable.iter())
            .map(|(w, t)| (*w, t.logging_view(settings.logging)))
            .collect();
        let top = self.shadow_top();
        let levels = TopOrdered {
            levels: TwoLevel {
                top,
                meshes: &logging,
            },
            order: self
                .shadow_orders
                .tables(top)
                .logging_view(settings.logging),
        };
        let stopped: Vec<(u32, u32, u32)> = rays
            .par_iter()
            .with_min_len(256)
            .filter_map(|r| {
                levels.first_stopper(r, |(w, view), local| w.occluder_leaf(local, *view))
            })
            .collect();
        let mut stoppers = vec![Vec::new(); self.meshes.len()];
        for &(_, mesh, first) in &stopped {
            stoppers[mesh as usize].push(first);
        }
        let instances: Vec<u32> = stopped.iter().map(|&(instance, _, _)| instance).collect();
        let (top_sorted, per_mesh) = rayon::join(
            || {
                (!instances.is_empty())
                    .then(|| self.shadow_orders.sort_for_light(top, &instances, settings))
            },
            || {
                (sortable.par_iter().zip(&stoppers))
                    .map(|((w, t), s)| {
                        (!s.is_empty()).then(|| w.sort_from_stoppers(t, s, settings))
                    })
                    .collect()
            },
        );
        Some(TwoLevelSorted {
            top: top_sorted,
            per_mesh,
            logging: settings.logging,
        })
    }

    /// What a light's shadow rays trace with the light's sorted top level and mesh trees,
    /// batches as `rays`.
    pub fn sorted_shadow_query<'a>(
        &'a self,
        sorted: &'a TwoLevelSorted,
        rays: RayMode,
    ) -> TwoLevelQuery<'a> {
        let meshes = (self.meshes.iter().zip(&sorted.per_mesh))
            .map(|(m, order)| match (m.sortable(), order) {
                (Some((wide, _)), Some(o)) => {
                    MeshQuery::Wide(wide.ordered(o.view()).with_rays(rays))
                }
                (Some((wide, tables)), None) => MeshQuery::Wide(
                    wide.ordered(tables.logging_view(sorted.logging))
                        .with_rays(rays),
                ),
                // Not reached: `sorted` was made on these trees, every one with a collapse.
                (None, _) => m.query(&ShadowOrder::Fbto, rays),
            })
            .collect();
        let top = self.shadow_top();
        let top_order = match &sorted.top {
            Some(o) => o.view(),
            None => (self.shadow_orders.tables(top)).logging_view(sorted.logging),
        };
        TwoLevelQuery {
            top,
            meshes,
            top_order,
            rays,
            srdh: None,
        }
    }

    /// The render-space boxes of the shadow top level's instances, in its order: the boxes it
    /// was built over (made as [`Placing`] made them; the top level does not keep them).
    fn shadow_instance_boxes(&self, objects: &[Object]) -> Vec<Aabb> {
        (self.shadow_top().instances.par_iter())
            .map(|instance| {
                let tree = &self.meshes[instance.mesh as usize].tree;
                let object = (instance.object != GROUP).then(|| &objects[instance.object as usize]);
                instance_box(&placement(&self.space, object, tree), &tree.bounds)
            })
            .collect()
    }

    /// One light's SRDH tree over the shadow top level's instances ([`SrdhTop`]) from the hit
    /// lists of its representative `rays` through both levels (each mesh tree front to back);
    /// `None` when fewer than `settings.min_occluded` of them are occluded.
    pub fn srdh_for_light(
        &self,
        objects: &[Object],
        rays: Vec<Ray>,
        settings: &SrdhSettings,
        sah: &BuildSettings,
    ) -> Option<SrdhTop> {
        let query = self.shadow_query(&ShadowOrder::Fbto, RayMode::Single);
        let set = query.levels().instance_ray_set(rays);
        (!set.is_empty() && set.occluded_fraction() >= settings.min_occluded as f64)
            .then(|| SrdhTop::build(self.shadow_instance_boxes(objects), &set, settings, sah))
    }

    /// What a light's shadow rays trace with its SRDH tree over the instances: the tree's
    /// kernels to the instances, each mesh tree front to back, one ray at a time.
    pub fn srdh_shadow_query<'a>(&'a self, srdh: &'a SrdhTop) -> TwoLevelQuery<'a> {
        TwoLevelQuery {
            srdh: Some(srdh),
            ..self.shadow_query(&ShadowOrder::Fbto, RayMode::Single)
        }
    }

    /// The render-space vertices and the reference of a hit's triangle.
    pub(super) fn hit_triangle(
        &self,
        objects: &[Object],
        instance: u32,
        triangle: u32,
    ) -> ([Vec3; 3], TriangleRef) {
        if instance == GROUP {
            let tree = &self.meshes[self.group.expect("a group hit has a group") as usize].tree;
            let t = triangle as usize;
            let reference = TriangleRef {
                object: tree.objects[t],
                primitive: tree.primitives[t],
            };
            return (tree.triangles[t], reference);
        }
        let object = &objects[instance as usize];
        let tree = &self.meshes[self.by_scene_mesh[object.mesh] as usize].tree;
        let m = render_from_mesh(&self.space, &object.world_from_object, &tree.space);
        let vertices =
            tree.triangles[triangle as usize].map(|v| m.transform_point3(v.as_dvec3()).as_vec3());
        let reference = TriangleRef {
            object: instance,
            primitive: tree.primitives[triangle as usize],
        };
        (vertices, reference)
    }

    /// Instances in the top levels (camera and shadow) and unique triangles held.
    pub fn counts(&self) -> (usize, usize) {
        let instances = self.camera.len() + self.shadow.as_ref().map_or(0, |s| s.len());
        let triangles = self.meshes.iter().map(|m| m.tree.triangles.len()).sum();
        (instances, triangles)
    }

    /// Instances in the top level shadow rays trace.
    pub fn shadow_instances(&self) -> usize {
        self.shadow_top().len()
    }

    /// Bytes held by the trees: the mesh trees (and their collapses), the top levels.
    pub fn bytes(&self) -> usize {
        let meshes: u64 = self
            .meshes
            .iter()
            .map(|m| m.tree.bytes() as u64 + m.wide.as_ref().map_or(0, |w| w.bytes() as u64))
            .sum();
        meshes as usize + self.camera.bytes() + self.shadow.as_ref().map_or(0, |s| s.bytes())
    }

    /// The statistics columns of the trees `top` heads.
    fn columns(&self, top: &TopLevel) -> TreeColumns {
        let (mut nodes, mut bytes) = (top.bvh.nodes.len() as u64, top.bytes() as u64);
        for m in &self.meshes {
            let (n, b) = m.nodes_and_bytes();
            nodes += n;
            bytes += b;
        }
        let triangles = self.counts().1 as u64;
        TreeColumns {
            build_ms: if self.reported { 0.0 } else { self.build_ms },
            refit: if self.reported {
                0
            } else {
                self.meshes_refit as u64
            },
            nodes,
            bytes,
            triangles,
            references: triangles,
            visible: 0,
        }
    }

    pub(super) fn camera_columns(&self) -> TreeColumns {
        self.columns(&self.camera)
    }

    /// The columns of the trees a light's rays traced: with its SRDH tree (`own`) in the
    /// shadow top level's place, that tree's nodes and bytes in the top level's.
    pub(super) fn shadow_columns(&self, own: Option<&SrdhBvh>) -> TreeColumns {
        let top = self.shadow_top();
        let mut c = self.columns(top);
        if let Some(own) = own {
            c.nodes = c.nodes - top.bvh.nodes.len() as u64 + own.bvh.nodes.len() as u64;
            c.bytes = c.bytes - top.bvh.bytes() as u64 + own.bytes() as u64;
        }
        c
    }

    /// The mesh trees' own build, collapse and order times, summed (ms), for reports.
    pub fn mesh_build_ms(&self) -> f64 {
        self.meshes.iter().map(|m| m.build_ms).sum()
    }
}

/// What the top levels are made of.
struct Placing<'a> {
    scene: &'a Scene,
    space: &'a RenderSpace,
    meshes: &'a [Arc<MeshEntry>],
    by_scene_mesh: &'a [u32],
    /// Objects in the group (placed by its one instance).
    grouped: &'a [bool],
    group: Option<u32>,
    settings: &'a BuildSettings,
}

impl Placing<'_> {
    /// The top level over the objects `include` picks: an instance per object outside the
    /// group placing its mesh tree (objects scaled to nothing are left out), and the group's
    /// one instance (render space as it is), built over their render-space boxes.
    fn top_level(&self, include: fn(&Object) -> bool) -> TopLevel {
        let mut placed: Vec<(Instance, Aabb)> = (self.scene.objects.par_iter().enumerate())
            .filter(|(i, o)| include(o) && !self.grouped[*i])
            .filter_map(|(i, o)| {
                let index = self.by_scene_mesh[o.mesh];
                let tree = &self.meshes[index as usize].tree;
                if tree.triangles.is_empty() {
                    return None;
                }
                let m = placement(self.space, Some(o), tree);
                let instance = Instance::new(&m, index, i as u32)?;
                Some((instance, instance_box(&m, &tree.bounds)))
            })
            .collect();
        if let Some(g) = self.group {
            let tree = &self.meshes[g as usize].tree;
            if !tree.triangles.is_empty() {
                let identity = placement(self.space, None, tree);
                let instance = Instance::new(&identity, g, GROUP).expect("invertible");
                placed.push((instance, instance_box(&identity, &tree.bounds)));
            }
        }
        let (instances, boxes): (Vec<Instance>, Vec<Aabb>) = placed.into_iter().unzip();
        TopLevel::build(instances, boxes, self.settings)
    }
}

/// Render space from the mesh space of `tree` as `object` places it; the group's tree
/// (`None`) is in render space already.
fn placement(space: &RenderSpace, object: Option<&Object>, tree: &MeshTree) -> DAffine3 {
    match object {
        Some(o) => render_from_mesh(space, &o.world_from_object, &tree.space),
        None => DAffine3::IDENTITY,
    }
}

/// The group's members (indices and signatures) and the render space, hashed: the group's
/// tree is kept while it holds.
fn group_key(space: &RenderSpace, changes: &ObjectChanges, grouped: &[bool]) -> u128 {
    let mut h = Xxh3::new();
    for v in [space.origin.x, space.origin.y, space.origin.z, space.scale] {
        h.update(&v.to_bits().to_le_bytes());
    }
    for (i, _) in grouped.iter().enumerate().filter(|(_, g)| **g) {
        h.update(&(i as u64).to_le_bytes());
        h.update(&changes.signature(i).to_le_bytes());
    }
    h.digest128()
}

/// The names that occur once among `items` (name, index), with their index.
fn unique_names<'a>(items: impl Iterator<Item = (&'a str, usize)>) -> HashMap<&'a str, usize> {
    let mut seen: HashMap<&str, Option<usize>> = HashMap::new();
    for (name, index) in items {
        seen.entry(name)
            .and_modify(|e| *e = None)
            .or_insert(Some(index));
    }
    seen.into_iter()
        .filter_map(|(name, index)| Some((name, index?)))
        .collect()
}
