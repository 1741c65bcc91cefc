//! Measuring each knob's trade of speed against accuracy or work (`antumbra trade`): the knob
//! table, the image knobs' error against a reference, the long-form table and the rule that
//! recommends a value per knob. The runs themselves are comparisons ([`crate::compare`]).

mod error;
mod knobs;
mod summary;
mod table;

pub use error::{mask_error, upsample, MaskError, LIT_THRESHOLD, REFERENCE_SPP};
pub use knobs::{
    knob, knob_names, knobs_markdown, parse_knob_arg, Knob, KnobKind, KnobValue, Target,
    FULL_RESOLUTION, KNOBS,
};
pub use summary::{recommend, summarise, Recommendation, ValueSummary, RMSE_BOUND};
pub use table::{to_csv, TradeRow, COLUMNS};
