//! Comparing methods on the same frames: labelled methods ([`MethodSpec`]), the run that
//! renders every frame with each, checks their answers against the baseline's and times them
//! fairly ([`Comparison`]), and the summary tables in the papers' forms.

mod hindsight;
mod method;
mod recommend;
mod run;
mod summary;
mod tables;

pub use hindsight::{hindsight, Hindsight};
pub use method::{default_methods, MethodSpec, DEFAULT_METHODS};
pub use recommend::{recommend, MethodTime, Recommendation};
pub use run::{CompareRow, Comparison, FrameComparison, MethodFrame, Mismatch, Step, Timing};
pub use summary::{
    pass_summaries, time_summaries, Figures, FrameFigures, PassSummary, TimeSummary, Work,
};
#[cfg(feature = "files")]
pub use tables::to_csv;
pub use tables::{cells, columns, JsonRow};
