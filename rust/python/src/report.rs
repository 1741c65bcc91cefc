//! `CompareReport`: the report folder of `antumbra compare` (`antumbra_report::ReportFolder`)
//! recorded frame by frame from Python, resumable, written by the CLI's own writer.

use std::path::Path;

use antumbra_core::compare::MethodSpec;
use antumbra_report::{ReportFolder, ReportSetup};
use pyo3::prelude::*;

use crate::compare::CompareRecord;
use crate::error::{ClientError, ClientResult, IntoPyResult};

fn invalid(e: anyhow::Error) -> ClientError {
    ClientError::invalid(format!("{e:#}"))
}

/// A report folder (`antumbra._native.CompareReport`); use `antumbra.CompareReport`.
#[pyclass(module = "antumbra._native")]
pub struct CompareReport {
    folder: ReportFolder,
}

#[pymethods]
impl CompareReport {
    /// Opens `out_dir` for this comparison, resuming the frames recorded there; a folder
    /// recorded for another scene, other methods, baseline or repeat raises InvalidInput.
    #[new]
    #[pyo3(signature = (out_dir, scene, methods, baseline = None, repeat = None))]
    fn new(
        py: Python<'_>,
        out_dir: &str,
        scene: &str,
        methods: Vec<String>,
        baseline: Option<String>,
        repeat: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let open = || -> ClientResult<Self> {
            let repeat = crate::scene::repeat_count(repeat)? as usize;
            let specs = methods
                .iter()
                .map(|m| m.parse::<MethodSpec>())
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| ClientError::invalid(e.to_string()))?;
            let setup =
                ReportSetup::new(scene, &specs, baseline.as_deref(), repeat).map_err(invalid)?;
            let folder =
                py.detach(|| ReportFolder::open(Path::new(out_dir), setup).map_err(invalid))?;
            Ok(CompareReport { folder })
        };
        open().py_result(py)
    }

    /// The frames recorded so far, in order.
    fn frames(&self) -> Vec<i32> {
        self.folder.frames()
    }

    /// Records one frame: its difference PNGs, then `frames/frame_NNNN.json`.
    fn add(&mut self, py: Python<'_>, record: &Bound<'_, CompareRecord>) -> PyResult<()> {
        let frame = record.get().frame.clone();
        let folder = &mut self.folder;
        py.detach(|| folder.add(frame).map_err(invalid))
            .py_result(py)
    }

    /// Writes compare.csv, compare.json, summary.md, plots/ and report.html; returns the path
    /// of report.html.
    fn write(&self, py: Python<'_>) -> PyResult<String> {
        let folder = &self.folder;
        py.detach(|| folder.write().map_err(invalid))
            .map(|p| p.display().to_string())
            .py_result(py)
    }

    /// The message of every recorded mismatch, in frame order.
    #[getter]
    fn mismatches(&self) -> Vec<String> {
        self.folder.mismatches().map(|m| m.to_string()).collect()
    }

    /// The report folder.
    #[getter]
    fn out_dir(&self) -> String {
        self.folder.out().display().to_string()
    }
}
