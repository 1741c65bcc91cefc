//! Frames both ways: a `FrameUpdate` into a core `Scene` against the stored meshes and images,
//! a `Scene` into the messages that recreate it; the hashes a frame uses and those a store lacks.

use std::collections::{HashMap, HashSet};
use std::sync::Arc;

use antumbra_core::alpha::AlphaSource;
use antumbra_core::scene::{Camera, Light, Mesh, Object, Resolution, Scene};
use glam::DMat4;

use super::alpha::{alpha_materials_state, scene_alpha};
use super::meshes::{upload_from_image, upload_from_mesh};
use super::MeshStore;
use crate::error::ProtocolError;
use crate::instances;
use crate::messages::{AlphaSourceState, FrameUpdate, LightState, ObjectState, Request};

/// The mesh hash of every object and every instance array of a frame, in frame order (with
/// repeats).
pub fn frame_mesh_hashes(update: &FrameUpdate) -> impl Iterator<Item = u64> + '_ {
    let objects = update.objects.iter().map(|o| o.mesh_hash);
    objects.chain(update.instances.iter().map(|a| a.mesh_hash))
}

/// The image hash of every alpha material of a frame that reads one, in order (with repeats).
pub fn frame_image_hashes(update: &FrameUpdate) -> impl Iterator<Item = u64> + '_ {
    update
        .alpha_materials
        .iter()
        .filter_map(|m| match m.source {
            AlphaSourceState::Image { hash, .. } => Some(hash),
            AlphaSourceState::Constant { .. } => None,
        })
}

/// The distinct image hashes of a frame that `store` lacks, in order of first use.
pub fn missing_images(update: &FrameUpdate, store: &impl MeshStore) -> Vec<u64> {
    distinct_lacking(frame_image_hashes(update), |h| store.image(h).is_none())
}

/// The distinct mesh hashes of a frame that `store` lacks, in order of first use.
pub fn missing_meshes(update: &FrameUpdate, store: &impl MeshStore) -> Vec<u64> {
    distinct_lacking(frame_mesh_hashes(update), |h| store.mesh(h).is_none())
}

/// The distinct hashes of `used` for which `lacks` holds, in order of first use.
pub fn distinct_lacking(
    used: impl IntoIterator<Item = u64>,
    mut lacks: impl FnMut(u64) -> bool,
) -> Vec<u64> {
    let mut seen = HashSet::new();
    used.into_iter()
        .filter(|&h| seen.insert(h) && lacks(h))
        .collect()
}

/// Checks an object's (or instance array's) slots against the frame's alpha materials.
fn check_materials(
    frame: i32,
    owner: &str,
    materials: &[Option<u32>],
    count: usize,
) -> Result<(), ProtocolError> {
    match materials
        .iter()
        .enumerate()
        .find(|(_, m)| m.is_some_and(|m| m as usize >= count))
    {
        Some((slot, m)) => Err(ProtocolError::invalid(
            format!("frame {frame}: {owner}.materials[{slot}]"),
            format!(
                "alpha material {}, but the frame has {count} alpha_materials",
                m.unwrap_or_default()
            ),
        )),
        None => Ok(()),
    }
}

