//! The comparison's report folder (`docs/compare.md`): each frame recorded as it comes
//! ([`ReportFolder`], resumable), then `compare.csv`, `compare.json`, `summary.md`, `plots/` and
//! `report.html` from every recorded frame; and the trade's folder ([`trade::TradeFolder`]:
//! `trade.csv`, Pareto plots, `trade.md`). Used by the CLI and the Python client alike.

mod diff_maps;
mod folder;
mod frame_records;
mod html;
pub mod plots;
mod record;
mod report;
mod table;
pub mod trade;

pub use diff_maps::{difference, DiffMap};
pub use folder::ReportFolder;
pub use record::{ComparedFrame, FrameRecord, ReportSetup};
pub use table::Table;
