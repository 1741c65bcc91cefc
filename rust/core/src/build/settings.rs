//! The builders' settings: one struct for every builder (bins, leaf sizes, SAH costs, the
//! OSAH weight) with the spatial-split settings inside it, and their validation.

use serde::{Deserialize, Serialize};

/// Upper bound of `BuildSettings::bins`; bins live in fixed arrays of this size.
pub const MAX_BINS: usize = 256;

/// Settings of the binned SAH builder.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BuildSettings {
    /// Bins per axis (2..=256). More bins find better splits at a higher build cost.
    pub bins: usize,
    /// Leaves never hold more triangles than this (1..=64).
    pub max_leaf_size: usize,
    /// Nodes of at most this many references become leaves without a split search
    /// (1..=`max_leaf_size`; Embree's `minLeafSize`). 1, the default, lets the SAH decide
    /// every leaf; larger values skip the bottom levels' binning (a faster build) for leaves
    /// of more triangles (more triangle tests, fewer nodes entered).
    #[serde(default = "default_min_leaf_size")]
    pub min_leaf_size: usize,
    /// SAH cost of one traversal step, relative to `intersection_cost`.
    pub traversal_cost: f32,
    /// SAH cost of one ray/triangle test.
    pub intersection_cost: f32,
    /// Spatial splits of the SBVH, ABVH and OSAH builders.
    #[serde(default)]
    pub spatial: SpatialSettings,
    /// OSAH weight w of the visible-triangle term (the paper's equation 4), in (0, 1).
    #[serde(default = "default_osah_weight")]
    pub osah_weight: f32,
    /// OSAH viability: besides the paper's condition (5), the hidden child must hold no visible
    /// triangle (true, the default: measured better); false is the paper's condition (5)
    /// alone.
    #[serde(default = "default_osah_strict")]
    pub osah_strict_viability: bool,
}

fn default_min_leaf_size() -> usize {
    1
}

fn default_osah_strict() -> bool {
    true
}

fn default_osah_weight() -> f32 {
    0.9
}

impl Default for BuildSettings {
    fn default() -> Self {
        BuildSettings {
            bins: 16,
            max_leaf_size: 8,
            min_leaf_size: default_min_leaf_size(),
            traversal_cost: 1.0,
            intersection_cost: 1.0,
            spatial: SpatialSettings::default(),
            osah_weight: default_osah_weight(),
            osah_strict_viability: default_osah_strict(),
        }
    }
}

/// Ranges are checked where settings enter (`crate::settings::SCHEMA`); the builders clamp
/// what they rely on.
impl BuildSettings {
    /// Nodes of at most this many references are leaves without a split search: the
    /// smallest leaf, never below 1 even in settings that were not validated.
    pub(crate) fn unsplit_refs(&self) -> usize {
        self.min_leaf_size.max(1)
    }
}

/// Settings of spatial splits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SpatialSettings {
    /// Whether the SBVH, ABVH and OSAH builders may split space at all.
    pub enabled: bool,
    /// Spatial bins per axis (2..=256).
    pub bins: usize,
    /// Spatial splits are tried only in nodes whose best object split's children overlap by
    /// more than this fraction of the root's surface area (Stich et al.'s alpha; 1 disables).
    pub alpha: f32,
    /// Spatial splits are tried only in nodes whose best object split's children overlap by
    /// at least this fraction of the node's own surface area (Embree's spatial-split gate;
    /// 0 tries every node that passes `alpha`, as Stich et al.).
    #[serde(default)]
    pub node_overlap: f32,
    /// Nodes with fewer references than this never try spatial splits (outside OSAH's depth
    /// they are built by the binned SAH builder); 0 tries every node.
    #[serde(default)]
    pub min_refs: usize,
    /// References may grow to at most (1 + max_growth) x triangles; the budget is handed down
    /// the tree in proportion to child sizes, so the build stays deterministic.
    pub max_growth: f32,
    /// Which axes spatial splits are binned on: all three (Stich et al.), or only the axis of
    /// the node's best object split (SAH's and, in OSAH nodes, OSAH's: at most two axes), which
    /// clips each straddling reference a third as often. The default is the object split's
    /// axis: it kept the bench views' N_IT/N_TS close to all three axes' at a much faster OSAH
    /// build; `All` is the SBVH as Stich et al. define it.
    pub axes: SpatialAxes,
    /// Nodes with fewer references than this bin spatial candidates with each straddling
    /// reference's box cut at the bin planes instead of its triangle clipped to each bin (the
    /// partition of the chosen split always clips, so children get the clipped triangles' tight
    /// boxes). 0 clips everywhere, as Stich et al. The default never clips in binning: cut
    /// boxes left every N_IT/N_TS and reference count of the bench views unchanged at a
    /// cheaper build.
    #[serde(default)]
    pub clip_min_refs: usize,
}

/// The default [`SpatialSettings::clip_min_refs`]: no node is that large (it also fits the
/// protocol's 32-bit field, so the default survives a round trip).
const CLIP_NEVER: usize = u32::MAX as usize;

/// The axes a node bins spatial split candidates on (see [`SpatialSettings::axes`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SpatialAxes {
    /// x, y and z, as Stich et al.
    All,
    /// The best object split's axis only.
    Object,
}

impl std::fmt::Display for SpatialAxes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SpatialAxes::All => "all",
            SpatialAxes::Object => "object",
        })
    }
}

impl std::str::FromStr for SpatialAxes {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "all" => Ok(SpatialAxes::All),
            "object" => Ok(SpatialAxes::Object),
            other => Err(format!("spatial axes: '{other}' is not all or object")),
        }
    }
}

impl Default for SpatialSettings {
    fn default() -> Self {
        SpatialSettings {
            enabled: true,
            bins: 32,
            alpha: 1e-5,
            node_overlap: 0.0,
            min_refs: 0,
            max_growth: 0.5,
            axes: SpatialAxes::Object,
            clip_min_refs: CLIP_NEVER,
        }
    }
}