/// Builds the frame's [`Scene`]. Each distinct mesh appears once in `Scene::meshes` (the store's
/// `Arc`, so unchanged meshes are the same `Arc` across frames and the renderer reuses its BVHs),
/// in order of first use. Checks objects' matrices, the camera, the resolution and the lights;
/// meshes were checked when they were uploaded.
pub fn scene_from_frame(
    update: &FrameUpdate,
    store: &impl MeshStore,
) -> Result<Scene, ProtocolError> {
    let frame = update.frame;
    let mut index_of: HashMap<u64, usize> = HashMap::new();
    let mut meshes: Vec<Arc<Mesh>> = Vec::new();
    let mut objects = Vec::with_capacity(instances::object_count(update) as usize);
    let mut mesh_index = |hash: u64, object: &str| -> Result<usize, ProtocolError> {
        if let Some(&i) = index_of.get(&hash) {
            return Ok(i);
        }
        let m = store.mesh(hash).ok_or_else(|| ProtocolError::UnknownMesh {
            frame,
            object: object.to_string(),
            hash,
        })?;
        meshes.push(m);
        index_of.insert(hash, meshes.len() - 1);
        Ok(meshes.len() - 1)
    };
    let alpha = scene_alpha(update, store)?;
    let material_count = alpha.materials.len();
    for o in &update.objects {
        let mesh = mesh_index(o.mesh_hash, &o.name)?;
        check_materials(
            frame,
            &format!("object '{}'", o.name),
            &o.materials,
            material_count,
        )?;
        if let Some(i) = o.world_from_object.iter().position(|v| !v.is_finite()) {
            return Err(antumbra_core::Error::NonFinite {
                owner: format!("object '{}' (frame {frame})", o.name),
                what: "world matrix",
                index: i,
                value: o.world_from_object[i],
            }
            .into());
        }
        objects.push(Object {
            name: o.name.clone(),
            mesh,
            world_from_object: DMat4::from_cols_array(&o.world_from_object),
            visible_to_camera: o.visible_to_camera,
            casts_shadow: o.casts_shadow,
            materials: o.materials.clone(),
        });
    }
    for array in &update.instances {
        let mesh = mesh_index(array.mesh_hash, &format!("{}[]", array.name))?;
        check_materials(
            frame,
            &format!("instance array '{}'", array.name),
            &array.materials,
            material_count,
        )?;
        objects.extend(instances::instance_objects(frame, array, mesh)?);
    }
    let in_frame = |error| ProtocolError::InFrame { frame, error };
    let camera = Camera::from(&update.camera);
    camera.validate().map_err(in_frame)?;
    let resolution = Resolution::from(&update.resolution);
    resolution.validate().map_err(in_frame)?;
    let lights: Vec<Light> = update.lights.iter().map(Light::from).collect();
    for light in &lights {
        light.validate().map_err(in_frame)?;
    }
    Ok(Scene {
        frame,
        meshes,
        objects,
        camera,
        lights,
        resolution,
        alpha,
    })
}

/// The `FrameUpdate` of a scene; meshes and alpha images are referred to by content hash.
pub fn frame_update_from_scene(scene: &Scene) -> Result<FrameUpdate, ProtocolError> {
    let hashes: Vec<u64> = scene.meshes.iter().map(|m| m.content_hash()).collect();
    let image_hashes: Vec<u64> = scene
        .alpha
        .images
        .iter()
        .map(|i| i.content_hash())
        .collect();
    let objects = scene
        .objects
        .iter()
        .map(|o| {
            let mesh_hash = *hashes.get(o.mesh).ok_or_else(|| {
                ProtocolError::Core(antumbra_core::Error::UnknownMesh {
                    object: o.name.clone(),
                    mesh: o.mesh,
                    mesh_count: scene.meshes.len(),
                })
            })?;
            Ok(ObjectState {
                name: o.name.clone(),
                mesh_hash,
                world_from_object: o.world_from_object.to_cols_array(),
                visible_to_camera: o.visible_to_camera,
                casts_shadow: o.casts_shadow,
                materials: o.materials.clone(),
            })
        })
        .collect::<Result<Vec<_>, ProtocolError>>()?;
    Ok(FrameUpdate {
        frame: scene.frame,
        objects,
        instances: Vec::new(),
        camera: (&scene.camera).into(),
        lights: scene.lights.iter().map(LightState::from).collect(),
        resolution: (&scene.resolution).into(),
        alpha_materials: alpha_materials_state(scene, &image_hashes)?,
    })
}

/// A scene as the messages that recreate it on a daemon: one `UploadMesh` per distinct mesh
/// content that an object uses, one `UploadImage` per distinct alpha image a material reads,
/// then the `FrameUpdate`. Fails only for an object's mesh or a material's image out of range.
pub fn scene_to_messages(scene: &Scene) -> Result<(Vec<Request>, Request), ProtocolError> {
    let update = frame_update_from_scene(scene)?;
    let mut uploaded = HashSet::new();
    let mut uploads = Vec::new();
    for o in &scene.objects {
        // frame_update_from_scene checked every index.
        if let Some(mesh) = scene.meshes.get(o.mesh) {
            let upload = upload_from_mesh(mesh);
            if uploaded.insert(upload.hash) {
                uploads.push(Request::UploadMesh(upload));
            }
        }
    }
    let mut images = HashSet::new();
    for m in &scene.alpha.materials {
        // frame_update_from_scene checked every image index.
        if let AlphaSource::Image { image, .. } = m.program.source {
            if let Some(image) = scene.alpha.images.get(image as usize) {
                let upload = upload_from_image(image);
                if images.insert(upload.hash) {
                    uploads.push(Request::UploadImage(upload));
                }
            }
        }
    }
    Ok((uploads, Request::FrameUpdate(update)))
}
