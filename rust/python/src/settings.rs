//! The render settings as one checked Python object: `Connection.render` and
//! `LocalSession.render` take it, and a spool job's `job.json` is its JSON, so the Python
//! spelling of the settings is parsed in exactly one place (`scene::render_settings_state`).

use antumbra_protocol::RenderSettingsState;
use pyo3::prelude::*;

use crate::error::{ClientError, IntoPyResult};
use crate::scene;

/// Settings of a render, checked as the daemon checks them when made (a bad value raises
/// `InvalidInput` naming the field before anything is sent).
#[pyclass(frozen, module = "antumbra._native")]
pub struct RenderSettings {
    pub state: RenderSettingsState,
}

#[pymethods]
impl RenderSettings {
    #[new]
    #[pyo3(signature = (spp, seed, build, order, leaf_size, bins, traversal_cost,
        intersection_cost, timing, width, visibility, osah_w = None, osah_viability = None,
        collapse = None, spatial_axes = None, min_leaf_size = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        spp: &Bound<'_, PyAny>,
        seed: &Bound<'_, PyAny>,
        build: &str,
        order: Option<&str>,
        leaf_size: &Bound<'_, PyAny>,
        bins: &Bound<'_, PyAny>,
        traversal_cost: f64,
        intersection_cost: f64,
        timing: &Bound<'_, PyAny>,
        width: &Bound<'_, PyAny>,
        visibility: &str,
        osah_w: Option<f64>,
        osah_viability: Option<&str>,
        collapse: Option<&str>,
        spatial_axes: Option<&str>,
        min_leaf_size: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        scene::render_settings_state(
            spp,
            seed,
            build,
            order,
            leaf_size,
            bins,
            traversal_cost,
            intersection_cost,
            timing,
            width,
            visibility,
            osah_w,
            osah_viability,
            collapse,
            spatial_axes,
            min_leaf_size,
        )
        .map(|state| RenderSettings { state })
        .py_result(py)
    }

    /// The settings as the protocol spells them (`RenderSettingsState`), as JSON.
    fn json(&self, py: Python<'_>) -> PyResult<String> {
        serde_json::to_string(&self.state)
            .map_err(|e| ClientError::invalid(e.to_string()))
            .py_result(py)
    }

    fn __repr__(&self) -> String {
        format!("RenderSettings({:?})", self.state)
    }
}
