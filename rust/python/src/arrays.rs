//! numpy arrays in, numpy arrays out: mesh arrays become an [`antumbra_core::scene::Mesh`]
//! (checked and hashed without the GIL), result planes become float32 arrays without a copy.

use antumbra_core::alpha::AlphaImage;
use antumbra_core::image::ImagePlane;
use antumbra_core::scene::{Mesh, TriangleRef, UvMap};
use glam::Vec3;
use numpy::ndarray::{Array2, ArrayView2};
use numpy::{
    Element, IntoPyArray, PyArray2, PyArrayDyn, PyArrayMethods, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

use crate::error::{ClientError, ClientResult};

/// A short description of a Python value for error messages: `float64 array of shape (8, 3)`,
/// `list`, ...
pub fn describe(obj: &Bound<'_, PyAny>) -> String {
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        let dtype = a
            .dtype()
            .str()
            .map(|s| s.to_string())
            .unwrap_or_else(|_| "?".into());
        let shape: Vec<String> = a.shape().iter().map(|d| d.to_string()).collect();
        let shape = if shape.len() == 1 {
            format!("({},)", shape[0])
        } else {
            format!("({})", shape.join(", "))
        };
        return format!("{dtype} array of shape {shape}");
    }
    obj.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "object".into())
}

/// Checks that `obj` is a 2-D numpy array with 3 columns; returns its row count.
fn check_n_by_3(
    obj: &Bound<'_, PyAny>,
    field: &str,
    expected: &str,
    rows: &str,
) -> ClientResult<usize> {
    let bad = || {
        ClientError::invalid(format!(
            "{field}: expected {expected} with shape ({rows}, 3), got {}",
            describe(obj)
        ))
    };
    let a = obj.cast::<PyUntypedArray>().map_err(|_| bad())?;
    match a.shape() {
        [n, 3] => Ok(*n),
        _ => Err(bad()),
    }
}

/// Rows of an (n, 3) array as a contiguous slice when it is one, else copied out.
fn with_rows<T, R: Send>(
    py: Python<'_>,
    array: &Bound<'_, PyArray2<T>>,
    f: impl Fn(&[T]) -> R + Send + Sync,
) -> ClientResult<R>
where
    T: Element + Copy + Sync,
{
    let ro = array
        .try_readonly()
        .map_err(|e| ClientError::invalid(format!("array is being written elsewhere: {e}")))?;
    // as_slice also accepts Fortran order, whose memory is not in row order.
    if array.is_c_contiguous() {
        if let Ok(slice) = ro.as_slice() {
            return Ok(py.detach(|| f(slice)));
        }
    }
    let view: ArrayView2<'_, T> = ro.as_array();
    let owned: Vec<T> = view.iter().copied().collect();
    Ok(py.detach(|| f(&owned)))
}

/// Object-space positions: a float32 array of shape (n, 3).
pub fn positions_from(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    mesh: &str,
) -> ClientResult<Vec<Vec3>> {
    vec3s_from(py, obj, &format!("mesh '{mesh}'.positions"))
}

/// Corner normals: a float32 array of shape (3m, 3), the three corners of each triangle in turn.
pub fn corner_normals_from(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    mesh: &str,
) -> ClientResult<Vec<[Vec3; 3]>> {
    let field = format!("mesh '{mesh}'.normals");
    let corners = vec3s_from(py, obj, &field)?;
    if corners.len() % 3 != 0 {
        return Err(ClientError::invalid(format!(
            "{field}: {} rows is not 3 per triangle",
            corners.len()
        )));
    }
    Ok(corners
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect())
}

fn vec3s_from(py: Python<'_>, obj: &Bound<'_, PyAny>, field: &str) -> ClientResult<Vec<Vec3>> {
    let field = field.to_string();
    check_n_by_3(obj, &field, "a float32 numpy array", "n")?;
    let array = obj.cast::<PyArray2<f32>>().map_err(|_| {
        ClientError::invalid(format!(
            "{field}: expected a float32 numpy array with shape (n, 3), got {} \
             (convert with .astype(numpy.float32))",
            describe(obj)
        ))
    })?;
    with_rows(py, array, |s| {
        s.chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect()
    })
}

/// Triangles: an integer array of shape (m, 3) whose values fit u32.
pub fn triangles_from(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    mesh: &str,
) -> ClientResult<Vec<[u32; 3]>> {
    let field = format!("mesh '{mesh}'.triangles");
    check_n_by_3(obj, &field, "an integer numpy array", "m")?;
    macro_rules! try_types {
        ($($t:ty),*) => {
            $(
                if let Ok(a) = obj.cast::<PyArray2<$t>>() {
                    return with_rows(py, a, |s| convert_indices(s, &field))?;
                }
            )*
        };
    }
    try_types!(u32, i32, i64, u64, u16, i16, u8, i8);
    Err(ClientError::invalid(format!(
        "{field}: expected an integer numpy array (uint32 or int) with shape (m, 3), got {}",
        describe(obj)
    )))
}

