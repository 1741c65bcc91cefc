//! Between the wire types and antumbra-core's: mesh uploads, frames, settings, results.
//!
//! Daemon side: [`mesh_from_upload`], [`scene_from_frame`], [`render_settings`],
//! [`frame_result_reply`]. Client side (Python client, recordings): [`upload_from_mesh`],
//! [`scene_to_messages`], [`planes_from_reply`], [`visible_from_reply`], [`stats_from_reply`].

use std::collections::HashMap;
use std::hash::BuildHasher;
use std::sync::Arc;

use antumbra_core::image::ImagePlane;
use antumbra_core::render::{FrameResult, RenderSettings, WarmUp};
use antumbra_core::scene::{
    AreaShape, Camera, Light, LightKind, Mesh, Object, Resolution, Scene, SensorFit, TriangleRef,
};
use antumbra_core::settings::NamedSettings;
use antumbra_core::stats::StatsRow;
use glam::DMat4;

use crate::bytes::{
    bytes_to_corner_normals, bytes_to_f32s, bytes_to_triangle_refs, bytes_to_triangles,
    bytes_to_vec3s, f32s_to_bytes, triangle_refs_to_bytes, triangles_to_bytes, vec3s_to_bytes,
};
use crate::error::ProtocolError;
use crate::instances;
use crate::limits::Limits;
use crate::messages::*;

/// Where the daemon keeps uploaded meshes, by content hash.
pub trait MeshStore {
    fn mesh(&self, hash: u64) -> Option<Arc<Mesh>>;
}

impl<S: BuildHasher> MeshStore for HashMap<u64, Arc<Mesh>, S> {
    fn mesh(&self, hash: u64) -> Option<Arc<Mesh>> {
        self.get(&hash).cloned()
    }
}

// ---------------------------------------------------------------------------------------------
// Meshes

/// Decodes and checks an upload: byte lengths (12 bytes a vertex, 12 a triangle), the triangle
/// limit, finite positions, indices in range, and that `hash` is the content hash of what
/// arrived. Every error names the mesh.
pub fn mesh_from_upload(upload: &UploadMesh, limits: &Limits) -> Result<Mesh, ProtocolError> {
    let name = &upload.name;
    let triangle_count = upload.triangles.len() as u64 / 12;
    if triangle_count > limits.max_triangles_per_mesh {
        return Err(ProtocolError::LimitExceeded {
            what: format!("mesh '{name}': triangles"),
            value: triangle_count,
            limit: limits.max_triangles_per_mesh,
            limit_name: "max_triangles_per_mesh",
        });
    }
    let positions = bytes_to_vec3s(&upload.positions, &format!("mesh '{name}'.positions"))?;
    let triangles = bytes_to_triangles(&upload.triangles, &format!("mesh '{name}'.triangles"))?;
    let normals = bytes_to_corner_normals(&upload.normals, &format!("mesh '{name}'.normals"))?;
    let mesh = Mesh::new(name.clone(), positions, triangles).with_normals(normals);
    mesh.validate()?;
    let actual = mesh.content_hash();
    if actual != upload.hash {
        return Err(ProtocolError::HashMismatch {
            mesh: name.clone(),
            declared: upload.hash,
            actual,
        });
    }
    Ok(mesh)
}

pub fn upload_from_mesh(mesh: &Mesh) -> UploadMesh {
    UploadMesh {
        hash: mesh.content_hash(),
        name: mesh.name.clone(),
        positions: vec3s_to_bytes(&mesh.positions),
        triangles: triangles_to_bytes(&mesh.triangles),
        normals: vec3s_to_bytes(mesh.normals.as_flattened()),
    }
}

// ---------------------------------------------------------------------------------------------
// Scene parts

impl From<SensorFit> for SensorFitState {
    fn from(f: SensorFit) -> Self {
        match f {
            SensorFit::Auto => SensorFitState::Auto,
            SensorFit::Horizontal => SensorFitState::Horizontal,
            SensorFit::Vertical => SensorFitState::Vertical,
        }
    }
}

impl From<SensorFitState> for SensorFit {
    fn from(f: SensorFitState) -> Self {
        match f {
            SensorFitState::Auto => SensorFit::Auto,
            SensorFitState::Horizontal => SensorFit::Horizontal,
            SensorFitState::Vertical => SensorFit::Vertical,
        }
    }
}

impl From<&Camera> for CameraState {
    fn from(c: &Camera) -> Self {
        CameraState {
            world_from_camera: c.world_from_camera.to_cols_array(),
            lens_mm: c.lens_mm,
            sensor_width_mm: c.sensor_width_mm,
            sensor_height_mm: c.sensor_height_mm,
            sensor_fit: c.sensor_fit.into(),
            shift_x: c.shift_x,
            shift_y: c.shift_y,
            clip_start: c.clip_start,
            clip_end: c.clip_end,
        }
    }
}

