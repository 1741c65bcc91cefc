//! Python values (dicts with Blender's field names) to the protocol's messages, with checks that
//! name the field at fault. Both sessions build their requests here, so the socket and the
//! in-process paths see the same messages.

use antumbra_core::scene::{Camera, Light, Resolution};
use antumbra_protocol::{
    check_limits, instances::MATRIX_BYTES, AlphaMaterialState, AlphaOp, AlphaSourceState,
    AreaShapeState, CameraState, Extension, FrameUpdate, InstanceArrayState, Interpolation,
    LightKindState, LightState, Limits, ObjectState, Passes, Request, ResolutionState,
    SensorFitState, DEFAULT_REPEAT, MAX_COMPARE_REPEAT,
};
use numpy::{PyArray2, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyOverflowError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyInt, PyString, PyTuple};
use serde_bytes::ByteBuf;

use crate::arrays::describe;
use crate::error::{ClientError, ClientResult};

/// The fields of one dict argument, read by name; remembers which keys were read so that a
/// misspelt key is an error rather than silently ignored.
struct Fields<'a, 'py> {
    dict: &'a Bound<'py, PyDict>,
    /// How the dict is named in messages: `objects[2] ('Cube')`, `camera`, ...
    owner: String,
    known: &'static [&'static str],
}

impl<'a, 'py> Fields<'a, 'py> {
    fn new(
        obj: &'a Bound<'py, PyAny>,
        owner: impl Into<String>,
        known: &'static [&'static str],
    ) -> ClientResult<Self> {
        let owner = owner.into();
        let dict = obj.cast::<PyDict>().map_err(|_| {
            ClientError::invalid(format!("{owner}: expected a dict, got {}", describe(obj)))
        })?;
        let f = Fields { dict, owner, known };
        f.check_keys()?;
        Ok(f)
    }

    fn check_keys(&self) -> ClientResult<()> {
        for key in self.dict.keys() {
            let name = key.cast::<PyString>().map(|s| s.to_string()).map_err(|_| {
                ClientError::invalid(format!(
                    "{}: keys must be strings, got {}",
                    self.owner,
                    describe(&key)
                ))
            })?;
            if !self.known.contains(&name.as_str()) {
                return Err(ClientError::invalid(format!(
                    "{}: unknown field '{name}' (known fields: {})",
                    self.owner,
                    self.known.join(", ")
                )));
            }
        }
        Ok(())
    }

    fn field(&self, key: &str) -> String {
        format!("{}.{key}", self.owner)
    }

    fn get(&self, key: &str) -> ClientResult<Option<Bound<'py, PyAny>>> {
        Ok(self.dict.get_item(key)?.filter(|v| !v.is_none()))
    }

    fn required(&self, key: &str) -> ClientResult<Bound<'py, PyAny>> {
        self.get(key)?
            .ok_or_else(|| ClientError::invalid(format!("{}: missing", self.field(key))))
    }

    fn f64_or(&self, key: &str, default: f64) -> ClientResult<f64> {
        match self.get(key)? {
            None => Ok(default),
            Some(v) => number(&v, &self.field(key)),
        }
    }

    fn bool_or(&self, key: &str, default: bool) -> ClientResult<bool> {
        match self.get(key)? {
            None => Ok(default),
            Some(v) => v.extract::<bool>().map_err(|_| {
                ClientError::invalid(format!(
                    "{}: expected True or False, got {}",
                    self.field(key),
                    describe(&v)
                ))
            }),
        }
    }

    fn string(&self, key: &str) -> ClientResult<String> {
        let v = self.required(key)?;
        string(&v, &self.field(key))
    }

    fn string_or(&self, key: &str, default: &str) -> ClientResult<String> {
        match self.get(key)? {
            None => Ok(default.to_string()),
            Some(v) => string(&v, &self.field(key)),
        }
    }

    fn matrix(&self, key: &str) -> ClientResult<[f64; 16]> {
        let v = self.required(key)?;
        matrix(&v, &self.field(key))
    }
}

