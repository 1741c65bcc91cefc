//! Python values (dicts with Blender's field names) to the protocol's messages, with checks that
//! name the field at fault. Both sessions build their requests here, so the socket and the
//! in-process paths see the same messages. One file per part: `fields` (reading values),
//! `objects` (objects, instance arrays), `parts` (camera, lights, resolution), `alpha` (alpha
//! materials); the frame, the passes and hash lists here.

mod alpha;
mod fields;
mod objects;
mod parts;

use antumbra_core::scene::{Camera, Light, Resolution};
use antumbra_protocol::{check_limits, FrameUpdate, Limits, Passes, Request};
use pyo3::prelude::*;

use crate::error::{ClientError, ClientResult};
use alpha::alpha_material;
use fields::{items, mesh_hash, string};
use objects::{instance_array, object};
use parts::{camera, light, resolution};

pub use fields::{frame_number, repeat_count};

/// A frame's scene state from Python values; `limits` bound the alpha materials read.
#[allow(clippy::too_many_arguments)] // the Python method's arguments
pub fn frame_update(
    frame: &Bound<'_, PyAny>,
    objects: &Bound<'_, PyAny>,
    camera_v: &Bound<'_, PyAny>,
    lights: &Bound<'_, PyAny>,
    resolution_v: &Bound<'_, PyAny>,
    instances: Option<&Bound<'_, PyAny>>,
    alpha_materials: Option<&Bound<'_, PyAny>>,
    limits: &Limits,
) -> ClientResult<FrameUpdate> {
    let frame = frame_number(frame, "frame")?;
    let alpha_materials = match alpha_materials.filter(|v| !v.is_none()) {
        None => Vec::new(),
        Some(v) => {
            let list = items(v, "alpha_materials")?;
            if list.len() as u64 > limits.max_alpha_materials {
                return Err(ClientError::invalid(format!(
                    "frame {frame}: alpha_materials: {} materials exceed the limit of {} \
                     (max_alpha_materials)",
                    list.len(),
                    limits.max_alpha_materials
                )));
            }
            list.iter()
                .enumerate()
                .map(|(i, m)| alpha_material(m, i, limits))
                .collect::<ClientResult<Vec<_>>>()?
        }
    };
    let material_count = alpha_materials.len();
    let objects = items(objects, "objects")?
        .iter()
        .enumerate()
        .map(|(i, o)| object(o, i, material_count))
        .collect::<ClientResult<Vec<_>>>()?;
    let lights = items(lights, "lights")?
        .iter()
        .enumerate()
        .map(|(i, l)| light(l, i))
        .collect::<ClientResult<Vec<_>>>()?;
    let instances = match instances.filter(|v| !v.is_none()) {
        None => Vec::new(),
        Some(v) => items(v, "instances")?
            .iter()
            .enumerate()
            .map(|(i, a)| instance_array(a, i, material_count))
            .collect::<ClientResult<Vec<_>>>()?,
    };
    let update = FrameUpdate {
        frame,
        objects,
        instances,
        camera: camera(camera_v, "camera")?,
        lights,
        resolution: resolution(resolution_v)?,
        alpha_materials,
    };
    Ok(update)
}

/// The checks a daemon makes on a frame that do not need its meshes (camera, resolution,
/// lights, limits), made before sending so that both sessions refuse bad input the same way.
pub fn check_frame(update: &FrameUpdate, limits: &Limits) -> ClientResult<()> {
    let frame = update.frame;
    let in_frame = |e: antumbra_core::Error| ClientError::invalid(format!("frame {frame}: {e}"));
    Camera::from(&update.camera).validate().map_err(in_frame)?;
    Resolution::from(&update.resolution)
        .validate()
        .map_err(in_frame)?;
    for l in &update.lights {
        Light::from(l).validate().map_err(in_frame)?;
    }
    check_limits(&Request::FrameUpdate(update.clone()), limits)
        .map_err(|e| ClientError::invalid(e.to_string()))
}

pub const PASS_NAMES: &[&str] = &["masks", "combined", "heat_maps", "visible", "object_ids"];

pub fn passes(v: &Bound<'_, PyAny>) -> ClientResult<Passes> {
    let mut p = Passes {
        masks: false,
        combined: false,
        heat_maps: false,
        visible_set: false,
        object_ids: false,
    };
    for item in items(v, "passes")? {
        let name = string(&item, "passes[]")?;
        match name.as_str() {
            "masks" => p.masks = true,
            "combined" => p.combined = true,
            "heat_maps" => p.heat_maps = true,
            "visible" => p.visible_set = true,
            "object_ids" => p.object_ids = true,
            other => {
                return Err(ClientError::invalid(format!(
                    "passes: unknown pass '{other}' (known: {})",
                    PASS_NAMES.join(", ")
                )))
            }
        }
    }
    Ok(p)
}

/// `missing_meshes`' argument: an iterable of hashes.
pub fn hashes(v: &Bound<'_, PyAny>) -> ClientResult<Vec<u64>> {
    items(v, "hashes")?
        .iter()
        .enumerate()
        .map(|(i, h)| mesh_hash(h, &format!("hashes[{i}]")))
        .collect()
}
