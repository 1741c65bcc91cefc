//! `antumbra._native`: the Rust half of the `antumbra` Python package.
//!
//! - [`mesh_hash`]: the protocol's mesh content hash of numpy arrays;
//! - [`connection::Connection`]: a session with the daemon over its Unix socket;
//! - [`local::LocalSession`]: the same methods, rendering in this process;
//! - [`report::CompareReport`]: a comparison's report folder, recorded frame by frame;
//! - [`trade::TradeReport`]: a trade's folder, likewise, and the knob table ([`trade::knobs`]).
//!
//! The protocol lives in `antumbra-protocol` only: this module builds its messages from Python
//! values and never encodes MessagePack itself. The Python package (`python/antumbra`) wraps
//! these classes (`antumbra.Client`, `antumbra.LocalSession`) and defines the exceptions.

mod arrays;
mod compare;
mod connection;
mod error;
mod files;
mod local;
mod rays;
mod recording;
mod replay;
mod report;
mod result;
mod scene;
mod settings;
mod trade;
mod uploads;

use std::path::Path;

use pyo3::prelude::*;
use pyo3::types::PyString;

use crate::arrays::{describe, image_from_array, mesh_from_arrays, MeshAlphaArgs};
use crate::error::{ClientError, ClientResult, IntoPyResult};

/// A mesh name: a str.
pub(crate) fn mesh_name(v: &Bound<'_, PyAny>) -> ClientResult<String> {
    v.cast::<PyString>().map(|s| s.to_string()).map_err(|_| {
        ClientError::invalid(format!("mesh name: expected a str, got {}", describe(v)))
    })
}

/// The content hash the protocol uses for a mesh (`antumbra_core::scene::Mesh::content_hash`):
/// positions a float32 array of shape (n, 3), triangles an integer array of shape (m, 3). The
/// values are not checked (NaN hashes like any other bits); `upload_mesh` checks them.
#[pyfunction]
#[pyo3(signature = (positions, triangles, normals = None, material_slots = None, uv_maps = None))]
fn mesh_hash(
    py: Python<'_>,
    positions: &Bound<'_, PyAny>,
    triangles: &Bound<'_, PyAny>,
    normals: Option<&Bound<'_, PyAny>>,
    material_slots: Option<&Bound<'_, PyAny>>,
    uv_maps: Option<&Bound<'_, PyAny>>,
) -> PyResult<u64> {
    let alpha = MeshAlphaArgs {
        material_slots,
        uv_maps,
    };
    mesh_from_arrays(py, "mesh", positions, triangles, normals, alpha, false)
        .map(|(_, hash)| hash)
        .py_result(py)
}

/// The content hash of an alpha image (`antumbra_core::alpha::AlphaImage::content_hash`):
/// texels a float32 array of shape (height, width), rows bottom first; checked (finite, not
/// empty) as `upload_image` checks it.
#[pyfunction]
fn image_hash(py: Python<'_>, texels: &Bound<'_, PyAny>) -> PyResult<u64> {
    image_from_array(py, texels, u64::MAX)
        .map(|(_, hash)| hash)
        .py_result(py)
}

/// The meshes and frames of a recording (`.antrec`) as numpy arrays and `frame_update` dicts.
#[pyfunction]
fn read_recording<'py>(py: Python<'py>, path: &str) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    replay::read_recording(py, path).py_result(py)
}

/// Writes a frame's planes (the daemon's order) as `antumbra render` writes them.
#[pyfunction]
#[pyo3(signature = (dir, frame, width, height, planes, exr = true, png = true))]
#[allow(clippy::too_many_arguments)]
fn save_frame(
    py: Python<'_>,
    dir: &str,
    frame: i32,
    width: u32,
    height: u32,
    planes: &Bound<'_, PyAny>,
    exr: bool,
    png: bool,
) -> PyResult<Vec<String>> {
    let outputs = antumbra_core::output::Outputs {
        exr,
        png,
        stats: false,
    };
    files::save_frame(py, dir, frame, width, height, planes, outputs).py_result(py)
}