fn string(v: &Bound<'_, PyAny>, field: &str) -> ClientResult<String> {
    v.cast::<PyString>()
        .map(|s| s.to_string())
        .map_err(|_| ClientError::invalid(format!("{field}: expected a str, got {}", describe(v))))
}

/// A number (int, float, numpy scalar) as f64.
fn number(v: &Bound<'_, PyAny>, field: &str) -> ClientResult<f64> {
    if v.cast::<PyString>().is_ok() {
        return Err(ClientError::invalid(format!(
            "{field}: expected a number, got str"
        )));
    }
    v.extract::<f64>().map_err(|_| {
        ClientError::invalid(format!("{field}: expected a number, got {}", describe(v)))
    })
}

/// An integer (Python int or numpy integer; not bool) that fits `T`.
pub fn integer<T>(v: &Bound<'_, PyAny>, field: &str, range: &str) -> ClientResult<T>
where
    T: for<'a, 'py> FromPyObject<'a, 'py>,
{
    let not_int =
        || ClientError::invalid(format!("{field}: expected an integer, got {}", describe(v)));
    if v.is_instance_of::<PyBool>() || !(v.is_instance_of::<PyInt>() || v.hasattr("__index__")?) {
        return Err(not_int());
    }
    let py = v.py();
    v.extract::<T>().map_err(|e| {
        let e: PyErr = e.into();
        if e.is_instance_of::<PyOverflowError>(py) {
            let shown = v.str().map(|s| s.to_string()).unwrap_or_default();
            ClientError::invalid(format!("{field}: {shown} is out of range ({range})"))
        } else {
            not_int()
        }
    })
}

/// `repeat` of `compare` and `trade` (timed passes per method and frame; None: the protocol's
/// default): an integer from 1 to `MAX_COMPARE_REPEAT`, else `InvalidInput` (a ValueError)
/// naming `repeat` and its range, whatever the integer's size.
pub fn repeat_count(v: Option<&Bound<'_, PyAny>>) -> ClientResult<u32> {
    let Some(v) = v.filter(|v| !v.is_none()) else {
        return Ok(DEFAULT_REPEAT);
    };
    let range = format!("timed passes per method and frame, 1 to {MAX_COMPARE_REPEAT}");
    let n = integer::<i64>(v, "repeat", &range)?;
    match u32::try_from(n) {
        Ok(n) if n >= 1 && u64::from(n) <= MAX_COMPARE_REPEAT => Ok(n),
        _ => Err(ClientError::invalid(format!(
            "repeat: {n} is out of range ({range})"
        ))),
    }
}

pub fn frame_number(v: &Bound<'_, PyAny>, field: &str) -> ClientResult<i32> {
    integer::<i32>(v, field, "a 32-bit signed frame number")
}

pub fn mesh_hash(v: &Bound<'_, PyAny>, field: &str) -> ClientResult<u64> {
    integer::<u64>(v, field, "a mesh hash is an unsigned 64-bit integer")
}

/// A 4x4 matrix indexed `[row][column]` (Blender's `Matrix`, a numpy (4, 4) array, nested
/// lists), as the protocol's column-major 16 values. Non-finite values are refused.
pub fn matrix(v: &Bound<'_, PyAny>, field: &str) -> ClientResult<[f64; 16]> {
    let bad = || {
        ClientError::invalid(format!(
            "{field}: expected a 4x4 matrix (4 rows of 4 numbers, as Blender's matrix_world \
             or a numpy (4, 4) array), got {}",
            describe(v)
        ))
    };
    let finite = |out: [f64; 16]| match out.iter().position(|x| !x.is_finite()) {
        None => Ok(out),
        Some(i) => Err(ClientError::invalid(format!(
            "{field}[{}][{}]: must be finite, got {}",
            i % 4,
            i / 4,
            out[i]
        ))),
    };
    // Fast path: a float64 numpy array of shape (4, 4).
    if let Ok(a) = v.cast::<PyArray2<f64>>() {
        if let Ok(ro) = a.try_readonly() {
            let view = ro.as_array();
            if view.shape() == [4, 4] {
                let mut out = [0.0f64; 16];
                for ((r, c), x) in view.indexed_iter() {
                    out[4 * c + r] = *x;
                }
                return finite(out);
            }
        }
    }
    if v.cast::<PyString>().is_ok() || v.len().ok() != Some(4) {
        return Err(bad());
    }
    let mut out = [0.0f64; 16];
    for r in 0..4 {
        let row = v.get_item(r).map_err(|_| bad())?;
        if row.cast::<PyString>().is_ok() || row.len().ok() != Some(4) {
            return Err(bad());
        }
        for c in 0..4 {
            let x = row.get_item(c).map_err(|_| bad())?;
            let value = number(&x, &format!("{field}[{r}][{c}]"))?;
            if !value.is_finite() {
                return Err(ClientError::invalid(format!(
                    "{field}[{r}][{c}]: must be finite, got {value}"
                )));
            }
            out[4 * c + r] = value;
        }
    }
    Ok(out)
}

fn choice<T: Copy>(value: &str, field: &str, options: &[(&'static str, T)]) -> ClientResult<T> {
    options
        .iter()
        .find(|(name, _)| name.eq_ignore_ascii_case(value))
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            let names: Vec<String> = options.iter().map(|(n, _)| format!("'{n}'")).collect();
            ClientError::invalid(format!(
                "{field}: expected one of {}, got '{value}'",
                names.join(", ")
            ))
        })
}

/// Iterates a Python iterable, naming it in the error if it is not one.
fn items<'py>(v: &Bound<'py, PyAny>, field: &str) -> ClientResult<Vec<Bound<'py, PyAny>>> {
    if v.cast::<PyString>().is_ok() || v.cast::<PyDict>().is_ok() {
        return Err(ClientError::invalid(format!(
            "{field}: expected a list, got {}",
            describe(v)
        )));
    }
    let iter = v.try_iter().map_err(|_| {
        ClientError::invalid(format!("{field}: expected a list, got {}", describe(v)))
    })?;
    iter.map(|i| i.map_err(ClientError::from)).collect()
}

