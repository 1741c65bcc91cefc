//! `compare`'s Python side: methods from Python values into a `Compare` request, and its reply
//! as rows keyed by the columns of `compare.csv` (`antumbra_core::compare::columns`), heat and
//! difference arrays, and the frame as the report folder records it.

use antumbra_core::compare::{cells, columns, MethodSpec, DEFAULT_METHODS};
use antumbra_core::image::ImagePlane;
use antumbra_core::stats::Cell;
use antumbra_protocol::{heat_from_reply, CompareMethod, CompareRequest, CompareResultReply};
use antumbra_report::{difference, ComparedFrame};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString};

use crate::arrays::{describe, plane_to_array};
use crate::error::{ClientError, ClientResult};
use crate::settings::given;

/// One compared frame as the report folder records it (`CompareReport.add`); opaque in Python.
#[pyclass(frozen, module = "antumbra._native")]
pub struct CompareRecord {
    pub frame: ComparedFrame,
}

fn method(label: &str, settings: antumbra_core::settings::NamedSettings) -> CompareMethod {
    CompareMethod {
        label: label.to_string(),
        settings,
    }
}

/// `methods`: None (the defaults), a dict {label: {setting: value}}, or a list of
/// `LABEL=NAME=VALUE,...` strings. The request is checked here as the daemon checks it (labels,
/// setting names and values, the baseline), so a bad method raises before anything is sent.
/// Returns the request and its baseline's label.
pub fn compare_request(
    frame: i32,
    methods: Option<&Bound<'_, PyAny>>,
    baseline: Option<String>,
    repeat: u32,
    common: Option<&Bound<'_, PyDict>>,
    images: bool,
) -> ClientResult<(CompareRequest, String)> {
    let methods = match methods {
        None => Vec::new(),
        Some(m) if m.is_none() => Vec::new(),
        Some(m) => match m.cast::<PyDict>() {
            Ok(d) => d
                .iter()
                .map(|(label, settings)| {
                    let label = label
                        .extract::<String>()
                        .map_err(|_| ClientError::invalid("methods: the labels must be text"))?;
                    let settings = settings.cast::<PyDict>().map_err(|_| {
                        ClientError::invalid(format!(
                            "methods['{label}']: expected a dict of settings, got {}",
                            describe(&settings)
                        ))
                    })?;
                    let s = given(Some(settings)).map_err(|e| match e {
                        ClientError::Invalid(m) => {
                            ClientError::invalid(format!("method '{label}': {m}"))
                        }
                        other => other,
                    })?;
                    Ok(method(&label, s))
                })
                .collect::<ClientResult<Vec<_>>>()?,
            Err(_) if m.cast::<PyString>().is_ok() => {
                return Err(ClientError::invalid(
                    "methods: expected a dict or a list of 'LABEL=NAME=VALUE,...' strings, got \
                     one string",
                ))
            }
            Err(_) => m
                .try_iter()
                .map_err(|_| {
                    ClientError::invalid(format!(
                        "methods: expected a dict or a list of 'LABEL=NAME=VALUE,...' strings, \
                         got {}",
                        describe(m)
                    ))
                })?
                .map(|item| {
                    let text = item?.extract::<String>().map_err(|_| {
                        ClientError::invalid("methods: each item must be 'LABEL=NAME=VALUE,...'")
                    })?;
                    let spec: MethodSpec = text
                        .parse()
                        .map_err(|e: antumbra_core::Error| ClientError::invalid(e.to_string()))?;
                    Ok(method(&spec.label, spec.settings))
                })
                .collect::<ClientResult<Vec<_>>>()?,
        },
    };
    let request = CompareRequest {
        frame,
        request_id: 0,
        settings: given(common)?,
        methods,
        baseline,
        repeat,
        images,
        warm_up: false,
    };
    let baseline = request
        .comparison()
        .map_err(|e| ClientError::invalid(e.to_string()))?
        .baseline()
        .to_string();
    Ok((request, baseline))
}