fn convert_indices<T>(values: &[T], field: &str) -> ClientResult<Vec<[u32; 3]>>
where
    T: Copy + TryInto<u32> + std::fmt::Display,
{
    let mut out = Vec::with_capacity(values.len() / 3);
    for (t, c) in values.chunks_exact(3).enumerate() {
        let mut tri = [0u32; 3];
        for (k, &v) in c.iter().enumerate() {
            tri[k] = v.try_into().map_err(|_| {
                ClientError::invalid(format!(
                    "{field}: triangle {t} has index {v}, which is not a vertex index \
                     (0 to 4294967295)"
                ))
            })?;
        }
        out.push(tri);
    }
    Ok(out)
}

/// A C-contiguous copy (or the array itself) of `v` as `dtype`; None if numpy cannot convert it.
fn contiguous<'py>(v: &Bound<'py, PyAny>, dtype: &str) -> Option<Bound<'py, PyAny>> {
    let numpy = v.py().import("numpy").ok()?;
    let kwargs = PyDict::new(v.py());
    kwargs.set_item("dtype", dtype).ok()?;
    numpy
        .call_method("ascontiguousarray", (v,), Some(&kwargs))
        .ok()
}

/// Whether `v` is a numpy array (or sequence) of integers, not floats or bools.
fn is_integer_array(v: &Bound<'_, PyAny>) -> bool {
    (|| -> PyResult<bool> {
        let array = v.py().import("numpy")?.call_method1("asarray", (v,))?;
        let kind: String = array.getattr("dtype")?.getattr("kind")?.extract()?;
        Ok(matches!(kind.as_str(), "i" | "u"))
    })()
    .unwrap_or(false)
}

/// Material slots: one integer per triangle (Blender's `material_index`), shape (m,).
pub fn material_slots_from(v: &Bound<'_, PyAny>, mesh: &str) -> ClientResult<Vec<u32>> {
    let field = format!("mesh '{mesh}'.material_slots");
    let bad = || {
        ClientError::invalid(format!(
            "{field}: expected an integer numpy array (uint32) with shape (m,), got {}",
            describe(v)
        ))
    };
    if !is_integer_array(v) {
        return Err(bad());
    }
    let array = contiguous(v, "int64").ok_or_else(bad)?;
    let array = array.cast::<PyArrayDyn<i64>>().map_err(|_| bad())?;
    if array.ndim() != 1 {
        return Err(bad());
    }
    let ro = array.readonly();
    let values = ro.as_slice().map_err(|_| bad())?;
    values
        .iter()
        .enumerate()
        .map(|(t, &v)| {
            u32::try_from(v).map_err(|_| {
                ClientError::invalid(format!(
                    "{field}[{t}]: {v} is not a material slot (0 to 4294967295)"
                ))
            })
        })
        .collect()
}

/// UV maps: a dict {name: float32 array of shape (m, 3, 2)}, (u, v) at each triangle's corners.
pub fn uv_maps_from(v: &Bound<'_, PyAny>, mesh: &str) -> ClientResult<Vec<UvMap>> {
    let field = format!("mesh '{mesh}'.uv_maps");
    let dict = v.cast::<PyDict>().map_err(|_| {
        ClientError::invalid(format!(
            "{field}: expected a dict {{uv map name: float32 array of shape (m, 3, 2)}}, got {}",
            describe(v)
        ))
    })?;
    let mut maps = Vec::with_capacity(dict.len());
    for (key, value) in dict.iter() {
        let name = key.cast::<PyString>().map(|s| s.to_string()).map_err(|_| {
            ClientError::invalid(format!(
                "{field}: keys are UV map names (str), got {}",
                describe(&key)
            ))
        })?;
        let field = format!("{field}['{name}']");
        let bad = || {
            ClientError::invalid(format!(
                "{field}: expected a float32 numpy array with shape (m, 3, 2), got {}",
                describe(&value)
            ))
        };
        let array = value.cast::<PyArrayDyn<f32>>().map_err(|_| bad())?;
        let m = match array.shape() {
            [m, 3, 2] => *m,
            _ => return Err(bad()),
        };
        let array = contiguous(&value, "float32").ok_or_else(bad)?;
        let array = array.cast::<PyArrayDyn<f32>>().map_err(|_| bad())?;
        let ro = array.readonly();
        let values = ro.as_slice().map_err(|_| bad())?;
        let mut corners = Vec::with_capacity(m);
        for c in values.chunks_exact(6) {
            corners.push([[c[0], c[1]], [c[2], c[3]], [c[4], c[5]]]);
        }
        maps.push(UvMap { name, corners });
    }
    Ok(maps)
}