// ---------------------------------------------------------------------------------------------
// Scene parts

/// How messages name item `index` of list `list`: by its name too when it has a readable one
/// (`objects[2] 'Cube'`).
fn item_label(v: &Bound<'_, PyAny>, list: &str, index: usize) -> String {
    v.cast::<PyDict>()
        .ok()
        .and_then(|d| d.get_item("name").ok().flatten())
        .and_then(|n| n.cast::<PyString>().ok().map(|s| s.to_string()))
        .map_or_else(
            || format!("{list}[{index}]"),
            |n| format!("{list}[{index}] '{n}'"),
        )
}

const OBJECT_FIELDS: &[&str] = &[
    "name",
    "mesh_hash",
    "matrix_world",
    "visible_camera",
    "visible_shadow",
    "cast_shadow",
    "materials",
];

/// `materials` of an object or instance array: per slot None (opaque) or an index into the
/// frame's `alpha_materials` (of which there are `count`).
fn slot_materials(f: &Fields<'_, '_>, count: usize) -> ClientResult<Vec<Option<u32>>> {
    let Some(v) = f.get("materials")? else {
        return Ok(Vec::new());
    };
    let field = f.field("materials");
    items(&v, &field)?
        .iter()
        .enumerate()
        .map(|(slot, m)| {
            if m.is_none() {
                return Ok(None);
            }
            let field = format!("{field}[{slot}]");
            let range = format!(
                "None or an index into alpha_materials, 0 to {}",
                count as i64 - 1
            );
            let index = integer::<u32>(m, &field, &range)?;
            if index as usize >= count {
                return Err(ClientError::invalid(format!(
                    "{field}: alpha material {index}, but the frame has {count} alpha_materials"
                )));
            }
            Ok(Some(index))
        })
        .collect()
}

