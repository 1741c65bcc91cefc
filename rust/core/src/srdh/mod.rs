//! SRDH (Feltman, Lee & Fatahalian, HPG 2012): a binary BVH specialised for one light's shadow
//! rays. From representative rays and every triangle each one intersects ([`RaySet`]), a greedy
//! top-down build ([`build_srdh`]) chooses per node the partition and the traversal kernel that
//! minimise the shadow-ray-distribution cost ([`cost`]); the kernel-guided any-hit traversal
//! ([`occluded_with`]) follows the kernels, stored in 2 bits per node next to the usual nodes.

mod build;
pub mod cost;
mod ray_set;

pub use build::{
    build_srdh, build_srdh_over_boxes, root_candidates, Candidate, RootCandidates, SrdhBvh,
    DEFAULT_KERNEL,
};
pub use ray_set::{all_hits, RaySet};