fn cell_to_py<'py>(py: Python<'py>, c: Cell) -> PyResult<Bound<'py, PyAny>> {
    Ok(match c {
        Cell::Text(v) => v.into_pyobject(py)?.into_any(),
        Cell::Int(v) => v.into_pyobject(py)?.into_any(),
        Cell::Count(v) => v.into_pyobject(py)?.into_any(),
        Cell::Flag(v) => v.into_pyobject(py)?.to_owned().into_any(),
        Cell::Real(v) => v.into_pyobject(py)?.into_any(),
    })
}

/// `{frame, methods, baseline, rows, mismatches, heat, difference, record}`: rows as dicts of
/// compare.csv's columns, mismatches as dicts `frame`, `label`, `what`, `pixels`, `message`;
/// heat and difference as {label: float32 (H, W) array}; record a [`CompareRecord`].
pub fn compare_reply_to_py<'py>(
    py: Python<'py>,
    request: &CompareRequest,
    baseline: String,
    r: CompareResultReply,
) -> ClientResult<Bound<'py, PyDict>> {
    let rows = PyList::empty(py);
    for row in &r.rows {
        let spec = r
            .methods
            .iter()
            .find(|m| m.split_once('=').is_some_and(|(l, _)| l == row.label))
            .cloned()
            .unwrap_or_default();
        let d = PyDict::new(py);
        for (name, cell) in cells(row, &spec) {
            d.set_item(name, cell_to_py(py, cell)?)?;
        }
        rows.append(d)?;
    }
    // Wrong answers only; edge differences across scene structures are not errors.
    let mismatches = PyList::empty(py);
    for m in r.mismatches.iter().filter(|m| m.is_wrong()) {
        let d = PyDict::new(py);
        d.set_item("frame", m.frame)?;
        d.set_item("label", &m.label)?;
        d.set_item("what", &m.what)?;
        d.set_item("pixels", m.pixels)?;
        d.set_item("message", m.to_string())?;
        mismatches.append(d)?;
    }
    let planes = heat_from_reply(&r).map_err(|e| ClientError::Mismatch(e.to_string()))?;
    let heat: Vec<(String, ImagePlane)> = planes.into_iter().map(|p| (p.name.clone(), p)).collect();
    let difference_arrays = PyDict::new(py);
    if let Some((_, base)) = heat.iter().find(|(l, _)| *l == baseline) {
        for (label, plane) in heat.iter().filter(|(l, _)| *l != baseline) {
            let d = difference(label, &baseline, plane, base)
                .map_err(|e| ClientError::Mismatch(format!("{e:#}")))?;
            difference_arrays.set_item(label, plane_to_array(py, d)?)?;
        }
    }
    let heat_arrays = PyDict::new(py);
    for (label, plane) in &heat {
        heat_arrays.set_item(label, plane_to_array(py, plane.clone())?)?;
    }
    let out = PyDict::new(py);
    out.set_item("frame", r.frame)?;
    out.set_item("methods", r.methods.clone())?;
    out.set_item("baseline", &baseline)?;
    out.set_item("rows", rows)?;
    out.set_item("mismatches", mismatches)?;
    out.set_item("heat", heat_arrays)?;
    out.set_item("difference", difference_arrays)?;
    let record = CompareRecord {
        frame: ComparedFrame {
            frame: r.frame,
            methods: r.methods,
            baseline,
            repeat: request.repeat as usize,
            settings: request.settings.clone(),
            rows: r.rows,
            mismatches: r.mismatches,
            heat,
        },
    };
    out.set_item("record", Bound::new(py, record)?)?;
    Ok(out)
}

/// The methods a comparison uses when none are given, as `LABEL=NAME=VALUE,...`.
#[pyfunction]
pub fn default_methods() -> Vec<&'static str> {
    DEFAULT_METHODS.to_vec()
}

/// The columns of a comparison's rows, in order (those of `compare.csv`).
#[pyfunction]
pub fn compare_columns() -> Vec<&'static str> {
    columns()
}
