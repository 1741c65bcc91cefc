//! Reading a recording (`.antrec`) back into Python values: its meshes as numpy arrays and its
//! frames as the same dicts `frame_update` takes (Blender's field names). The Blender add-on
//! uses it to turn a recorded or built-in animation into a `.blend`.

use antumbra_protocol::{
    image_from_upload,
    instances::{resolve_unchanged, MATRIX_BYTES},
    mesh_from_upload, AlphaMaterialState, AlphaOp, AlphaSourceState, AreaShapeState, CameraState,
    Extension, FrameUpdate, InstanceArrayState, Interpolation, LightKindState, LightState,
    ObjectState, RecordingReader, Request, ResolutionState, SensorFitState,
};
use numpy::ndarray::Array2;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::error::{ClientError, ClientResult};

/// A column-major protocol matrix as Blender's row-major nested lists.
fn rows(m: &[f64; 16]) -> [[f64; 4]; 4] {
    std::array::from_fn(|r| std::array::from_fn(|c| m[4 * c + r]))
}

fn object_dict<'py>(py: Python<'py>, o: &ObjectState) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("name", &o.name)?;
    d.set_item("mesh_hash", o.mesh_hash)?;
    d.set_item("matrix_world", rows(&o.world_from_object))?;
    d.set_item("visible_camera", o.visible_to_camera)?;
    d.set_item("visible_shadow", o.casts_shadow)?;
    if !o.materials.is_empty() {
        d.set_item("materials", o.materials.clone())?;
    }
    Ok(d)
}

/// An alpha material as `frame_update`'s `alpha_materials` takes it (the exporter's contract
/// with its name; an image by the hash `upload_image` returns).
fn alpha_material_dict<'py>(
    py: Python<'py>,
    m: &AlphaMaterialState,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("name", &m.name)?;
    match m.source {
        AlphaSourceState::Constant { alpha } => {
            d.set_item("kind", "constant")?;
            d.set_item("alpha", alpha)?;
        }
        AlphaSourceState::Image {
            hash,
            interpolation,
            extension,
        } => {
            d.set_item("kind", "texture")?;
            d.set_item("image", hash)?;
            d.set_item("uv_map", &m.uv_map)?;
            let interpolation = match interpolation {
                Interpolation::Closest => "Closest",
                Interpolation::Linear => "Linear",
                Interpolation::Cubic => "Cubic",
            };
            d.set_item("interpolation", interpolation)?;
            let extension = match extension {
                Extension::Repeat => "REPEAT",
                Extension::Extend => "EXTEND",
                Extension::Clip => "CLIP",
                Extension::Mirror => "MIRROR",
            };
            d.set_item("extension", extension)?;
        }
    }
    let ops = PyList::empty(py);
    for op in &m.ops {
        let item = match *op {
            AlphaOp::Multiply(c) => ("MULTIPLY", Some(c)),
            AlphaOp::Add(c) => ("ADD", Some(c)),
            AlphaOp::Subtract(c) => ("SUBTRACT", Some(c)),
            AlphaOp::Power(c) => ("POWER", Some(c)),
            AlphaOp::GreaterThan(c) => ("GREATER_THAN", Some(c)),
            AlphaOp::LessThan(c) => ("LESS_THAN", Some(c)),
            AlphaOp::OneMinus => ("ONE_MINUS", None),
            AlphaOp::Clamp => ("CLAMP", None),
        };
        match item {
            (name, Some(c)) => ops.append(PyList::new(
                py,
                [
                    name.into_pyobject(py)?.into_any(),
                    c.into_pyobject(py)?.into_any(),
                ],
            )?)?,
            (name, None) => ops.append(PyList::new(py, [name])?)?,
        }
    }
    d.set_item("ops", ops)?;
    Ok(d)
}

