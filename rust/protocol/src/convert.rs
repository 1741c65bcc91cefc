//! Between the wire types and antumbra-core's: mesh uploads, frames, settings, results.
//!
//! Daemon side: [`mesh_from_upload`], [`scene_from_frame`], [`render_settings`],
//! [`frame_result_reply`]. Client side (Python client, recordings): [`upload_from_mesh`],
//! [`scene_to_messages`], [`planes_from_reply`], [`visible_from_reply`], [`stats_from_reply`].

use std::collections::HashMap;
use std::hash::BuildHasher;
use std::sync::Arc;

use antumbra_core::alpha::{AlphaImage, AlphaProgram, AlphaSource};
use antumbra_core::image::ImagePlane;
use antumbra_core::render::{FrameResult, RenderSettings, WarmUp};
use antumbra_core::scene::{
    AlphaMaterial, AreaShape, Camera, Light, LightKind, Mesh, Object, Resolution, Scene,
    SceneAlpha, SensorFit, TriangleRef, UvMap,
};
use antumbra_core::settings::NamedSettings;
use antumbra_core::stats::StatsRow;
use glam::DMat4;

use crate::bytes::{
    bytes_to_corner_normals, bytes_to_corner_uvs, bytes_to_f32s, bytes_to_triangle_refs,
    bytes_to_triangles, bytes_to_u32s, bytes_to_vec3s, corner_uvs_to_bytes, f32s_to_bytes,
    triangle_refs_to_bytes, triangles_to_bytes, u32s_to_bytes, vec3s_to_bytes,
};
use crate::error::ProtocolError;
use crate::instances;
use crate::limits::Limits;
use crate::messages::*;

/// Where the daemon keeps uploaded meshes (and alpha images), by content hash.
pub trait MeshStore {
    fn mesh(&self, hash: u64) -> Option<Arc<Mesh>>;
    /// The alpha image with this hash; a store of meshes alone holds none.
    fn image(&self, _hash: u64) -> Option<Arc<AlphaImage>> {
        None
    }
}

impl<S: BuildHasher> MeshStore for HashMap<u64, Arc<Mesh>, S> {
    fn mesh(&self, hash: u64) -> Option<Arc<Mesh>> {
        self.get(&hash).cloned()
    }
}

