//! Reading Python values: a dict's fields by name (a misspelt key is an error), strings,
//! numbers, integers in range, frame numbers, hashes, matrices, choices, sequences.

use antumbra_protocol::{DEFAULT_REPEAT, MAX_COMPARE_REPEAT};
use numpy::{PyArray2, PyArrayMethods};
use pyo3::exceptions::PyOverflowError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyInt, PyString};

use crate::arrays::describe;
use crate::error::{ClientError, ClientResult};

/// The fields of one dict argument, read by name; remembers which keys were read so that a
/// misspelt key is an error rather than silently ignored.
pub(super) struct Fields<'a, 'py> {
    dict: &'a Bound<'py, PyDict>,
    /// How the dict is named in messages: `objects[2] ('Cube')`, `camera`, ...
    pub(super) owner: String,
    known: &'static [&'static str],
}

impl<'a, 'py> Fields<'a, 'py> {
    pub(super) fn new(
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

    pub(super) fn check_keys(&self) -> ClientResult<()> {
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

    pub(super) fn field(&self, key: &str) -> String {
        format!("{}.{key}", self.owner)
    }

    pub(super) fn get(&self, key: &str) -> ClientResult<Option<Bound<'py, PyAny>>> {
        Ok(self.dict.get_item(key)?.filter(|v| !v.is_none()))
    }

    pub(super) fn required(&self, key: &str) -> ClientResult<Bound<'py, PyAny>> {
        self.get(key)?
            .ok_or_else(|| ClientError::invalid(format!("{}: missing", self.field(key))))
    }

    pub(super) fn f64_or(&self, key: &str, default: f64) -> ClientResult<f64> {
        match self.get(key)? {
            None => Ok(default),
            Some(v) => number(&v, &self.field(key)),
        }
    }

    pub(super) fn bool_or(&self, key: &str, default: bool) -> ClientResult<bool> {
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

    pub(super) fn string(&self, key: &str) -> ClientResult<String> {
        let v = self.required(key)?;
        string(&v, &self.field(key))
    }

    pub(super) fn string_or(&self, key: &str, default: &str) -> ClientResult<String> {
        match self.get(key)? {
            None => Ok(default.to_string()),
            Some(v) => string(&v, &self.field(key)),
        }
    }

    pub(super) fn matrix(&self, key: &str) -> ClientResult<[f64; 16]> {
        let v = self.required(key)?;
        matrix(&v, &self.field(key))
    }
}

pub(super) fn string(v: &Bound<'_, PyAny>, field: &str) -> ClientResult<String> {
    v.cast::<PyString>()
        .map(|s| s.to_string())
        .map_err(|_| ClientError::invalid(format!("{field}: expected a str, got {}", describe(v))))
}

/// A number (int, float, numpy scalar) as f64.
pub(super) fn number(v: &Bound<'_, PyAny>, field: &str) -> ClientResult<f64> {
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

pub(super) fn choice<T: Copy>(
    value: &str,
    field: &str,
    options: &[(&'static str, T)],
) -> ClientResult<T> {
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
pub(super) fn items<'py>(
    v: &Bound<'py, PyAny>,
    field: &str,
) -> ClientResult<Vec<Bound<'py, PyAny>>> {
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