/// Writes `data` to `path` atomically (a unique temporary file beside it, synced, renamed): the
/// writer of every antumbra file, for the add-on's tables too.
#[pyfunction]
fn write_file_atomic(py: Python<'_>, path: &str, data: &[u8]) -> PyResult<()> {
    antumbra_core::atomic_file::write_bytes_atomic(Path::new(path), data)
        .map_err(|e| ClientError::invalid(e.to_string()))
        .py_result(py)
}

/// Writes statistics rows (dicts of their columns, as `Result.stats` gives them) as the CLI
/// writes `stats.csv` (`format="csv"`) or `stats.json` (`format="json"`), atomically.
#[pyfunction]
fn write_stats(py: Python<'_>, path: &str, rows: &Bound<'_, PyAny>, format: &str) -> PyResult<()> {
    let write = || -> ClientResult<()> {
        let rows = files::stats_rows(rows)?;
        let path = Path::new(path);
        match format {
            "csv" => antumbra_core::stats::write_csv(path, &rows),
            "json" => antumbra_core::stats::write_json(path, &rows),
            other => {
                return Err(ClientError::invalid(format!(
                    "format: 'csv' or 'json', got '{other}'"
                )))
            }
        }
        .map_err(|e| ClientError::invalid(e.to_string()))
    };
    write().py_result(py)
}

/// Every channel of an EXR file as float32 arrays.
#[pyfunction]
fn read_exr<'py>(py: Python<'py>, path: &str) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    files::load_exr(py, path).py_result(py)
}

/// A heat map through the turbo colour map, as the PNGs show it: (uint8 (h, w, 3), max).
#[pyfunction]
#[pyo3(signature = (array, max = None))]
fn colorize_heat<'py>(
    py: Python<'py>,
    array: &Bound<'py, PyAny>,
    max: Option<f32>,
) -> PyResult<(Bound<'py, numpy::PyArray3<u8>>, f32)> {
    files::colorize_heat(py, array, max).py_result(py)
}

/// A difference image as the comparison's PNGs draw it: (uint8 (h, w, 3), scale).
#[pyfunction]
#[pyo3(signature = (array, scale = None))]
fn colorize_difference<'py>(
    py: Python<'py>,
    array: &Bound<'py, PyAny>,
    scale: Option<f32>,
) -> PyResult<(Bound<'py, numpy::PyArray3<u8>>, f32)> {
    files::colorize_difference(py, array, scale).py_result(py)
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    error::set_package(&m.name()?.to_string());
    m.add_function(wrap_pyfunction!(mesh_hash, m)?)?;
    m.add_function(wrap_pyfunction!(image_hash, m)?)?;
    m.add_function(wrap_pyfunction!(read_recording, m)?)?;
    m.add_function(wrap_pyfunction!(save_frame, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(write_file_atomic, m)?)?;
    m.add_function(wrap_pyfunction!(write_stats, m)?)?;
    m.add_function(wrap_pyfunction!(colorize_heat, m)?)?;
    m.add_function(wrap_pyfunction!(colorize_difference, m)?)?;
    m.add_class::<settings::RenderSettings>()?;
    m.add_function(wrap_pyfunction!(settings::settings_schema, m)?)?;
    m.add_function(wrap_pyfunction!(compare::default_methods, m)?)?;
    m.add_function(wrap_pyfunction!(compare::compare_columns, m)?)?;
    m.add_class::<compare::CompareRecord>()?;
    m.add_class::<report::CompareReport>()?;
    m.add_function(wrap_pyfunction!(trade::knobs, m)?)?;
    m.add_function(wrap_pyfunction!(trade::trade_columns, m)?)?;
    m.add_class::<trade::TradeFrameRecord>()?;
    m.add_class::<trade::TradeReport>()?;
    m.add_class::<connection::Connection>()?;
    m.add_class::<local::LocalSession>()?;
    m.add_class::<rays::RayScene>()?;
    m.add("PROTOCOL_VERSION", antumbra_protocol::PROTOCOL_VERSION)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
