//! The cost model of `auto`: exact work counts to estimated nanoseconds of this machine kind,
//! through one table of calibrated weights ([`WEIGHTS`]).

use crate::trace::TraversalStats;

/// Nanoseconds of wall time (both cores of the calibration machine) per unit of work.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weights {
    /// Per ray/box test (N_box), per ray/triangle test (N_T), per node entered (N_B + N_L).
    pub box_test: f64,
    pub triangle_test: f64,
    pub node_visit: f64,
    /// Building the binary tree, per triangle: binned SAH, and OSAH (the split builder).
    pub sah_triangle: f64,
    pub osah_triangle: f64,
    /// Collapsing a binary tree to a wide one, per triangle of the set.
    pub collapse_triangle: f64,
    /// A per-tree order (SATO), and the sorting tables, per node of the wide tree.
    pub per_tree_node: f64,
    pub tables_node: f64,
    /// Sorting one light: per logged representative ray, and per node of the wide tree.
    pub log_ray: f64,
    pub sort_node: f64,
    /// SRDH for one light: per representative ray (its full hit list), per triangle built.
    pub srdh_ray: f64,
    pub srdh_triangle: f64,
}

/// Measured by `cargo run --release -p antumbra-cli --example auto_weights` (100k triangles,
/// 640x360, bedroom, city, forest; 2 cores, load about 4): box and triangle tests, and a wide
/// front-to-back traversal's per-node sort, add nothing measurable beyond the nodes entered
/// (non-negative least squares over 98 passes).
pub const WEIGHTS: Weights = Weights {
    box_test: 0.0,
    triangle_test: 0.0,
    node_visit: 27.2,
    sah_triangle: 230.0,
    osah_triangle: 285.0,
    collapse_triangle: 46.0,
    per_tree_node: 148.0,
    tables_node: 322.0,
    log_ray: 220.0,
    sort_node: 81.0,
    srdh_ray: 2097.0,
    srdh_triangle: 460.0,
};

impl Weights {
    /// The estimated time of the traversal work `w`, ns.
    pub fn trace_ns(&self, w: &TraversalStats) -> f64 {
        self.box_test * w.boxes as f64
            + self.triangle_test * w.triangles as f64
            + self.node_visit * (w.inner + w.leaves) as f64
    }

    /// Estimated time per ray of the work `w` over `rays` rays, ns (0 without rays).
    pub fn per_ray_ns(&self, w: &TraversalStats, rays: u64) -> f64 {
        if rays == 0 {
            0.0
        } else {
            self.trace_ns(w) / rays as f64
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_is_priced_linearly() {
        let w = TraversalStats {
            inner: 2,
            leaves: 1,
            triangles: 4,
            boxes: 8,
        };
        let ns = WEIGHTS.trace_ns(&w);
        let expected =
            8.0 * WEIGHTS.box_test + 4.0 * WEIGHTS.triangle_test + 3.0 * WEIGHTS.node_visit;
        assert!((ns - expected).abs() < 1e-9);
        assert!((WEIGHTS.per_ray_ns(&w, 2) - ns / 2.0).abs() < 1e-9);
        assert_eq!(WEIGHTS.per_ray_ns(&w, 0), 0.0);
    }
}
