//! A frame's images as files, written by the same Rust code as `antumbra render` and the
//! daemon's spool (`antumbra_core::output::write_frame_files`), and EXR files read back.

use std::path::Path;

use antumbra_core::image::ImagePlane;
use antumbra_core::output::{
    difference_scale, diverging_rgb, heatmap_rgb, read_exr, write_frame_files, ColorMap, HeatScale,
    Outputs,
};
use antumbra_core::render::{FrameResult, HeatMaps};
use antumbra_core::stats::StatsRow;
use numpy::{IntoPyArray, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyList};

use crate::arrays::{describe, plane_to_array};
use crate::error::{ClientError, ClientResult};

/// A (name, float32 (h, w) array) pair as a plane.
fn plane_from(item: &Bound<'_, PyAny>, width: u32, height: u32) -> ClientResult<ImagePlane> {
    let (name, array): (String, Bound<'_, PyAny>) = item.extract().map_err(|_| {
        ClientError::invalid(format!(
            "planes: expected (name, array) pairs, got {}",
            describe(item)
        ))
    })?;
    let array: PyReadonlyArray2<'_, f32> = array.extract().map_err(|_| {
        ClientError::invalid(format!(
            "plane '{name}': expected a float32 array of shape ({height}, {width}), got {}",
            describe(&array)
        ))
    })?;
    let view = array.as_array();
    if view.dim() != (height as usize, width as usize) {
        return Err(ClientError::invalid(format!(
            "plane '{name}': shape {:?}, the frame is ({height}, {width})",
            view.dim()
        )));
    }
    Ok(ImagePlane {
        name,
        width,
        height,
        data: view.iter().copied().collect(),
    })
}

/// Rebuilds a frame's result from its planes in the daemon's order: the masks
/// (`shadow.<light>`), `combined`, then the six heat maps if present.
fn result_from_planes(frame: i32, mut planes: Vec<ImagePlane>) -> ClientResult<FrameResult> {
    let (width, height) = planes.first().map_or((0, 0), |p| (p.width, p.height));
    let at = planes
        .iter()
        .position(|p| p.name == "combined")
        .ok_or_else(|| ClientError::invalid("planes: no 'combined' plane"))?;
    let heat: Vec<ImagePlane> = planes.split_off(at + 1);
    let combined = planes.pop().expect("combined is at `at`");
    let mut masks = Vec::with_capacity(planes.len());
    for mut m in planes {
        m.name = match m.name.strip_prefix("shadow.") {
            Some(light) => light.to_string(),
            None => {
                return Err(ClientError::invalid(format!(
                    "plane '{}': masks before 'combined' are named shadow.<light>",
                    m.name
                )))
            }
        };
        masks.push(m);
    }
    let heat = match heat.len() {
        0 => None,
        6 => {
            let mut it = heat.into_iter();
            let mut three = || [(); 3].map(|_| it.next().expect("six planes"));
            Some(HeatMaps {
                primary: three(),
                shadow: three(),
            })
        }
        n => {
            return Err(ClientError::invalid(format!(
                "planes: {n} planes after 'combined', expected the 6 heat maps or none"
            )))
        }
    };
    Ok(FrameResult {
        frame,
        width,
        height,
        masks,
        combined,
        heat,
        visible: Vec::new(),
        primary_hits: Vec::new(),
        structure: Default::default(),
        primary_objects: Vec::new(),
        stats: Vec::new(),
    })
}

/// Writes `frame_NNNN.exr` (every plane) and/or the PNGs into `dir`; returns the file names.
pub fn save_frame(
    py: Python<'_>,
    dir: &str,
    frame: i32,
    width: u32,
    height: u32,
    planes: &Bound<'_, PyAny>,
    outputs: Outputs,
) -> ClientResult<Vec<String>> {
    let list = planes
        .cast::<PyList>()
        .map_err(|_| ClientError::invalid("planes: expected a list of (name, array) pairs"))?;
    let planes = list
        .iter()
        .map(|item| plane_from(&item, width, height))
        .collect::<ClientResult<Vec<_>>>()?;
    let result = result_from_planes(frame, planes)?;
    let written = py
        .detach(|| {
            std::fs::create_dir_all(dir)?;
            write_frame_files(Path::new(dir), &result, &outputs)
                .map_err(|e| std::io::Error::other(e.to_string()))
        })
        .map_err(|e| ClientError::invalid(format!("writing frame {frame} to {dir}: {e}")))?;
    Ok(written.files)
}

/// Every channel of an EXR as `{name: float32 (h, w) array}`, rows top to bottom.
pub fn load_exr<'py>(py: Python<'py>, path: &str) -> ClientResult<Bound<'py, PyDict>> {
    let planes = py
        .detach(|| read_exr(Path::new(path)))
        .map_err(|e| ClientError::invalid(format!("reading {path}: {e}")))?;
    let out = PyDict::new(py);
    for p in planes {
        let name = p.name.clone();
        out.set_item(name, plane_to_array(py, p)?)?;
    }
    Ok(out)
}