fn object(v: &Bound<'_, PyAny>, index: usize, materials: usize) -> ClientResult<ObjectState> {
    let f = Fields::new(v, item_label(v, "objects", index), OBJECT_FIELDS)?;
    let name = f.string("name")?;
    let mesh_hash = mesh_hash(&f.required("mesh_hash")?, &f.field("mesh_hash"))?;
    let world_from_object = f.matrix("matrix_world")?;
    let visible_to_camera = f.bool_or("visible_camera", true)?;
    let casts_shadow = match (f.get("visible_shadow")?, f.get("cast_shadow")?) {
        (Some(_), Some(_)) => {
            return Err(ClientError::invalid(format!(
                "{}: give either visible_shadow (Blender's name) or cast_shadow, not both",
                f.owner
            )))
        }
        (Some(_), None) => f.bool_or("visible_shadow", true)?,
        _ => f.bool_or("cast_shadow", true)?,
    };
    Ok(ObjectState {
        name,
        mesh_hash,
        world_from_object,
        visible_to_camera,
        casts_shadow,
        materials: slot_materials(&f, materials)?,
    })
}

const INSTANCE_FIELDS: &[&str] = &[
    "name",
    "mesh_hash",
    "matrices",
    "ids",
    "visible_camera",
    "visible_shadow",
    "materials",
];

/// `instances[i]`: every placement of one mesh as arrays; matrices travel as Blender's f32.
fn instance_array(
    v: &Bound<'_, PyAny>,
    index: usize,
    materials: usize,
) -> ClientResult<InstanceArrayState> {
    let f = Fields::new(v, item_label(v, "instances", index), INSTANCE_FIELDS)?;
    let matrices = instance_matrices(&f.required("matrices")?, &f.field("matrices"))?;
    let count = matrices.len() / MATRIX_BYTES;
    let ids = match f.get("ids")? {
        None => ByteBuf::new(),
        Some(ids) => instance_ids(&ids, &f.field("ids"), count)?,
    };
    Ok(InstanceArrayState {
        name: f.string("name")?,
        mesh_hash: mesh_hash(&f.required("mesh_hash")?, &f.field("mesh_hash"))?,
        matrices,
        ids,
        visible_to_camera: f.bool_or("visible_camera", true)?,
        casts_shadow: f.bool_or("visible_shadow", true)?,
        unchanged: false,
        materials: slot_materials(&f, materials)?,
    })
}

fn contiguous<'py>(v: &Bound<'py, PyAny>, dtype: &str) -> PyResult<Bound<'py, PyAny>> {
    let numpy = v.py().import("numpy")?;
    let kwargs = PyDict::new(v.py());
    kwargs.set_item("dtype", dtype)?;
    numpy.call_method("ascontiguousarray", (v,), Some(&kwargs))
}

/// (n, 4, 4) or (n, 3, 4) world matrices indexed [instance][row][column], as the wire's rows
/// 0..3 of f32; the last row of a 4x4 must be (0, 0, 0, 1) and every value finite.
fn instance_matrices(v: &Bound<'_, PyAny>, field: &str) -> ClientResult<ByteBuf> {
    let bad = || {
        ClientError::invalid(format!(
            "{field}: expected an array of world matrices with shape (n, 4, 4) or (n, 3, 4), \
             got {}",
            describe(v)
        ))
    };
    let array = contiguous(v, "float32").map_err(|_| bad())?;
    let array = array.cast::<PyArrayDyn<f32>>().map_err(|_| bad())?;
    let shape = array.shape().to_vec();
    let rows = match shape.as_slice() {
        [_, 4, 4] => 4,
        [_, 3, 4] => 3,
        _ => return Err(bad()),
    };
    let ro = array.readonly();
    let values = ro.as_slice().map_err(|_| bad())?;
    let mut bytes = Vec::with_capacity(values.len() / rows * 3 * 4);
    for (i, m) in values.chunks_exact(rows * 4).enumerate() {
        if let Some(k) = m.iter().position(|x| !x.is_finite()) {
            return Err(ClientError::invalid(format!(
                "{field}[{i}][{}][{}]: must be finite, got {}",
                k / 4,
                k % 4,
                m[k]
            )));
        }
        if rows == 4 && m[12..] != [0.0, 0.0, 0.0, 1.0] {
            return Err(ClientError::invalid(format!(
                "{field}[{i}][3]: the last row must be (0, 0, 0, 1), got {:?}",
                &m[12..]
            )));
        }
        bytes.extend(m[..12].iter().flat_map(|x| x.to_le_bytes()));
    }
    Ok(ByteBuf::from(bytes))
}

