//! The `Compare` request: one frame rendered with several methods by antumbra-core's
//! [`Comparison`], whose rows and mismatches travel back as the core's own serde forms. (The
//! comparison a session keeps across its requests is `antumbra_session::CompareState`.)

use antumbra_core::compare::{default_methods, Comparison, FrameComparison, MethodSpec};
use antumbra_core::image::ImagePlane;
use serde::{Deserialize, Serialize};

use crate::convert::{image, plane_from_image};
use crate::error::ProtocolError;
use crate::messages::{Image, NamedSettings};

pub use antumbra_core::compare::{CompareRow as CompareRowState, Mismatch as MismatchState};

/// One labelled method: the settings it changes over the request's common ones.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompareMethod {
    pub label: String,
    #[serde(default)]
    pub settings: NamedSettings,
}

/// Timed passes per method and frame when a request names none (`Compare` and `Trade`).
pub const DEFAULT_REPEAT: u32 = 3;

fn default_repeat() -> u32 {
    DEFAULT_REPEAT
}

/// Render a frame sent with `FrameUpdate` with every method. The session keeps one comparison
/// while `settings`, `methods`, `baseline` and `repeat` stay the same, so each method keeps its
/// state across frames (previous-frame visibility, tree reuse) as `antumbra compare` does.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompareRequest {
    pub frame: i32,
    /// Chosen by the client; echoed in `CompareResult`.
    pub request_id: u64,
    /// The settings every method shares (spp, seed), by name.
    #[serde(default)]
    pub settings: NamedSettings,
    /// In order; empty: antumbra-core's default methods.
    #[serde(default)]
    pub methods: Vec<CompareMethod>,
    /// The label whose answers the others must equal; nil: the first method.
    #[serde(default)]
    pub baseline: Option<String>,
    /// Timed passes per method (at least 1).
    #[serde(default = "default_repeat")]
    pub repeat: u32,
    /// Whether the reply carries each method's heat plane (`CompareResult.heat`).
    #[serde(default)]
    pub images: bool,
    /// Advance every method's state only (as `RenderRequest::warm_up`): the `CompareResult`
    /// has no rows, mismatches or heat. Omitted when false.
    #[serde(default, skip_serializing_if = "crate::messages::is_false")]
    pub warm_up: bool,
}

/// The reply to `Compare`: one row per method x pass x light, and the methods whose masks or
/// primary ids differ from the baseline's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompareResultReply {
    pub request_id: u64,
    pub frame: i32,
    /// Each method's spec as `LABEL=NAME=VALUE,...` (the `settings` column of compare.csv).
    pub methods: Vec<String>,
    pub rows: Vec<CompareRowState>,
    pub mismatches: Vec<MismatchState>,
    /// When the request asked for images: per method, in order, its shadow-ray node visits per
    /// pixel (N_B summed over lights and samples), named by the method's label.
    #[serde(default)]
    pub heat: Vec<Image>,
}

impl CompareRequest {
    /// The methods this request names (the defaults when none).
    pub fn specs(&self) -> Result<Vec<MethodSpec>, ProtocolError> {
        if self.methods.is_empty() {
            return Ok(default_methods());
        }
        self.methods
            .iter()
            .map(|m| MethodSpec::new(&m.label, m.settings.clone()).map_err(ProtocolError::Core))
            .collect()
    }

    /// A fresh comparison of this request's methods; an unknown setting or a bad value is an
    /// error naming the method and the setting.
    pub fn comparison(&self) -> Result<Comparison, ProtocolError> {
        Comparison::new(
            &self.specs()?,
            &self.settings,
            self.baseline.as_deref(),
            self.repeat as usize,
        )
        .map_err(ProtocolError::Core)
    }

    /// Whether a comparison built for `other` serves this request too (same methods, common
    /// settings, baseline and repeat; `images` only shapes the reply): then the methods' state
    /// carries over.
    pub fn same_comparison(&self, other: &CompareRequest) -> bool {
        self.settings == other.settings
            && self.methods == other.methods
            && self.baseline == other.baseline
            && self.repeat == other.repeat
    }
}

/// The reply for one compared frame, with each method's heat plane when `images`.
pub fn compare_result_reply(
    comparison: &Comparison,
    result: FrameComparison,
    request_id: u64,
    images: bool,
) -> CompareResultReply {
    let heat = if images {
        let planes = result.methods.iter();
        planes
            .filter_map(|m| Some(image(m.shadow_heat()?, m.label.clone())))
            .collect()
    } else {
        Vec::new()
    };
    CompareResultReply {
        request_id,
        frame: result.frame,
        methods: comparison.specs().iter().map(|s| s.to_string()).collect(),
        rows: result.methods.into_iter().flat_map(|m| m.rows).collect(),
        mismatches: result.mismatches,
        heat,
    }
}

/// The reply to a warm-up: the methods, and no rows, mismatches or heat.
pub fn compare_warm_up_reply(
    comparison: &Comparison,
    frame: i32,
    request_id: u64,
) -> CompareResultReply {
    CompareResultReply {
        request_id,
        frame,
        methods: comparison.specs().iter().map(|s| s.to_string()).collect(),
        rows: Vec::new(),
        mismatches: Vec::new(),
        heat: Vec::new(),
    }
}

/// The heat planes of a reply, each named by its method's label; a plane whose data does not
/// fill its size is an error naming it.
pub fn heat_from_reply(reply: &CompareResultReply) -> Result<Vec<ImagePlane>, ProtocolError> {
    reply
        .heat
        .iter()
        .map(|img| plane_from_image(img, reply.frame))
        .collect()
}

/// The `Progress` stage of a running comparison: `done` of `total` method passes
/// ([`Comparison::steps`]), sent once before the first and after each.
pub const COMPARE_STAGE: &str = "compare";
