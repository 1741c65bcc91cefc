//! The `Trade` request: one frame swept over every knob of a trade by antumbra-core's [`Trade`]
//! (each knob's values a comparison, image knobs against the reference), whose rows and
//! mismatches travel back as the core's own serde forms. (The trade a session keeps across its
//! requests is `antumbra_session::TradeState`.)

use antumbra_core::trade::Trade;
use serde::{Deserialize, Serialize};

use crate::error::ProtocolError;
use crate::messages::NamedSettings;

pub use antumbra_core::trade::{TradeMismatch as TradeMismatchState, TradeRow as TradeRowState};

fn default_repeat() -> u32 {
    crate::compare::DEFAULT_REPEAT
}

/// Sweep a frame sent with `FrameUpdate` over every knob named. The session keeps one trade
/// while `settings`, `knobs` and `repeat` stay the same, so each knob value keeps its state
/// across frames (previous-frame visibility, tree reuse) as `antumbra trade` does.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TradeRequest {
    pub frame: i32,
    /// Chosen by the client; echoed in `TradeResult`.
    pub request_id: u64,
    /// The settings every value shares (spp, seed), by name; a knob's base method and value
    /// win over them.
    #[serde(default)]
    pub settings: NamedSettings,
    /// Each knob as `NAME` or `NAME=V1,V2,...` (`antumbra trade --knob`), in order; empty:
    /// every knob of antumbra-core's `KNOBS`.
    #[serde(default)]
    pub knobs: Vec<String>,
    /// Timed passes per value (at least 1).
    #[serde(default = "default_repeat")]
    pub repeat: u32,
}

/// The reply to `Trade`: one row per knob x value x pass x light (trade.csv's), and the work
/// knobs' values whose answers differ from their default value's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TradeResultReply {
    pub request_id: u64,
    pub frame: i32,
    pub rows: Vec<TradeRowState>,
    pub mismatches: Vec<TradeMismatchState>,
}

impl TradeRequest {
    /// A fresh trade of this request's knobs; an unknown knob or a bad value is an error
    /// naming the knob and the value.
    pub fn trade(&self) -> Result<Trade, ProtocolError> {
        Trade::parse(&self.knobs, &self.settings, self.repeat as usize).map_err(ProtocolError::Core)
    }

    /// Whether a trade built for `other` serves this request too (same knobs, common settings
    /// and repeat): then the values' state carries over.
    pub fn same_trade(&self, other: &TradeRequest) -> bool {
        self.settings == other.settings && self.knobs == other.knobs && self.repeat == other.repeat
    }
}

/// The `Progress` stage of a running trade: `done` of `total` passes ([`Trade::steps`]), sent
/// once before the first and after each.
pub const TRADE_STAGE: &str = "trade";
