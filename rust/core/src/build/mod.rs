//! BVH builders and their reusable pieces, after Embree's `kernels/builders`: primitive
//! references, the settings, per-thread scratch and centroid binning, then one file per builder:
//! binned SAH, the split builder (SBVH, ABVH, OSAH; its object splits, spatial splits, clipping
//! and cost models apart), VSAH and the wide collapse. [`BuildMethod`] picks a binary builder.

mod binning;
mod clip;
mod collapse;
mod coverage;
mod object_split;
mod osah_cost;
mod primref;
mod sah;
mod scratch;
mod settings;
mod spatial_split;
mod split;
mod vsah;

pub use collapse::{CollapseCost, CollapseMethod, CollapseSettings, MERGE_LIMIT};
pub use coverage::check_references;
pub(crate) use primref::{Box4, PrimRef};
pub use sah::{build_binned_sah, build_over_boxes};
pub(crate) use sah::{build_sah_nodes, MEDIAN_DEPTH};
pub use settings::{BuildSettings, SpatialAxes, SpatialSettings, MAX_BINS};

use serde::{Deserialize, Serialize};

use crate::bvh::Bvh;
use split::{build_split_bvh, SplitPolicy};

/// Which builder makes the binary BVH.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum BuildMethod {
    /// Binned SAH.
    #[default]
    Sah,
    /// SAH with spatial splits everywhere (Stich et al. 2009).
    Sbvh,
    /// Spatial splits only where visible triangles are, SAH elsewhere.
    Abvh,
    /// ABVH plus the occlusion heuristic near the root (Vinkler, Havran & Sochor).
    Osah,
    /// SAH over the visible triangles only: a bound for comparisons, not a complete tree.
    Vsah,
}

impl BuildMethod {
    pub const ALL: [BuildMethod; 5] = [
        BuildMethod::Sah,
        BuildMethod::Sbvh,
        BuildMethod::Abvh,
        BuildMethod::Osah,
        BuildMethod::Vsah,
    ];

    pub fn name(&self) -> &'static str {
        match self {
            BuildMethod::Sah => "sah",
            BuildMethod::Sbvh => "sbvh",
            BuildMethod::Abvh => "abvh",
            BuildMethod::Osah => "osah",
            BuildMethod::Vsah => "vsah",
        }
    }

    /// Whether the build reads a visible-triangle set.
    pub fn uses_visibility(&self) -> bool {
        matches!(
            self,
            BuildMethod::Abvh | BuildMethod::Osah | BuildMethod::Vsah
        )
    }

    /// Whether the tree answers every ray (all but VSAH).
    pub fn is_complete(&self) -> bool {
        *self != BuildMethod::Vsah
    }
}

impl std::fmt::Display for BuildMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for BuildMethod {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<Self> {
        BuildMethod::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                crate::Error::invalid(
                    "build",
                    format!("unknown build method '{s}' (known: sah, sbvh, abvh, osah, vsah)"),
                )
            })
    }
}

/// Builds a BVH over `triangles` with the chosen method and no visibility input (ABVH and OSAH
/// then build the SAH tree, VSAH takes every triangle as visible).
pub fn build(method: BuildMethod, triangles: &[[glam::Vec3; 3]], settings: &BuildSettings) -> Bvh {
    build_with_visibility(method, triangles, None, settings)
}

/// Builds a BVH over `triangles`; `visible[i]` says whether triangle i is expected to be seen
/// (read by ABVH, OSAH and VSAH; `None` is an empty set, except for VSAH where it is all).
pub fn build_with_visibility(
    method: BuildMethod,
    triangles: &[[glam::Vec3; 3]],
    visible: Option<&[bool]>,
    settings: &BuildSettings,
) -> Bvh {
    match method {
        BuildMethod::Sah => build_binned_sah(triangles, settings),
        BuildMethod::Sbvh => build_split_bvh(triangles, None, SplitPolicy::Sbvh, settings),
        BuildMethod::Abvh => build_split_bvh(triangles, visible, SplitPolicy::Abvh, settings),
        BuildMethod::Osah => build_split_bvh(triangles, visible, SplitPolicy::Osah, settings),
        BuildMethod::Vsah => match visible {
            Some(v) => vsah::build_vsah(triangles, v, settings),
            None => build_binned_sah(triangles, settings),
        },
    }
}

#[cfg(test)]
mod fingerprint_tests;
