//! `trade`'s Python side: knobs from Python values into a `Trade` request, its reply as rows
//! keyed by trade.csv's columns (`antumbra_core::trade::cells`), the knob table, and
//! `TradeReport`: the folder `antumbra trade` writes (`antumbra_report::trade::TradeFolder`),
//! recorded frame by frame.

use std::path::Path;

use antumbra_core::settings::NamedSettings;
use antumbra_core::stats::Cell;
use antumbra_core::trade::{cells, columns, Target, KNOBS};
use antumbra_protocol::{TradeRequest, TradeResultReply};
use antumbra_report::trade::{knob_texts, recommendations, TradeFolder, TradeRecord, TradeSetup};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString};

use crate::arrays::describe;
use crate::error::{ClientError, ClientResult, IntoPyResult};
use crate::settings::given;

fn invalid(e: impl std::fmt::Display) -> ClientError {
    ClientError::invalid(e.to_string())
}

/// One traded frame as the folder records it (`TradeReport.add`); opaque in Python.
#[pyclass(frozen, module = "antumbra._native")]
pub struct TradeFrameRecord {
    record: TradeRecord,
}

/// `knobs`: None (every knob) or a list of `NAME` or `NAME=V1,V2,...` strings (the Python
/// wrapper spells a dict so). Checked here as the daemon checks it (known knobs, each value
/// resolved with the shared settings), so a bad knob or value raises naming it before
/// anything is sent.
pub fn trade_request(
    frame: i32,
    knobs: Option<&Bound<'_, PyAny>>,
    repeat: u32,
    common: Option<&Bound<'_, PyDict>>,
) -> ClientResult<TradeRequest> {
    let expected = "knobs: expected a list of 'NAME' or 'NAME=V1,V2,...' strings";
    let knobs: Vec<String> = match knobs {
        None => Vec::new(),
        Some(k) if k.is_none() => Vec::new(),
        Some(k) if k.cast::<PyString>().is_ok() => {
            return Err(ClientError::invalid(format!("{expected}, got one string")))
        }
        Some(k) => k
            .try_iter()
            .map_err(|_| ClientError::invalid(format!("{expected}, got {}", describe(k))))?
            .map(|item| {
                item?
                    .extract::<String>()
                    .map_err(|_| ClientError::invalid(format!("{expected}: each item a str")))
            })
            .collect::<ClientResult<Vec<_>>>()?,
    };
    let request = TradeRequest {
        frame,
        request_id: 0,
        settings: given(common)?,
        knobs,
        repeat,
    };
    request.trade().map_err(invalid)?;
    Ok(request)
}

fn cell_to_py<'py>(py: Python<'py>, c: Option<Cell>) -> PyResult<Bound<'py, PyAny>> {
    Ok(match c {
        None => py.None().into_bound(py),
        Some(Cell::Text(v)) => v.into_pyobject(py)?.into_any(),
        Some(Cell::Int(v)) => v.into_pyobject(py)?.into_any(),
        Some(Cell::Count(v)) => v.into_pyobject(py)?.into_any(),
        Some(Cell::Flag(v)) => v.into_pyobject(py)?.to_owned().into_any(),
        Some(Cell::Real(v)) => v.into_pyobject(py)?.into_any(),
    })
}

/// `{frame, knobs, rows, mismatches, record}`: rows as dicts of trade.csv's columns (None
/// where the CSV cell is empty), mismatches as dicts `knob`, `frame`, `label`, `what`,
/// `pixels`, `message`; record a [`TradeFrameRecord`].
pub fn trade_reply_to_py<'py>(
    py: Python<'py>,
    request: &TradeRequest,
    r: TradeResultReply,
) -> ClientResult<Bound<'py, PyDict>> {
    let rows = PyList::empty(py);
    for row in &r.rows {
        let d = PyDict::new(py);
        for (name, cell) in cells(row) {
            d.set_item(name, cell_to_py(py, cell)?)?;
        }
        rows.append(d)?;
    }
    let mismatches = PyList::empty(py);
    for m in &r.mismatches {
        let d = PyDict::new(py);
        d.set_item("knob", &m.knob)?;
        d.set_item("frame", m.mismatch.frame)?;
        d.set_item("label", &m.mismatch.label)?;
        d.set_item("what", &m.mismatch.what)?;
        d.set_item("pixels", m.mismatch.pixels)?;
        d.set_item("message", m.to_string())?;
        mismatches.append(d)?;
    }
    let knobs = knob_texts(&request.knobs).map_err(invalid)?;
    let out = PyDict::new(py);
    out.set_item("frame", r.frame)?;
    out.set_item("knobs", knobs.clone())?;
    out.set_item("rows", rows)?;
    out.set_item("mismatches", mismatches)?;
    let record = TradeRecord {
        frame: r.frame,
        knobs,
        repeat: request.repeat as usize,
        settings: request.settings.clone(),
        rows: r.rows,
        mismatches: r.mismatches,
    };
    out.set_item("record", Bound::new(py, TradeFrameRecord { record })?)?;
    Ok(out)
}

