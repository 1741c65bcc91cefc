//! The comparison's report folder (`docs/compare.md`): each frame recorded as it comes
//! ([`ReportFolder`], resumable), then `compare.csv`, `compare.json`, `summary.md`, `plots/` and
//! `report.html` from every recorded frame. Used by `antumbra compare` and the Python client.

mod diff_maps;
mod folder;
mod html;
pub mod plots;
mod record;
mod report;
mod table;

pub use diff_maps::{difference, DiffMap};
pub use folder::ReportFolder;
pub use record::{ComparedFrame, FrameRecord, ReportSetup};
pub use table::Table;
