//! How a tree is built ([`BuildOptions`]) and how rays are traced on it ([`TraceOptions`]), with
//! the checks that turn a bad choice into an error naming the field.

use antumbra_core::build::{BuildMethod, BuildSettings, CollapseSettings, MAX_BINS};
use antumbra_core::bvh::BvhWidth;
use antumbra_core::order::ShadowOrder;
use antumbra_core::trace::wide::BoxKernel;
use antumbra_core::{Error, Result};

use crate::Interval;

/// How [`crate::Scene::build`] makes its tree.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildOptions {
    /// The binary builder: SAH, SBVH, ABVH, OSAH or VSAH (`auto` is the renderer's per-frame
    /// policy, not a builder).
    pub method: BuildMethod,
    /// Bins, leaf sizes, SAH costs and spatial splits of the builder.
    pub settings: BuildSettings,
    /// Children per node: 2 traces the binary tree; 4 and 8 its wide collapse (SIMD box tests).
    pub width: BvhWidth,
    /// How the binary tree is collapsed into 4- or 8-wide nodes.
    pub collapse: CollapseSettings,
    /// Per caller triangle, whether it is expected to be seen: read by ABVH, OSAH (spatial splits
    /// and the occlusion heuristic where visible triangles are) and VSAH (a tree over the visible
    /// triangles alone, so it misses the others). `None`: no triangle for ABVH and OSAH (they
    /// build the SAH tree), every triangle for VSAH.
    pub visible: Option<Vec<bool>>,
    /// Threads of the build: 0 uses rayon's global pool, n a pool of its own of n threads.
    pub threads: usize,
}

impl Default for BuildOptions {
    /// SAH, 8 wide: the 8-wide traversal is the one that outruns Embree per thread
    /// (BENCHMARKS.md), the binary tree is 0.5-0.6x of it.
    fn default() -> Self {
        BuildOptions {
            method: BuildMethod::Sah,
            settings: BuildSettings::default(),
            width: BvhWidth::Eight,
            collapse: CollapseSettings::default(),
            visible: None,
            threads: 0,
        }
    }
}

impl BuildOptions {
    pub(crate) fn check(&self, triangles: usize) -> Result<()> {
        let s = &self.settings;
        in_range("settings.bins", s.bins, 2, MAX_BINS)?;
        in_range("settings.max_leaf_size", s.max_leaf_size, 1, 64)?;
        in_range(
            "settings.min_leaf_size",
            s.min_leaf_size,
            1,
            s.max_leaf_size,
        )?;
        in_range("settings.spatial.bins", s.spatial.bins, 2, MAX_BINS)?;
        for (field, cost) in [
            ("settings.traversal_cost", s.traversal_cost),
            ("settings.intersection_cost", s.intersection_cost),
        ] {
            if !(cost.is_finite() && cost > 0.0) {
                return Err(Error::invalid(field, format!("must be > 0, got {cost}")));
            }
        }
        check_threads(self.threads)?;
        if let Some(v) = &self.visible {
            if v.len() != triangles {
                return Err(Error::invalid(
                    "visible",
                    format!("has {} entries for {triangles} triangles", v.len()),
                ));
            }
        }
        Ok(())
    }
}

/// The most threads a pool may be asked for: far above any machine's cores, far below what
/// would exhaust the process (each thread has its own stack).
pub const MAX_THREADS: usize = 1024;

fn check_threads(threads: usize) -> Result<()> {
    in_range("threads", threads, 0, MAX_THREADS)
}

fn in_range(field: &str, value: usize, lo: usize, hi: usize) -> Result<()> {
    if (lo..=hi).contains(&value) {
        Ok(())
    } else {
        Err(Error::invalid(
            field,
            format!("must be in {lo}..={hi}, got {value}"),
        ))
    }
}

/// How [`crate::Scene`]'s queries trace a batch of rays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TraceOptions {
    /// Whether a hit at exactly `t_near` counts.
    pub interval: Interval,
    /// The box test of 4- and 8-wide trees (every kernel gives the same answers and counts).
    pub kernel: BoxKernel,
    /// The child order of any-hit queries: `stored`, `fbto` (the default), `sato`, `rtsah`,
    /// `random`, or `sorted`, prepared from the pseudo-random `budget` share of the batch's own
    /// rays. It changes the work, never the answers. `srdh` (a per-light tree of the renderer) is
    /// refused; `auto` is the renderer's per-light policy, not an order.
    pub order: ShadowOrder,
    /// Threads: 0 uses rayon's global pool, n a pool of its own of n threads (1: the timing of
    /// one core).
    pub threads: usize,
}

impl TraceOptions {
    pub(crate) fn check(&self) -> Result<()> {
        check_threads(self.threads)?;
        self.order.validate()?;
        match self.order {
            ShadowOrder::Srdh(_) => Err(Error::invalid(
                "order",
                format!(
                    "'{}' is a per-light policy of the renderer; ray queries take stored, fbto, \
                     sato, rtsah, random or sorted",
                    self.order
                ),
            )),
            _ => Ok(()),
        }
    }
}