/// One unsigned 32-bit id per instance (Blender's persistent id of the instance).
fn instance_ids(v: &Bound<'_, PyAny>, field: &str, count: usize) -> ClientResult<ByteBuf> {
    let bad = || {
        ClientError::invalid(format!(
            "{field}: expected {count} integer ids, shape ({count},), got {}",
            describe(v)
        ))
    };
    let kind: String = (|| {
        let array = v.py().import("numpy")?.call_method1("asarray", (v,))?;
        array.getattr("dtype")?.getattr("kind")?.extract()
    })()
    .map_err(|_: PyErr| bad())?;
    if !matches!(kind.as_str(), "i" | "u") {
        return Err(bad());
    }
    let array = contiguous(v, "int64").map_err(|_| bad())?;
    let array = array.cast::<PyArrayDyn<i64>>().map_err(|_| bad())?;
    if array.shape() != [count] {
        return Err(bad());
    }
    let ro = array.readonly();
    let values = ro.as_slice().map_err(|_| bad())?;
    let mut bytes = Vec::with_capacity(count * 4);
    for (i, &id) in values.iter().enumerate() {
        let id = u32::try_from(id).map_err(|_| {
            ClientError::invalid(format!(
                "{field}[{i}]: {id} is out of range (0 to 2^32 - 1)"
            ))
        })?;
        bytes.extend(id.to_le_bytes());
    }
    Ok(ByteBuf::from(bytes))
}

const CAMERA_FIELDS: &[&str] = &[
    "matrix_world",
    "lens",
    "sensor_width",
    "sensor_height",
    "sensor_fit",
    "shift_x",
    "shift_y",
    "clip_start",
    "clip_end",
];

/// A camera dict with Blender's field names; unset fields take Blender's defaults for a new
/// camera (50 mm lens, 36 x 24 mm sensor, AUTO fit, no shift, clip 0.1 to 1000).
pub fn camera(v: &Bound<'_, PyAny>, owner: &str) -> ClientResult<CameraState> {
    let f = Fields::new(v, owner, CAMERA_FIELDS)?;
    let fit = f.string_or("sensor_fit", "AUTO")?;
    Ok(CameraState {
        world_from_camera: f.matrix("matrix_world")?,
        lens_mm: f.f64_or("lens", 50.0)?,
        sensor_width_mm: f.f64_or("sensor_width", 36.0)?,
        sensor_height_mm: f.f64_or("sensor_height", 24.0)?,
        sensor_fit: choice(
            &fit,
            &f.field("sensor_fit"),
            &[
                ("AUTO", SensorFitState::Auto),
                ("HORIZONTAL", SensorFitState::Horizontal),
                ("VERTICAL", SensorFitState::Vertical),
            ],
        )?,
        shift_x: f.f64_or("shift_x", 0.0)?,
        shift_y: f.f64_or("shift_y", 0.0)?,
        clip_start: f.f64_or("clip_start", 0.1)?,
        clip_end: f.f64_or("clip_end", 1000.0)?,
    })
}

const LIGHT_FIELDS: &[&str] = &[
    "name",
    "matrix_world",
    "type",
    "shadow_soft_size",
    "angle",
    "spot_size",
    "spot_blend",
    "shape",
    "size",
    "size_y",
    "use_shadow",
];

