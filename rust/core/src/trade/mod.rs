//! Measuring each knob's trade of speed against accuracy or work (`antumbra trade`): the knob
//! table, the image knobs' error against a reference, the long-form table and the rule that
//! recommends a value per knob; the sweeps ([`KnobSweep`], [`Trade`]) are comparisons
//! ([`crate::compare`]) of each knob's values.

mod error;
mod knobs;
mod summary;
mod sweep;
mod table;

pub use error::{mask_error, upsample, MaskError, LIT_THRESHOLD, REFERENCE_SPP};
pub use knobs::{
    knob, knob_names, knobs_markdown, parse_knob_arg, Knob, KnobKind, KnobValue, Target,
    FULL_RESOLUTION, KNOBS,
};
pub use summary::{recommend, summarise, Recommendation, ValueSummary, RMSE_BOUND};
pub use sweep::{
    knob_choices, KnobChoice, KnobFrame, KnobSweep, Reference, Trade, TradeFrame, TradeMismatch,
    TradeStep,
};
#[cfg(feature = "files")]
pub use table::to_csv;
pub use table::{cells, columns, TradeRow};