/// An alpha image from a float32 array of shape (height, width), rows bottom first (Blender's
/// order); checked (size, at most `max_texels` texels before anything is copied, finite texels)
/// and hashed without the GIL. Returns it and its hash.
pub fn image_from_array(
    py: Python<'_>,
    texels: &Bound<'_, PyAny>,
    max_texels: u64,
) -> ClientResult<(AlphaImage, u64)> {
    let field = "texels";
    let bad = || {
        ClientError::invalid(format!(
            "{field}: expected a float32 numpy array with shape (height, width), rows bottom              first, got {}",
            describe(texels)
        ))
    };
    let array = texels.cast::<PyArray2<f32>>().map_err(|_| bad())?;
    let (height, width) = match array.shape() {
        [h, w] => (*h, *w),
        _ => return Err(bad()),
    };
    let (Ok(width), Ok(height)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err(bad());
    };
    let count = width as u64 * height as u64;
    if count > max_texels {
        return Err(ClientError::invalid(format!(
            "{field}: a {width}x{height} image has {count} texels, over the limit of \
             {max_texels} (max_image_texels)"
        )));
    }
    let texels = with_rows(py, array, |s| s.to_vec())?;
    let image = AlphaImage {
        width,
        height,
        texels,
    };
    py.detach(|| {
        let hash = image.content_hash();
        image
            .validate(&format!("image {hash:#018x}"))
            .map_err(|e| ClientError::invalid(e.to_string()))?;
        Ok((image, hash))
    })
}

/// What a mesh carries for alpha materials, as Python gave it: `material_slots=`, `uv_maps=`.
#[derive(Clone, Copy, Default)]
pub struct MeshAlphaArgs<'a, 'py> {
    pub material_slots: Option<&'a Bound<'py, PyAny>>,
    pub uv_maps: Option<&'a Bound<'py, PyAny>>,
}

/// A mesh from numpy arrays (corner normals, material slots and UV maps optional), checked if
/// `validate` (finite positions, normals and UVs, indices in range, one slot and one corner
/// triple per triangle) and hashed; the work on the arrays runs without the GIL. Returns the
/// mesh and its content hash.
pub fn mesh_from_arrays(
    py: Python<'_>,
    name: &str,
    positions: &Bound<'_, PyAny>,
    triangles: &Bound<'_, PyAny>,
    normals: Option<&Bound<'_, PyAny>>,
    alpha: MeshAlphaArgs<'_, '_>,
    validate: bool,
) -> ClientResult<(Mesh, u64)> {
    let positions = positions_from(py, positions, name)?;
    let triangles = triangles_from(py, triangles, name)?;
    let normals = match normals {
        Some(n) if !n.is_none() => corner_normals_from(py, n, name)?,
        _ => Vec::new(),
    };
    let material_slots = match alpha.material_slots {
        Some(v) if !v.is_none() => material_slots_from(v, name)?,
        _ => Vec::new(),
    };
    let uv_maps = match alpha.uv_maps {
        Some(v) if !v.is_none() => uv_maps_from(v, name)?,
        _ => Vec::new(),
    };
    let mesh = Mesh::new(name, positions, triangles)
        .with_normals(normals)
        .with_alpha(material_slots, uv_maps);
    py.detach(|| {
        if validate {
            mesh.validate()
                .map_err(|e| ClientError::invalid(e.to_string()))?;
        }
        let hash = mesh.content_hash();
        Ok((mesh, hash))
    })
}

/// An image plane as a float32 array of shape (height, width), rows top to bottom; the plane's
/// buffer becomes the array's (no copy).
pub fn plane_to_array<'py>(
    py: Python<'py>,
    plane: ImagePlane,
) -> ClientResult<Bound<'py, PyArray2<f32>>> {
    let shape = (plane.height as usize, plane.width as usize);
    let a = Array2::from_shape_vec(shape, plane.data)
        .map_err(|e| ClientError::Mismatch(format!("image '{}': {e}", plane.name)))?;
    Ok(a.into_pyarray(py))
}

/// The visible set as a uint32 array of shape (k, 2): (object index, triangle index) rows.
pub fn visible_to_array<'py>(py: Python<'py>, refs: &[TriangleRef]) -> Bound<'py, PyArray2<u32>> {
    let flat: Vec<u32> = refs.iter().flat_map(|r| [r.object, r.primitive]).collect();
    Array2::from_shape_vec((refs.len(), 2), flat)
        .expect("two values per reference")
        .into_pyarray(py)
}