/// Blender's default sun angle, 0.526 degrees.
const DEFAULT_SUN_ANGLE: f64 = 0.526 * std::f64::consts::PI / 180.0;

fn light(v: &Bound<'_, PyAny>, index: usize) -> ClientResult<LightState> {
    let f = Fields::new(v, item_label(v, "lights", index), LIGHT_FIELDS)?;
    let name = f.string("name")?;
    let world_from_light = f.matrix("matrix_world")?;
    let kind_name = f.string("type")?;
    #[derive(Clone, Copy)]
    enum Kind {
        Point,
        Sun,
        Spot,
        Area,
    }
    let kind = choice(
        &kind_name,
        &f.field("type"),
        &[
            ("POINT", Kind::Point),
            ("SUN", Kind::Sun),
            ("SPOT", Kind::Spot),
            ("AREA", Kind::Area),
        ],
    )?;
    let radius = || f.f64_or("shadow_soft_size", 0.25);
    let kind = match kind {
        Kind::Point => LightKindState::Point { radius: radius()? },
        Kind::Sun => LightKindState::Sun {
            angle: f.f64_or("angle", DEFAULT_SUN_ANGLE)?,
        },
        Kind::Spot => LightKindState::Spot {
            radius: radius()?,
            spot_size: f.f64_or("spot_size", std::f64::consts::FRAC_PI_4)?,
            spot_blend: f.f64_or("spot_blend", 0.15)?,
        },
        Kind::Area => {
            let shape_name = f.string_or("shape", "SQUARE")?;
            let shape = choice(
                &shape_name,
                &f.field("shape"),
                &[
                    ("SQUARE", AreaShapeState::Square),
                    ("RECTANGLE", AreaShapeState::Rectangle),
                    ("DISK", AreaShapeState::Disk),
                    ("ELLIPSE", AreaShapeState::Ellipse),
                ],
            )?;
            let size_x = f.f64_or("size", 0.25)?;
            let size_y = match shape {
                AreaShapeState::Square | AreaShapeState::Disk => size_x,
                AreaShapeState::Rectangle | AreaShapeState::Ellipse => f.f64_or("size_y", 0.25)?,
            };
            LightKindState::Area {
                shape,
                size_x,
                size_y,
            }
        }
    };
    Ok(LightState {
        name,
        world_from_light,
        kind,
        casts_shadow: f.bool_or("use_shadow", true)?,
    })
}

const RESOLUTION_FIELDS: &[&str] = &[
    "x",
    "y",
    "percentage",
    "resolution_x",
    "resolution_y",
    "resolution_percentage",
    "pixel_aspect_x",
    "pixel_aspect_y",
];

/// A resolution: a dict (`x`, `y`, `percentage`, `pixel_aspect_x`, `pixel_aspect_y`; Blender's
/// `resolution_x`, `resolution_y`, `resolution_percentage` are accepted too) or an `(x, y)` pair.
pub fn resolution(v: &Bound<'_, PyAny>) -> ClientResult<ResolutionState> {
    let dimension = |v: &Bound<'_, PyAny>, field: &str| -> ClientResult<u32> {
        integer::<u32>(v, field, "a positive 32-bit size")
    };
    if let Ok(t) = v.cast::<PyTuple>() {
        if t.len() != 2 {
            return Err(ClientError::invalid(format!(
                "resolution: expected a dict or an (x, y) pair, got a tuple of {} items",
                t.len()
            )));
        }
        return Ok(ResolutionState {
            x: dimension(&t.get_item(0)?, "resolution.x")?,
            y: dimension(&t.get_item(1)?, "resolution.y")?,
            percentage: 100,
            pixel_aspect_x: 1.0,
            pixel_aspect_y: 1.0,
        });
    }
    let f = Fields::new(v, "resolution", RESOLUTION_FIELDS)?;
    let either = |a: &str, b: &str| -> ClientResult<Option<(Bound<'_, PyAny>, String)>> {
        match (f.get(a)?, f.get(b)?) {
            (Some(_), Some(_)) => Err(ClientError::invalid(format!(
                "resolution: give either {a} or {b}, not both"
            ))),
            (Some(v), None) => Ok(Some((v, f.field(a)))),
            (None, Some(v)) => Ok(Some((v, f.field(b)))),
            (None, None) => Ok(None),
        }
    };
    let dim = |a: &str, b: &str| -> ClientResult<u32> {
        let (v, field) = either(a, b)?
            .ok_or_else(|| ClientError::invalid(format!("resolution.{a}: missing")))?;
        dimension(&v, &field)
    };
    let percentage = match either("percentage", "resolution_percentage")? {
        None => 100,
        Some((v, field)) => integer::<u32>(&v, &field, "a percentage")?,
    };
    Ok(ResolutionState {
        x: dim("x", "resolution_x")?,
        y: dim("y", "resolution_y")?,
        percentage,
        pixel_aspect_x: f.f64_or("pixel_aspect_x", 1.0)?,
        pixel_aspect_y: f.f64_or("pixel_aspect_y", 1.0)?,
    })
}

