//! Objects and instance arrays: their dicts, slot materials, and the arrays' matrices and ids.

use antumbra_protocol::{instances::MATRIX_BYTES, InstanceArrayState, ObjectState};
use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use serde_bytes::ByteBuf;

use super::fields::{integer, items, mesh_hash, Fields};
use crate::arrays::describe;
use crate::error::{ClientError, ClientResult};

/// How messages name item `index` of list `list`: by its name too when it has a readable one
/// (`objects[2] 'Cube'`).
pub(super) fn item_label(v: &Bound<'_, PyAny>, list: &str, index: usize) -> String {
    v.cast::<PyDict>()
        .ok()
        .and_then(|d| d.get_item("name").ok().flatten())
        .and_then(|n| n.cast::<PyString>().ok().map(|s| s.to_string()))
        .map_or_else(
            || format!("{list}[{index}]"),
            |n| format!("{list}[{index}] '{n}'"),
        )
}

pub(super) const OBJECT_FIELDS: &[&str] = &[
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
pub(super) fn slot_materials(f: &Fields<'_, '_>, count: usize) -> ClientResult<Vec<Option<u32>>> {
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

pub(super) fn object(
    v: &Bound<'_, PyAny>,
    index: usize,
    materials: usize,
) -> ClientResult<ObjectState> {
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

pub(super) const INSTANCE_FIELDS: &[&str] = &[
    "name",
    "mesh_hash",
    "matrices",
    "ids",
    "visible_camera",
    "visible_shadow",
    "materials",
];

/// `instances[i]`: every placement of one mesh as arrays; matrices travel as Blender's f32.
pub(super) fn instance_array(
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

pub(super) fn contiguous<'py>(v: &Bound<'py, PyAny>, dtype: &str) -> PyResult<Bound<'py, PyAny>> {
    let numpy = v.py().import("numpy")?;
    let kwargs = PyDict::new(v.py());
    kwargs.set_item("dtype", dtype)?;
    numpy.call_method("ascontiguousarray", (v,), Some(&kwargs))
}

/// (n, 4, 4) or (n, 3, 4) world matrices indexed [instance][row][column], as the wire's rows
/// 0..3 of f32; the last row of a 4x4 must be (0, 0, 0, 1) and every value finite.
pub(super) fn instance_matrices(v: &Bound<'_, PyAny>, field: &str) -> ClientResult<ByteBuf> {
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
pub(super) fn instance_ids(
    v: &Bound<'_, PyAny>,
    field: &str,
    count: usize,
) -> ClientResult<ByteBuf> {
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
