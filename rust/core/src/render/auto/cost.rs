//! The cost model of `auto`: exact work counts to estimated nanoseconds of this machine kind,
//! through one table of calibrated weights ([`WEIGHTS`]), priced per traversal kernel.

use crate::trace::TraversalStats;

/// The traversal a pass's rays ran: each prices a node entered differently (a binary node tests
/// two boxes one by one, a wide one eight at once; front to back on a wide tree also sorts the
/// children it hits), and camera and shadow rays cost differently to make.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Traversal {
    /// Shadow rays on a binary tree (front to back, or a light's SRDH tree).
    BinaryAnyHit,
    /// Shadow rays on a wide tree in a stored order (SATO, sorted per light).
    WideAnyHit,
    /// Shadow rays on a wide tree front to back (a sort of the hit children per node).
    WideFrontToBack,
    /// Camera rays (closest hit) on the binary tree.
    BinaryClosest,
    /// Camera rays (closest hit) on a wide tree.
    WideClosest,
}

impl Traversal {
    pub const ALL: [Traversal; 5] = [
        Traversal::BinaryAnyHit,
        Traversal::WideAnyHit,
        Traversal::WideFrontToBack,
        Traversal::BinaryClosest,
        Traversal::WideClosest,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Traversal::BinaryAnyHit => "binary_any_hit",
            Traversal::WideAnyHit => "wide_any_hit",
            Traversal::WideFrontToBack => "wide_front_to_back",
            Traversal::BinaryClosest => "binary_closest",
            Traversal::WideClosest => "wide_closest",
        }
    }

    /// The camera rays' traversal: on the wide tree at widths 4 and 8, else the binary one.
    pub fn camera(wide: bool) -> Traversal {
        if wide {
            Traversal::WideClosest
        } else {
            Traversal::BinaryClosest
        }
    }

    fn is_camera(self) -> bool {
        matches!(self, Traversal::BinaryClosest | Traversal::WideClosest)
    }
}

/// Nanoseconds of wall time (both cores of the calibration machine) per unit of work.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weights {
    /// Per ray/box test (N_box) and per ray/triangle test (N_T), whatever the kernel.
    pub box_test: f64,
    pub triangle_test: f64,
    /// Per ray made and traced, apart from its nodes: a shadow ray (light sample, ray set-up,
    /// the mask's write) and a camera ray (its surface record).
    pub shadow_ray: f64,
    pub camera_ray: f64,
    /// Per node entered (N_B + N_L), by kernel in the order of [`Traversal::ALL`].
    pub node: [f64; 5],
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
/// 640x360, the five scenes; 2 cores, otherwise idle; medians of 3 timed passes). Without the
/// per-ray terms the nodes were priced at 27 ns and took the rays' own cost with them, so
/// orders that enter fewer nodes looked far cheaper than they trace.
pub const WEIGHTS: Weights = Weights {
    box_test: 0.0,
    triangle_test: 3.37,
    shadow_ray: 39.3,
    camera_ray: 53.9,
    node: [11.9, 5.20, 4.91, 9.30, 2.95],
    sah_triangle: 139.0,
    osah_triangle: 269.0,
    collapse_triangle: 70.7,
    per_tree_node: 164.0,
    tables_node: 375.0,
    // Choosing the representative rays included (a scan of every pixel, one thread): 135 ns
    // without it.
    log_ray: 264.0,
    sort_node: 120.0,
    srdh_ray: 1415.0,
    srdh_triangle: 457.0,
};

impl Weights {
    /// The estimated time of the traversal work `w` of `rays` rays on `kernel`, ns.
    pub fn trace_ns(&self, kernel: Traversal, w: &TraversalStats, rays: u64) -> f64 {
        let ray = if kernel.is_camera() {
            self.camera_ray
        } else {
            self.shadow_ray
        };
        ray * rays as f64
            + self.box_test * w.boxes as f64
            + self.triangle_test * w.triangles as f64
            + self.node[kernel as usize] * (w.inner + w.leaves) as f64
    }

    /// Estimated time per ray of the work `w` over `rays` rays on `kernel`, ns (0 without rays).
    pub fn per_ray_ns(&self, kernel: Traversal, w: &TraversalStats, rays: u64) -> f64 {
        if rays == 0 {
            0.0
        } else {
            self.trace_ns(kernel, w, rays) / rays as f64
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_is_priced_linearly_per_kernel() {
        let w = TraversalStats {
            inner: 2,
            leaves: 1,
            triangles: 4,
            boxes: 8,
            ..TraversalStats::default()
        };
        for kernel in Traversal::ALL {
            let ns = WEIGHTS.trace_ns(kernel, &w, 2);
            let ray = if kernel.is_camera() {
                WEIGHTS.camera_ray
            } else {
                WEIGHTS.shadow_ray
            };
            let expected = 2.0 * ray
                + 8.0 * WEIGHTS.box_test
                + 4.0 * WEIGHTS.triangle_test
                + 3.0 * WEIGHTS.node[kernel as usize];
            assert!((ns - expected).abs() < 1e-9, "{kernel:?}");
            assert!((WEIGHTS.per_ray_ns(kernel, &w, 2) - ns / 2.0).abs() < 1e-9);
            assert_eq!(WEIGHTS.per_ray_ns(kernel, &w, 0), 0.0);
        }
    }
}