// ---------------------------------------------------------------------------------------------
// Alpha materials

const ALPHA_MATERIAL_FIELDS: &[&str] = &[
    "name",
    "kind",
    "alpha",
    "image",
    "channel",
    "uv_map",
    "interpolation",
    "extension",
    "ops",
];

/// The fields only a texture material has (the exporter's contract, `docs/alpha_export.md`).
const TEXTURE_ONLY: &[&str] = &["image", "channel", "uv_map", "interpolation", "extension"];

/// One Math node of a material's `ops`: `[NAME, constant]`, or `[NAME]` for ONE_MINUS, CLAMP.
fn alpha_op(v: &Bound<'_, PyAny>, field: &str) -> ClientResult<AlphaOp> {
    let parts = items(v, field)?;
    let name = match parts.first() {
        Some(n) => string(n, &format!("{field}[0]"))?,
        None => {
            return Err(ClientError::invalid(format!(
                "{field}: expected [operation, constant] or [operation], got an empty list"
            )))
        }
    };
    #[derive(Clone, Copy)]
    enum Op {
        With(fn(f32) -> AlphaOp),
        Alone(AlphaOp),
    }
    let op = choice(
        &name,
        &format!("{field}[0]"),
        &[
            ("MULTIPLY", Op::With(AlphaOp::Multiply)),
            ("ADD", Op::With(AlphaOp::Add)),
            ("SUBTRACT", Op::With(AlphaOp::Subtract)),
            ("POWER", Op::With(AlphaOp::Power)),
            ("GREATER_THAN", Op::With(AlphaOp::GreaterThan)),
            ("LESS_THAN", Op::With(AlphaOp::LessThan)),
            ("ONE_MINUS", Op::Alone(AlphaOp::OneMinus)),
            ("CLAMP", Op::Alone(AlphaOp::Clamp)),
        ],
    )?;
    match (op, parts.len()) {
        (Op::With(make), 2) => {
            let c = number(&parts[1], &format!("{field}[1]"))? as f32;
            if !c.is_finite() {
                return Err(ClientError::invalid(format!(
                    "{field}[1]: the constant of {name} must be finite, got {c}"
                )));
            }
            Ok(make(c))
        }
        (Op::Alone(op), 1) => Ok(op),
        (Op::With(_), n) => Err(ClientError::invalid(format!(
            "{field}: {name} takes one constant ([{name}, c]), got {} values",
            n - 1
        ))),
        (Op::Alone(_), n) => Err(ClientError::invalid(format!(
            "{field}: {name} takes no constant ([{name}]), got {} values",
            n - 1
        ))),
    }
}