/// A heat map as the PNGs draw it (turbo, 0 to `max`, or to the plane's largest value): an
/// uint8 sRGB array of shape (h, w, 3) and the max used.
pub fn colorize_heat<'py>(
    py: Python<'py>,
    array: &Bound<'py, PyAny>,
    max: Option<f32>,
) -> ClientResult<(Bound<'py, numpy::PyArray3<u8>>, f32)> {
    let array: PyReadonlyArray2<'_, f32> = array.extract().map_err(|_| {
        ClientError::invalid(format!(
            "heat map: expected a float32 array of shape (h, w), got {}",
            describe(array)
        ))
    })?;
    let view = array.as_array();
    let (h, w) = view.dim();
    let plane = ImagePlane {
        name: "heat".into(),
        width: w as u32,
        height: h as u32,
        data: view.iter().copied().collect(),
    };
    let scale = match max {
        Some(max) => HeatScale::Linear { max },
        None => HeatScale::Auto,
    };
    let (rgb, legend) = py
        .detach(|| heatmap_rgb(&plane, ColorMap::Turbo, scale))
        .map_err(|e| ClientError::invalid(e.to_string()))?;
    let rgb = numpy::ndarray::Array3::from_shape_vec((h, w, 3), rgb)
        .expect("three bytes per pixel")
        .into_pyarray(py);
    Ok((rgb, legend.max))
}

/// One statistics row from a dict of its columns (as `Result.stats` gives them, or as read back
/// A difference image as the comparison's PNGs draw it (diverging, blue -`scale`, white 0, red
/// +`scale`; `scale` defaults to the largest absolute difference, at least 1): an uint8 sRGB
/// array of shape (h, w, 3) and the scale used.
pub fn colorize_difference<'py>(
    py: Python<'py>,
    array: &Bound<'py, PyAny>,
    scale: Option<f32>,
) -> ClientResult<(Bound<'py, numpy::PyArray3<u8>>, f32)> {
    let array: PyReadonlyArray2<'_, f32> = array.extract().map_err(|_| {
        ClientError::invalid(format!(
            "difference: expected a float32 array of shape (h, w), got {}",
            describe(array)
        ))
    })?;
    let view = array.as_array();
    let (h, w) = view.dim();
    let plane = ImagePlane {
        name: "difference".into(),
        width: w as u32,
        height: h as u32,
        data: view.iter().copied().collect(),
    };
    let scale = match scale {
        Some(s) if s > 0.0 && s.is_finite() => s,
        Some(s) => {
            return Err(ClientError::invalid(format!(
                "difference: scale {s} is not > 0"
            )))
        }
        None => difference_scale(&plane),
    };
    let rgb: Vec<u8> = py.detach(|| {
        plane
            .data
            .iter()
            .flat_map(|&v| diverging_rgb(v / scale))
            .collect()
    });
    let rgb = numpy::ndarray::Array3::from_shape_vec((h, w, 3), rgb)
        .expect("three bytes per pixel")
        .into_pyarray(py);
    Ok((rgb, scale))
}

/// from JSON); missing columns take their defaults, unknown ones are ignored.
fn stats_row_from(i: usize, row: &Bound<'_, PyAny>) -> ClientResult<StatsRow> {
    let bad = |what: String| ClientError::invalid(format!("rows[{i}]{what}"));
    let dict = row
        .cast::<PyDict>()
        .map_err(|_| bad(format!(": expected a dict, got {}", describe(row))))?;
    let mut map = serde_json::Map::new();
    for (key, value) in dict.iter() {
        let key: String = key
            .extract()
            .map_err(|_| bad(": keys must be str".into()))?;
        // Floats go across as they are (no text round trip), so the CSV is exact.
        let json = if value.is_none() {
            serde_json::Value::Null
        } else if let Ok(b) = value.cast::<PyBool>() {
            serde_json::Value::Bool(b.is_true())
        } else if let Ok(i) = value.extract::<i64>() {
            i.into()
        } else if let Ok(u) = value.extract::<u64>() {
            u.into()
        } else if let Ok(f) = value.extract::<f64>() {
            serde_json::Number::from_f64(f).map_or(serde_json::Value::Null, Into::into)
        } else if let Ok(t) = value.extract::<String>() {
            t.into()
        } else {
            return Err(bad(format!(
                ".{key}: unsupported value {}",
                describe(&value)
            )));
        };
        map.insert(key, json);
    }
    serde_json::from_value(map.into()).map_err(|e| bad(format!(": {e}")))
}

/// The rows of `Result.stats` (a list of dicts) as the daemon's statistics rows.
pub fn stats_rows(rows: &Bound<'_, PyAny>) -> ClientResult<Vec<StatsRow>> {
    let list = rows.cast::<PyList>().map_err(|_| {
        ClientError::invalid(format!(
            "rows: expected a list of dicts, got {}",
            describe(rows)
        ))
    })?;
    list.iter()
        .enumerate()
        .map(|(i, row)| stats_row_from(i, &row))
        .collect()
}