/// An instance array as `frame_update` takes it: matrices float32 (n, 4, 4), ids uint32 (n,)
/// when the array names its instances.
fn instance_dict<'py>(py: Python<'py>, a: &InstanceArrayState) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("name", &a.name)?;
    d.set_item("mesh_hash", a.mesh_hash)?;
    let count = a.matrices.len() / MATRIX_BYTES;
    let f32s = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    let mut matrices = Vec::with_capacity(count * 16);
    for m in a.matrices.chunks_exact(MATRIX_BYTES) {
        matrices.extend(m.chunks_exact(4).map(f32s));
        matrices.extend([0.0, 0.0, 0.0, 1.0]);
    }
    let matrices = numpy::ndarray::Array3::from_shape_vec((count, 4, 4), matrices)
        .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
    d.set_item("matrices", matrices.into_pyarray(py))?;
    if !a.ids.is_empty() {
        let ids: Vec<u32> = a
            .ids
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        d.set_item("ids", ids.into_pyarray(py))?;
    }
    d.set_item("visible_camera", a.visible_to_camera)?;
    d.set_item("visible_shadow", a.casts_shadow)?;
    if !a.materials.is_empty() {
        d.set_item("materials", a.materials.clone())?;
    }
    Ok(d)
}

fn camera_dict<'py>(py: Python<'py>, c: &CameraState) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("matrix_world", rows(&c.world_from_camera))?;
    d.set_item("lens", c.lens_mm)?;
    d.set_item("sensor_width", c.sensor_width_mm)?;
    d.set_item("sensor_height", c.sensor_height_mm)?;
    let fit = match c.sensor_fit {
        SensorFitState::Auto => "AUTO",
        SensorFitState::Horizontal => "HORIZONTAL",
        SensorFitState::Vertical => "VERTICAL",
    };
    d.set_item("sensor_fit", fit)?;
    d.set_item("shift_x", c.shift_x)?;
    d.set_item("shift_y", c.shift_y)?;
    d.set_item("clip_start", c.clip_start)?;
    d.set_item("clip_end", c.clip_end)?;
    Ok(d)
}

fn light_dict<'py>(py: Python<'py>, l: &LightState) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("name", &l.name)?;
    d.set_item("matrix_world", rows(&l.world_from_light))?;
    d.set_item("use_shadow", l.casts_shadow)?;
    match l.kind {
        LightKindState::Point { radius } => {
            d.set_item("type", "POINT")?;
            d.set_item("shadow_soft_size", radius)?;
        }
        LightKindState::Sun { angle } => {
            d.set_item("type", "SUN")?;
            d.set_item("angle", angle)?;
        }
        LightKindState::Spot {
            radius,
            spot_size,
            spot_blend,
        } => {
            d.set_item("type", "SPOT")?;
            d.set_item("shadow_soft_size", radius)?;
            d.set_item("spot_size", spot_size)?;
            d.set_item("spot_blend", spot_blend)?;
        }
        LightKindState::Area {
            shape,
            size_x,
            size_y,
        } => {
            d.set_item("type", "AREA")?;
            let shape = match shape {
                AreaShapeState::Square => "SQUARE",
                AreaShapeState::Rectangle => "RECTANGLE",
                AreaShapeState::Disk => "DISK",
                AreaShapeState::Ellipse => "ELLIPSE",
            };
            d.set_item("shape", shape)?;
            d.set_item("size", size_x)?;
            d.set_item("size_y", size_y)?;
        }
    }
    Ok(d)
}

fn resolution_dict<'py>(py: Python<'py>, r: &ResolutionState) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("x", r.x)?;
    d.set_item("y", r.y)?;
    d.set_item("percentage", r.percentage)?;
    d.set_item("pixel_aspect_x", r.pixel_aspect_x)?;
    d.set_item("pixel_aspect_y", r.pixel_aspect_y)?;
    Ok(d)
}

fn frame_dict<'py>(py: Python<'py>, f: &FrameUpdate) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("frame", f.frame)?;
    let objects = PyList::empty(py);
    for o in &f.objects {
        objects.append(object_dict(py, o)?)?;
    }
    d.set_item("objects", objects)?;
    if !f.instances.is_empty() {
        let instances = PyList::empty(py);
        for a in &f.instances {
            instances.append(instance_dict(py, a)?)?;
        }
        d.set_item("instances", instances)?;
    }
    d.set_item("camera", camera_dict(py, &f.camera)?)?;
    let lights = PyList::empty(py);
    for l in &f.lights {
        lights.append(light_dict(py, l)?)?;
    }
    d.set_item("lights", lights)?;
    d.set_item("resolution", resolution_dict(py, &f.resolution)?)?;
    if !f.alpha_materials.is_empty() {
        let materials = PyList::empty(py);
        for m in &f.alpha_materials {
            materials.append(alpha_material_dict(py, m)?)?;
        }
        d.set_item("alpha_materials", materials)?;
    }
    Ok(d)
}