/// `alpha_materials[i]`: the exporter's contract dict with a `name`, its `image` the hash
/// `upload_image` returned. An "opaque" material is a constant alpha of 1.
fn alpha_material(
    v: &Bound<'_, PyAny>,
    index: usize,
    limits: &Limits,
) -> ClientResult<AlphaMaterialState> {
    let f = Fields::new(
        v,
        item_label(v, "alpha_materials", index),
        ALPHA_MATERIAL_FIELDS,
    )?;
    let name = f.string("name")?;
    let kind = f.string("kind")?;
    #[derive(Clone, Copy, PartialEq)]
    enum Kind {
        Opaque,
        Constant,
        Texture,
    }
    let kind = choice(
        &kind,
        &f.field("kind"),
        &[
            ("opaque", Kind::Opaque),
            ("constant", Kind::Constant),
            ("texture", Kind::Texture),
        ],
    )?;
    // A field of another kind is a mistake in the caller's contract, not something to ignore.
    let misplaced = |key: &str| -> ClientResult<()> {
        let belongs = match key {
            "alpha" => kind == Kind::Constant,
            k if TEXTURE_ONLY.contains(&k) => kind == Kind::Texture,
            _ => true,
        };
        if !belongs && f.get(key)?.is_some() {
            return Err(ClientError::invalid(format!(
                "{}: not a field of a material of kind '{}'",
                f.field(key),
                f.string("kind")?
            )));
        }
        Ok(())
    };
    for key in ALPHA_MATERIAL_FIELDS {
        misplaced(key)?;
    }
    let source = match kind {
        Kind::Opaque => AlphaSourceState::Constant { alpha: 1.0 },
        Kind::Constant => {
            let field = f.field("alpha");
            let alpha = number(&f.required("alpha")?, &field)? as f32;
            if !alpha.is_finite() {
                return Err(ClientError::invalid(format!(
                    "{field}: must be finite, got {alpha}"
                )));
            }
            AlphaSourceState::Constant { alpha }
        }
        Kind::Texture => {
            let hash = integer::<u64>(
                &f.required("image")?,
                &f.field("image"),
                "an image hash (upload_image's) is an unsigned 64-bit integer",
            )?;
            // The texels already hold the channel the material reads (the exporter's array).
            let channel = f.string_or("channel", "alpha")?;
            choice(
                &channel,
                &f.field("channel"),
                &[("alpha", ()), ("luminance", ())],
            )?;
            let interpolation = choice(
                &f.string_or("interpolation", "Linear")?,
                &f.field("interpolation"),
                &[
                    ("Linear", Interpolation::Linear),
                    ("Closest", Interpolation::Closest),
                    ("Cubic", Interpolation::Cubic),
                    // Cycles renders Smart as Cubic.
                    ("Smart", Interpolation::Cubic),
                ],
            )?;
            let extension = choice(
                &f.string_or("extension", "REPEAT")?,
                &f.field("extension"),
                &[
                    ("REPEAT", Extension::Repeat),
                    ("EXTEND", Extension::Extend),
                    ("CLIP", Extension::Clip),
                    ("MIRROR", Extension::Mirror),
                ],
            )?;
            AlphaSourceState::Image {
                hash,
                interpolation,
                extension,
            }
        }
    };
    let ops = match f.get("ops")? {
        None => Vec::new(),
        Some(v) => {
            let field = f.field("ops");
            let list = items(&v, &field)?;
            if list.len() as u64 > limits.max_alpha_ops {
                return Err(ClientError::invalid(format!(
                    "{field}: {} operations exceed the limit of {} (max_alpha_ops)",
                    list.len(),
                    limits.max_alpha_ops
                )));
            }
            list.iter()
                .enumerate()
                .map(|(i, op)| alpha_op(op, &format!("{field}[{i}]")))
                .collect::<ClientResult<Vec<_>>>()?
        }
    };
    Ok(AlphaMaterialState {
        name,
        uv_map: f.string_or("uv_map", "")?,
        source,
        ops,
    })
}

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

// ---------------------------------------------------------------------------------------------
// Passes

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
