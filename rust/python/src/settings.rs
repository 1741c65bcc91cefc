//! The render settings as one checked Python object, from keyword arguments named as the core
//! schema names them (`antumbra_core::settings::SCHEMA`), checked in Rust exactly as the daemon
//! checks them; and the schema itself for Python (`settings_schema()`), which the add-on's panel
//! is made from.

use antumbra_core::settings::{setting, Kind, NamedSettings, SettingValue, SCHEMA};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString};

use crate::arrays::describe;
use crate::error::{ClientError, ClientResult, IntoPyResult};

/// Settings of a render, checked when made (a bad value raises `InvalidInput` naming the
/// setting before anything is sent).
#[pyclass(frozen, module = "antumbra._native")]
pub struct RenderSettings {
    /// Every setting by name, as the protocol carries them.
    pub state: NamedSettings,
}

/// One Python value as a setting's value: `None` leaves the setting at its default, and `True`
/// or `False` are `on` or `off` for a setting whose words are those (`timing`).
fn value(name: &str, v: &Bound<'_, PyAny>) -> ClientResult<Option<SettingValue>> {
    let on_off =
        setting(name).is_some_and(|s| matches!(s.kind, Kind::Choice(w) if w.contains(&"on")));
    Ok(Some(if v.is_none() {
        return Ok(None);
    } else if let Ok(b) = v.cast::<PyBool>() {
        match (on_off, b.is_true()) {
            (true, true) => SettingValue::from("on"),
            (true, false) => SettingValue::from("off"),
            (false, b) => SettingValue::Bool(b),
        }
    } else if v.cast::<PyInt>().is_ok() {
        SettingValue::Int(v.extract::<i64>().map_err(|_| {
            ClientError::invalid(format!("{name}: integer {} is out of range", describe(v)))
        })?)
    } else if v.cast::<PyFloat>().is_ok() {
        SettingValue::Float(
            v.extract::<f64>()
                .map_err(|e| ClientError::invalid(e.to_string()))?,
        )
    } else if let Ok(s) = v.cast::<PyString>() {
        SettingValue::Text(s.to_string())
    } else {
        // numpy scalars and other numbers.
        match v.extract::<i64>() {
            Ok(i) if v.extract::<f64>().is_ok_and(|f| f == i as f64) => SettingValue::Int(i),
            _ => match v.extract::<f64>() {
                Ok(f) => SettingValue::Float(f),
                Err(_) => {
                    return Err(ClientError::invalid(format!(
                        "{name}: expected a boolean, an integer, a number or text, got {}",
                        describe(v)
                    )))
                }
            },
        }
    }))
}

/// The settings given in keyword arguments, checked (names, values and how they combine) but
/// without the defaults of those left out: a method's or a comparison's own settings.
pub fn given(kwargs: Option<&Bound<'_, PyDict>>) -> ClientResult<NamedSettings> {
    let mut given = NamedSettings::new();
    if let Some(kwargs) = kwargs {
        for (k, v) in kwargs.iter() {
            let name = k
                .extract::<String>()
                .map_err(|_| ClientError::invalid("setting names must be text"))?;
            if let Some(v) = value(&name, &v)? {
                given.0.insert(name, v);
            }
        }
    }
    given
        .resolve()
        .map_err(|e| ClientError::invalid(e.to_string()))?;
    Ok(given)
}

/// The checked settings of keyword arguments.
pub fn from_kwargs(kwargs: Option<&Bound<'_, PyDict>>) -> ClientResult<NamedSettings> {
    let settings = given(kwargs)?
        .resolve()
        .map_err(|e| ClientError::invalid(e.to_string()))?;
    Ok(settings.to_named())
}

#[pymethods]
impl RenderSettings {
    #[new]
    #[pyo3(signature = (**settings))]
    fn new(py: Python<'_>, settings: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        from_kwargs(settings)
            .map(|state| RenderSettings { state })
            .py_result(py)
    }

    /// Every setting by name, as the protocol and a spool job's `job.json` spell them, as JSON.
    fn json(&self, py: Python<'_>) -> PyResult<String> {
        serde_json::to_string(&self.state)
            .map_err(|e| ClientError::invalid(e.to_string()))
            .py_result(py)
    }

    fn __repr__(&self) -> String {
        format!("RenderSettings({:?})", self.state.0)
    }
}

fn py_value<'py>(py: Python<'py>, v: &SettingValue) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        SettingValue::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        SettingValue::Int(i) => i.into_pyobject(py)?.into_any(),
        SettingValue::Float(f) => f.into_pyobject(py)?.into_any(),
        SettingValue::Text(t) => PyString::new(py, t).into_any(),
    })
}

/// The schema: one dict per setting with `name`, `type` ('bool', 'int', 'float', 'choice',
/// 'text'), `default`, `group`, `group_title`, `help`, `expected`, and per type `min`/`max`
/// (`open` for numbers whose bounds are excluded), `choices`, or `syntax`.
#[pyfunction]
pub fn settings_schema(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let list = PyList::empty(py);
    for s in SCHEMA {
        let d = PyDict::new(py);
        d.set_item("name", s.name)?;
        d.set_item("default", py_value(py, &s.default_value())?)?;
        d.set_item(
            "group",
            serde_json::to_value(s.group)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string)),
        )?;
        d.set_item("group_title", s.group.title())?;
        d.set_item("help", s.help)?;
        d.set_item("expected", s.expected())?;
        match s.kind {
            Kind::Bool => d.set_item("type", "bool")?,
            Kind::Int { min, max } => {
                d.set_item("type", "int")?;
                d.set_item("min", min)?;
                d.set_item("max", max)?;
            }
            Kind::IntChoice(list) => {
                d.set_item("type", "choice")?;
                d.set_item("choices", list.to_vec())?;
            }
            Kind::Float { min, max, open } => {
                d.set_item("type", "float")?;
                d.set_item("min", min)?;
                d.set_item("max", max)?;
                d.set_item("open", open)?;
            }
            Kind::Choice(words) => {
                d.set_item("type", "choice")?;
                d.set_item("choices", words.to_vec())?;
            }
            Kind::Text { syntax } => {
                d.set_item("type", "text")?;
                d.set_item("syntax", syntax)?;
            }
        }
        list.append(d)?;
    }
    Ok(list)
}
