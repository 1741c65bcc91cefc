//! Replies to Python values. A rendered frame goes through the protocol's `FrameResultReply` on
//! both paths (the daemon sends it; the in-process session builds it with the daemon's
//! `frame_result_reply`), so both give the same arrays bit for bit.

use antumbra_core::stats::Cell;
use antumbra_protocol::{
    planes_from_reply, visible_from_reply, DaemonStats, FrameResultReply, Limits, StatsRowState,
};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::arrays::{plane_to_array, visible_to_array};
use crate::error::{ClientError, ClientResult};

/// `{"frame", "width", "height", "request_id", "images": [(name, array)], "stats": [dict],
/// "visible": array or None}`; the Python layer wraps it in `antumbra.Result`.
pub fn frame_result_to_py<'py>(
    py: Python<'py>,
    reply: FrameResultReply,
) -> ClientResult<Bound<'py, PyDict>> {
    let bad = |e: antumbra_protocol::ProtocolError| ClientError::Mismatch(e.to_string());
    let planes = py.detach(|| planes_from_reply(&reply)).map_err(bad)?;
    let visible = visible_from_reply(&reply).map_err(bad)?;
    for p in &planes {
        if (p.width, p.height) != (reply.width, reply.height) {
            return Err(ClientError::Mismatch(format!(
                "frame {}: image '{}' is {}x{}, the frame {}x{}",
                reply.frame, p.name, p.width, p.height, reply.width, reply.height
            )));
        }
    }
    let out = PyDict::new(py);
    out.set_item("frame", reply.frame)?;
    out.set_item("width", reply.width)?;
    out.set_item("height", reply.height)?;
    out.set_item("request_id", reply.request_id)?;
    let images = PyList::empty(py);
    for plane in planes {
        let name = plane.name.clone();
        images.append((name, plane_to_array(py, plane)?))?;
    }
    out.set_item("images", images)?;
    let stats = PyList::empty(py);
    for row in &reply.stats {
        stats.append(stats_row(py, row)?)?;
    }
    out.set_item("stats", stats)?;
    match visible {
        Some(v) => out.set_item("visible", visible_to_array(py, &v))?,
        None => out.set_item("visible", py.None())?,
    }
    Ok(out)
}

macro_rules! dict_of {
    ($py:expr, $value:expr, [$($field:ident),* $(,)?]) => {{
        let d = PyDict::new($py);
        $( d.set_item(stringify!($field), &$value.$field)?; )*
        d
    }};
}

/// A statistics row as a dict of its columns (`StatsRow::cells`: the CSV's names and order).
pub fn stats_row<'py>(py: Python<'py>, r: &StatsRowState) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, cell) in r.cells() {
        match cell {
            Cell::Text(v) => d.set_item(name, v)?,
            Cell::Int(v) => d.set_item(name, v)?,
            Cell::Count(v) => d.set_item(name, v)?,
            Cell::Flag(v) => d.set_item(name, v)?,
            Cell::Real(v) => d.set_item(name, v)?,
        }
    }
    Ok(d)
}

pub fn daemon_stats<'py>(py: Python<'py>, s: &DaemonStats) -> PyResult<Bound<'py, PyDict>> {
    Ok(dict_of!(
        py,
        s,
        [
            sessions,
            sessions_total,
            meshes_cached,
            bytes_cached,
            renders_done,
            renders_cancelled,
            renders_failed,
            uptime_s,
            meshes_evicted,
            images_cached,
            images_evicted,
        ]
    ))
}

pub fn limits<'py>(py: Python<'py>, l: &Limits) -> PyResult<Bound<'py, PyDict>> {
    Ok(dict_of!(
        py,
        l,
        [
            max_frame_bytes,
            max_triangles_per_mesh,
            max_meshes,
            max_objects,
            max_image_pixels,
            max_spp,
            max_lights,
            max_render_bytes,
            max_request_passes,
            max_image_texels,
            max_alpha_materials,
            max_alpha_ops,
            max_uv_maps,
            max_material_slots,
        ]
    ))
}