/// Meshes from one map and alpha images from another (a session's, a replay's).
impl<S: BuildHasher, T: BuildHasher> MeshStore
    for (
        &HashMap<u64, Arc<Mesh>, S>,
        &HashMap<u64, Arc<AlphaImage>, T>,
    )
{
    fn mesh(&self, hash: u64) -> Option<Arc<Mesh>> {
        self.0.get(&hash).cloned()
    }

    fn image(&self, hash: u64) -> Option<Arc<AlphaImage>> {
        self.1.get(&hash).cloned()
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
    let material_slots = bytes_to_u32s(
        &upload.material_slots,
        &format!("mesh '{name}'.material_slots"),
    )?;
    let uv_maps = uv_maps_from_upload(upload, limits)?;
    let mesh = Mesh::new(name.clone(), positions, triangles)
        .with_normals(normals)
        .with_alpha(material_slots, uv_maps);
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

/// An upload's UV maps: at most `max_uv_maps`, names distinct (a material finds its map by
/// name), whole corners; counts and values are checked with the mesh (`Mesh::validate`).
fn uv_maps_from_upload(upload: &UploadMesh, limits: &Limits) -> Result<Vec<UvMap>, ProtocolError> {
    let name = &upload.name;
    let count = upload.uv_maps.len() as u64;
    if count > limits.max_uv_maps {
        return Err(ProtocolError::LimitExceeded {
            what: format!("mesh '{name}': uv_maps"),
            value: count,
            limit: limits.max_uv_maps,
            limit_name: "max_uv_maps",
        });
    }
    let mut maps: Vec<UvMap> = Vec::with_capacity(upload.uv_maps.len());
    for map in &upload.uv_maps {
        let field = format!("mesh '{name}'.uv_maps['{}']", map.name);
        if maps.iter().any(|m| m.name == map.name) {
            return Err(ProtocolError::invalid(field, "two UV maps have this name"));
        }
        let corners = bytes_to_corner_uvs(&map.corners, &format!("{field}.corners"))?;
        maps.push(UvMap {
            name: map.name.clone(),
            corners,
        });
    }
    Ok(maps)
}

pub fn upload_from_mesh(mesh: &Mesh) -> UploadMesh {
    UploadMesh {
        hash: mesh.content_hash(),
        name: mesh.name.clone(),
        positions: vec3s_to_bytes(&mesh.positions),
        triangles: triangles_to_bytes(&mesh.triangles),
        normals: vec3s_to_bytes(mesh.normals.as_flattened()),
        material_slots: u32s_to_bytes(&mesh.material_slots),
        uv_maps: mesh
            .uv_maps
            .iter()
            .map(|m| UvMapState {
                name: m.name.clone(),
                corners: corner_uvs_to_bytes(&m.corners),
            })
            .collect(),
    }
}

// ---------------------------------------------------------------------------------------------
// Alpha images

/// How messages name an image: by its hash (images have no name on the wire).
pub fn image_label(hash: u64) -> String {
    format!("image {hash:#018x}")
}

/// Decodes and checks an image upload: the texel limit (before decoding), the byte length,
/// `width * height` finite texels, and that `hash` is the content hash of what arrived.
pub fn image_from_upload(
    upload: &UploadImage,
    limits: &Limits,
) -> Result<AlphaImage, ProtocolError> {
    crate::check::check_image_texels(upload, limits)?;
    let label = image_label(upload.hash);
    let texels = bytes_to_f32s(&upload.texels, &format!("{label}.texels"))?;
    let image = AlphaImage {
        width: upload.width,
        height: upload.height,
        texels,
    };
    image.validate(&label)?;
    let actual = image.content_hash();
    if actual != upload.hash {
        return Err(ProtocolError::ImageHashMismatch {
            declared: upload.hash,
            actual,
        });
    }
    Ok(image)
}

pub fn upload_from_image(image: &AlphaImage) -> UploadImage {
    UploadImage {
        hash: image.content_hash(),
        width: image.width,
        height: image.height,
        texels: f32s_to_bytes(&image.texels),
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
    let mut seen = std::collections::HashSet::new();
    frame_image_hashes(update)
        .filter(|&h| seen.insert(h) && store.image(h).is_none())
        .collect()
}

/// The frame's alpha images and materials: each distinct image once (the store's `Arc`), in
/// order of first use; errors name the frame and the material (an image the store lacks, a
/// constant that is not finite).
fn scene_alpha(update: &FrameUpdate, store: &impl MeshStore) -> Result<SceneAlpha, ProtocolError> {
    let frame = update.frame;
    let mut alpha = SceneAlpha::default();
    let mut index_of: HashMap<u64, u32> = HashMap::new();
    for (i, m) in update.alpha_materials.iter().enumerate() {
        let owner = format!("frame {frame}: alpha_materials[{i}] '{}'", m.name);
        let source = match m.source {
            AlphaSourceState::Constant { alpha } => AlphaSource::Constant(alpha),
            AlphaSourceState::Image {
                hash,
                interpolation,
                extension,
            } => {
                let image = match index_of.get(&hash) {
                    Some(&k) => k,
                    None => {
                        let image =
                            store
                                .image(hash)
                                .ok_or_else(|| ProtocolError::UnknownImage {
                                    frame,
                                    material: m.name.clone(),
                                    hash,
                                })?;
                        alpha.images.push(image);
                        let k = (alpha.images.len() - 1) as u32;
                        index_of.insert(hash, k);
                        k
                    }
                };
                // One UV map per material, by name: the mesh's map of that name is UV set 0.
                AlphaSource::Image {
                    image,
                    uv_set: 0,
                    interpolation,
                    extension,
                }
            }
        };
        let program = AlphaProgram {
            source,
            ops: m.ops.clone(),
        };
        program.validate(&owner, alpha.images.len(), 1)?;
        alpha.materials.push(AlphaMaterial {
            name: m.name.clone(),
            uv_map: m.uv_map.clone(),
            program,
        });
    }
    Ok(alpha)
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

/// A scene's alpha materials as the wire's, images by content hash (`image_hashes`, parallel
/// to `scene.alpha.images`).
fn alpha_materials_state(
    scene: &Scene,
    image_hashes: &[u64],
) -> Result<Vec<AlphaMaterialState>, ProtocolError> {
    scene
        .alpha
        .materials
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let source = match m.program.source {
                AlphaSource::Constant(alpha) => AlphaSourceState::Constant { alpha },
                AlphaSource::Image {
                    image,
                    interpolation,
                    extension,
                    ..
                } => AlphaSourceState::Image {
                    hash: *image_hashes.get(image as usize).ok_or_else(|| {
                        ProtocolError::invalid(
                            format!("alpha.materials[{i}] '{}'.source.image", m.name),
                            format!(
                                "image {image}, but the scene has {} alpha images",
                                image_hashes.len()
                            ),
                        )
                    })?,
                    interpolation,
                    extension,
                },
            };
            Ok(AlphaMaterialState {
                name: m.name.clone(),
                uv_map: m.uv_map.clone(),
                source,
                ops: m.program.ops.clone(),
            })
        })
        .collect()
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
    let mut images = std::collections::HashSet::new();
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