/// `{"meshes": {hash: {"name", "positions": float32 (n, 3), "triangles": uint32 (m, 3), and
/// for a mesh with corner normals "normals": float32 (3m, 3), with slots "material_slots":
/// uint32 (m,), with UV maps "uv_maps": {name: float32 (m, 3, 2)}}}, "images": {hash: float32
/// (height, width), rows bottom first}, "frames": [frame dict, ...]}` in the file's order.
/// Meshes and images are checked (hash, finite values, indices in range) as the daemon checks
/// an upload.
pub fn read_recording<'py>(py: Python<'py>, path: &str) -> ClientResult<Bound<'py, PyDict>> {
    let fail = |e: &dyn std::fmt::Display| ClientError::invalid(format!("recording {path}: {e}"));
    let mut reader = RecordingReader::open(path).map_err(|e| fail(&e))?;
    let limits = reader.limits().clone();
    let meshes = PyDict::new(py);
    let images = PyDict::new(py);
    let frames = PyList::empty(py);
    let mut previous: Option<FrameUpdate> = None;
    while let Some(request) = py.detach(|| reader.next_request()).map_err(|e| fail(&e))? {
        match request {
            Request::UploadMesh(upload) => {
                let mesh = py
                    .detach(|| mesh_from_upload(&upload, &limits))
                    .map_err(|e| fail(&e))?;
                let flat_p: Vec<f32> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
                let flat_t: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
                let entry = PyDict::new(py);
                entry.set_item("name", &mesh.name)?;
                let p = Array2::from_shape_vec((mesh.positions.len(), 3), flat_p)
                    .expect("three floats per position");
                let t = Array2::from_shape_vec((mesh.triangles.len(), 3), flat_t)
                    .expect("three indices per triangle");
                entry.set_item("positions", p.into_pyarray(py))?;
                entry.set_item("triangles", t.into_pyarray(py))?;
                if !mesh.normals.is_empty() {
                    let corners = mesh.normals.as_flattened();
                    let flat_n: Vec<f32> = corners.iter().flat_map(|n| n.to_array()).collect();
                    let n = Array2::from_shape_vec((corners.len(), 3), flat_n)
                        .expect("three floats per normal");
                    entry.set_item("normals", n.into_pyarray(py))?;
                }
                if !mesh.material_slots.is_empty() {
                    entry.set_item(
                        "material_slots",
                        mesh.material_slots.clone().into_pyarray(py),
                    )?;
                }
                if !mesh.uv_maps.is_empty() {
                    let maps = PyDict::new(py);
                    for map in &mesh.uv_maps {
                        let flat: Vec<f32> = map.corners.as_flattened().as_flattened().to_vec();
                        let a =
                            numpy::ndarray::Array3::from_shape_vec((map.corners.len(), 3, 2), flat)
                                .expect("six floats per triangle");
                        maps.set_item(&map.name, a.into_pyarray(py))?;
                    }
                    entry.set_item("uv_maps", maps)?;
                }
                meshes.set_item(upload.hash, entry)?;
            }
            Request::UploadImage(upload) => {
                let image = py
                    .detach(|| image_from_upload(&upload, &limits))
                    .map_err(|e| fail(&e))?;
                let shape = (image.height as usize, image.width as usize);
                let a = Array2::from_shape_vec(shape, image.texels)
                    .expect("validated: width x height texels");
                images.set_item(upload.hash, a.into_pyarray(py))?;
            }
            Request::FrameUpdate(mut update) => {
                // A daemon's recording holds arrays as sent: unchanged ones repeat the last frame.
                resolve_unchanged(&mut update, previous.as_ref()).map_err(|e| fail(&e))?;
                frames.append(frame_dict(py, &update)?)?;
                previous = Some(update);
            }
            // Hello, renders and the rest carry no scene state.
            _ => {}
        }
    }
    let out = PyDict::new(py);
    out.set_item("meshes", meshes)?;
    out.set_item("images", images)?;
    out.set_item("frames", frames)?;
    Ok(out)
}