impl From<&CameraState> for Camera {
    fn from(c: &CameraState) -> Self {
        Camera {
            world_from_camera: DMat4::from_cols_array(&c.world_from_camera),
            lens_mm: c.lens_mm,
            sensor_width_mm: c.sensor_width_mm,
            sensor_height_mm: c.sensor_height_mm,
            sensor_fit: c.sensor_fit.into(),
            shift_x: c.shift_x,
            shift_y: c.shift_y,
            clip_start: c.clip_start,
            clip_end: c.clip_end,
        }
    }
}

impl From<AreaShape> for AreaShapeState {
    fn from(s: AreaShape) -> Self {
        match s {
            AreaShape::Square => AreaShapeState::Square,
            AreaShape::Rectangle => AreaShapeState::Rectangle,
            AreaShape::Disk => AreaShapeState::Disk,
            AreaShape::Ellipse => AreaShapeState::Ellipse,
        }
    }
}

impl From<AreaShapeState> for AreaShape {
    fn from(s: AreaShapeState) -> Self {
        match s {
            AreaShapeState::Square => AreaShape::Square,
            AreaShapeState::Rectangle => AreaShape::Rectangle,
            AreaShapeState::Disk => AreaShape::Disk,
            AreaShapeState::Ellipse => AreaShape::Ellipse,
        }
    }
}

impl From<LightKind> for LightKindState {
    fn from(k: LightKind) -> Self {
        match k {
            LightKind::Point { radius } => LightKindState::Point { radius },
            LightKind::Sun { angle } => LightKindState::Sun { angle },
            LightKind::Spot {
                radius,
                spot_size,
                spot_blend,
            } => LightKindState::Spot {
                radius,
                spot_size,
                spot_blend,
            },
            LightKind::Area {
                shape,
                size_x,
                size_y,
            } => LightKindState::Area {
                shape: shape.into(),
                size_x,
                size_y,
            },
        }
    }
}

impl From<LightKindState> for LightKind {
    fn from(k: LightKindState) -> Self {
        match k {
            LightKindState::Point { radius } => LightKind::Point { radius },
            LightKindState::Sun { angle } => LightKind::Sun { angle },
            LightKindState::Spot {
                radius,
                spot_size,
                spot_blend,
            } => LightKind::Spot {
                radius,
                spot_size,
                spot_blend,
            },
            LightKindState::Area {
                shape,
                size_x,
                size_y,
            } => LightKind::Area {
                shape: shape.into(),
                size_x,
                size_y,
            },
        }
    }
}

impl From<&Light> for LightState {
    fn from(l: &Light) -> Self {
        LightState {
            name: l.name.clone(),
            world_from_light: l.world_from_light.to_cols_array(),
            kind: l.kind.into(),
            casts_shadow: l.casts_shadow,
        }
    }
}

impl From<&LightState> for Light {
    fn from(l: &LightState) -> Self {
        Light {
            name: l.name.clone(),
            world_from_light: DMat4::from_cols_array(&l.world_from_light),
            kind: l.kind.into(),
            casts_shadow: l.casts_shadow,
        }
    }
}

impl From<&Resolution> for ResolutionState {
    fn from(r: &Resolution) -> Self {
        ResolutionState {
            x: r.x,
            y: r.y,
            percentage: r.percentage,
            pixel_aspect_x: r.pixel_aspect_x,
            pixel_aspect_y: r.pixel_aspect_y,
        }
    }
}

impl From<&ResolutionState> for Resolution {
    fn from(r: &ResolutionState) -> Self {
        Resolution {
            x: r.x,
            y: r.y,
            percentage: r.percentage,
            pixel_aspect_x: r.pixel_aspect_x,
            pixel_aspect_y: r.pixel_aspect_y,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Frames

/// The mesh hash of every object and every instance array of a frame, in frame order (with
/// repeats).
pub fn frame_mesh_hashes(update: &FrameUpdate) -> impl Iterator<Item = u64> + '_ {
    let objects = update.objects.iter().map(|o| o.mesh_hash);
    objects.chain(update.instances.iter().map(|a| a.mesh_hash))
}

/// The distinct mesh hashes of a frame that `store` lacks, in order of first use.
pub fn missing_meshes(update: &FrameUpdate, store: &impl MeshStore) -> Vec<u64> {
    let mut seen = std::collections::HashSet::new();
    frame_mesh_hashes(update)
        .filter(|&h| seen.insert(h) && store.mesh(h).is_none())
        .collect()
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
    for o in &update.objects {
        let mesh = mesh_index(o.mesh_hash, &o.name)?;
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
            materials: Vec::new(),
        });
    }
    for array in &update.instances {
        let mesh = mesh_index(array.mesh_hash, &format!("{}[]", array.name))?;
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
        alpha: Default::default(),
    })
}