/// Every knob of `antumbra trade` (`KNOBS`), in order: dicts `name`, `kind` ('image' or
/// 'work'), `trades`, `base` (the method it varies from), `sets` (what a value sets), `values`
/// (the table's) and `default` (with no shared settings).
#[pyfunction]
pub fn knobs<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
    let out = PyList::empty(py);
    let none = NamedSettings::new();
    for k in KNOBS {
        let d = PyDict::new(py);
        d.set_item("name", k.name)?;
        d.set_item("kind", k.kind.name())?;
        d.set_item("trades", k.trades)?;
        d.set_item("base", k.base)?;
        let sets = match k.target {
            Target::Setting(name) => name.to_string(),
            Target::OrderOption { option, .. } => format!("order option {option}"),
            Target::Resolution => "resolution percentage".into(),
        };
        d.set_item("sets", sets)?;
        d.set_item("values", k.values.to_vec())?;
        let default = k.default_value(&none).map_err(invalid).py_result(py)?;
        d.set_item("default", default)?;
        out.append(d)?;
    }
    Ok(out)
}

/// The columns of a trade's rows, in order (those of `trade.csv`).
#[pyfunction]
pub fn trade_columns() -> Vec<&'static str> {
    columns()
}

/// A trade folder (`antumbra._native.TradeReport`); use `antumbra.TradeReport`.
#[pyclass(module = "antumbra._native")]
pub struct TradeReport {
    folder: TradeFolder,
}

#[pymethods]
impl TradeReport {
    /// Opens `out_dir` for this trade, resuming the frames recorded there; a folder recorded
    /// for another scene, other knobs or repeat raises InvalidInput.
    #[new]
    #[pyo3(signature = (out_dir, scene, knobs = Vec::new(), repeat = None))]
    fn new(
        py: Python<'_>,
        out_dir: &str,
        scene: &str,
        knobs: Vec<String>,
        repeat: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let open = || -> ClientResult<Self> {
            let repeat = crate::scene::repeat_count(repeat)? as usize;
            let setup =
                TradeSetup::new(scene, &knobs, repeat).map_err(|e| invalid(format!("{e:#}")))?;
            let folder = py.detach(|| {
                TradeFolder::open(Path::new(out_dir), setup).map_err(|e| invalid(format!("{e:#}")))
            })?;
            Ok(TradeReport { folder })
        };
        open().py_result(py)
    }

    /// The frames recorded so far, in order.
    fn frames(&self) -> Vec<i32> {
        self.folder.frames()
    }

    /// Records one frame: `frames/frame_NNNN.json`.
    fn add(&mut self, py: Python<'_>, record: &Bound<'_, TradeFrameRecord>) -> PyResult<()> {
        let record = record.get().record.clone();
        let folder = &mut self.folder;
        py.detach(|| folder.add(record).map_err(|e| invalid(format!("{e:#}"))))
            .py_result(py)
    }

    /// Writes trade.csv, plots/ and trade.md; returns trade.md's path.
    fn write(&self, py: Python<'_>) -> PyResult<String> {
        let folder = &self.folder;
        py.detach(|| folder.write().map_err(|e| invalid(format!("{e:#}"))))
            .map(|p| p.display().to_string())
            .py_result(py)
    }

    /// One dict per knob: `knob`, `default`, `recommended`, `why` (trade.md's first table).
    fn recommendations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let reports = self
            .folder
            .reports()
            .map_err(|e| invalid(format!("{e:#}")))
            .py_result(py)?;
        let table = recommendations(&reports);
        let out = PyList::empty(py);
        for row in &table.rows {
            let d = PyDict::new(py);
            for (name, cell) in table.header.iter().zip(row) {
                d.set_item(name, cell)?;
            }
            out.append(d)?;
        }
        Ok(out)
    }

    /// The message of every recorded mismatch, knob after knob.
    #[getter]
    fn mismatches(&self) -> Vec<String> {
        self.folder
            .mismatches()
            .iter()
            .map(|m| m.to_string())
            .collect()
    }

    /// The folder.
    #[getter]
    fn out_dir(&self) -> String {
        self.folder.out().display().to_string()
    }
}