/// The `FrameUpdate` of a scene; meshes are referred to by content hash.
pub fn frame_update_from_scene(scene: &Scene) -> Result<FrameUpdate, ProtocolError> {
    let hashes: Vec<u64> = scene.meshes.iter().map(|m| m.content_hash()).collect();
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
    })
}

/// A scene as the messages that recreate it on a daemon: one `UploadMesh` per distinct mesh
/// content that an object uses, then the `FrameUpdate`. Fails only for an object whose mesh
/// index is out of range.
pub fn scene_to_messages(scene: &Scene) -> Result<(Vec<Request>, Request), ProtocolError> {
    let update = frame_update_from_scene(scene)?;
    let mut uploaded = std::collections::HashSet::new();
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
    Ok((uploads, Request::FrameUpdate(update)))
}

// ---------------------------------------------------------------------------------------------
// Settings

/// The core settings of a request: [`NamedSettings::resolve`], every error naming its setting.
pub fn render_settings(s: &NamedSettings) -> Result<RenderSettings, ProtocolError> {
    Ok(s.resolve()?)
}

// ---------------------------------------------------------------------------------------------
// Results

pub(crate) fn image(plane: &ImagePlane, name: String) -> Image {
    Image {
        name,
        width: plane.width,
        height: plane.height,
        data: f32s_to_bytes(&plane.data),
    }
}

/// The reply for a rendered frame, with the requested passes. Image names follow the CLI's EXR
/// channels: `shadow.<light>` per mask, `combined`, `primary.N_B|N_L|N_T`,
/// `shadow.N_B|N_L|N_T`, then `primary.object` (the object-id pass), in that order.
pub fn frame_result_reply(
    result: &FrameResult,
    request_id: u64,
    passes: &Passes,
) -> FrameResultReply {
    let mut images = Vec::new();
    if passes.masks {
        let names = antumbra_core::output::mask_names(result);
        for (m, name) in result.masks.iter().zip(names) {
            images.push(image(m, name.plane));
        }
    }
    if passes.combined {
        images.push(image(&result.combined, result.combined.name.clone()));
    }
    if passes.heat_maps {
        if let Some(h) = &result.heat {
            for p in h.primary.iter().chain(h.shadow.iter()) {
                images.push(image(p, p.name.clone()));
            }
        }
    }
    if passes.object_ids {
        let plane = result.object_plane();
        images.push(image(&plane, plane.name.clone()));
    }
    FrameResultReply {
        request_id,
        frame: result.frame,
        width: result.width,
        height: result.height,
        images,
        stats: result.stats.clone(),
        visible: passes
            .visible_set
            .then(|| triangle_refs_to_bytes(&result.visible)),
    }
}

/// The reply to a warm-up (`RenderRequest::warm_up`): the frame's size, no images, no
/// statistics rows, and the visible set when `passes` asks for it.
pub fn warm_up_reply(warmed: &WarmUp, request_id: u64, passes: &Passes) -> FrameResultReply {
    FrameResultReply {
        request_id,
        frame: warmed.frame,
        width: warmed.width,
        height: warmed.height,
        images: Vec::new(),
        stats: Vec::new(),
        visible: passes
            .visible_set
            .then(|| triangle_refs_to_bytes(&warmed.visible)),
    }
}

/// The images of a result as core planes (named as on the wire), checking each one's size.
pub fn planes_from_reply(reply: &FrameResultReply) -> Result<Vec<ImagePlane>, ProtocolError> {
    reply
        .images
        .iter()
        .map(|img| plane_from_image(img, reply.frame))
        .collect()
}

/// One image of frame `frame`'s reply as a plane; data that does not fill its size is an error.
pub(crate) fn plane_from_image(img: &Image, frame: i32) -> Result<ImagePlane, ProtocolError> {
    let field = format!("frame {frame}: image '{}'.data", img.name);
    let data = bytes_to_f32s(&img.data, &field)?;
    let expected = img.width as u64 * img.height as u64;
    if data.len() as u64 != expected {
        return Err(ProtocolError::invalid(
            field,
            format!(
                "{}x{} needs {expected} values, has {}",
                img.width,
                img.height,
                data.len()
            ),
        ));
    }
    Ok(ImagePlane {
        name: img.name.clone(),
        width: img.width,
        height: img.height,
        data,
    })
}

/// The visible set of a result, if it was requested.
pub fn visible_from_reply(
    reply: &FrameResultReply,
) -> Result<Option<Vec<TriangleRef>>, ProtocolError> {
    reply
        .visible
        .as_ref()
        .map(|v| bytes_to_triangle_refs(v, &format!("frame {}: visible", reply.frame)))
        .transpose()
}

pub fn stats_from_reply(reply: &FrameResultReply) -> Vec<StatsRow> {
    reply.stats.clone()
}
