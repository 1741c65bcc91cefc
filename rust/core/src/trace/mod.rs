//! Ray queries: closest hit and any hit on the binary BVH (any hit generic over the child
//! order, see [`crate::order`]), the wide trees' queries, [`RayQuery`] (the one face over all of
//! them, for one ray and a batch), and the brute-force reference they are tested against. The
//! traversals are generic over a [`HitFilter`] too: [`Opaque`] is today's code; the alpha
//! filters and [`AlphaQuery`] trace through alpha-textured materials (`docs/alpha.md`). Work
//! counters are a generic parameter: with [`NoStats`] every counting call is an empty inline
//! function, so the timed path pays nothing for them.

mod alpha_query;
mod any_hit;
mod brute;
mod closest;
mod counters;
mod filter;
mod query;
pub mod wide;

pub use alpha_query::AlphaQuery;
pub(crate) use alpha_query::{alpha_query_for, forward_alpha_query};
pub use any_hit::occluding_leaf;
pub(crate) use any_hit::{any_hit_walk, occluding_leaf_filtered};
pub use brute::{
    brute_closest_hit, brute_closest_hit_alpha, brute_occluded, brute_transmission,
    transmission_of_hits,
};
pub(crate) use closest::closest_hit_filtered;
pub use counters::{AlphaStats, Counters, NoStats, TraversalStats};
pub use filter::{AlphaClip, AlphaScenes, HitFilter, Opaque, Transmission, TransparentHit};
pub(crate) use query::{closest_hit_each, forward_ray_query, occluded_each};
pub use query::{BinaryInOrder, OrderedBinary, OrderedWide, RayMode, RayQuery};

/// A closest hit: the ray parameter, the triangle id (in the `TriangleSet` the BVH was built
/// from, or in the hit instance's mesh tree) and the barycentric weights of its vertices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub triangle: u32,
    /// The object hit in a two-level scene (its index in the frame's objects,
    /// [`crate::two_level`]); 0 on a flat tree, whose `triangle` alone names the triangle.
    pub instance: u32,
    pub b0: f32,
    pub b1: f32,
    pub b2: f32,
}

impl Hit {
    /// Orders hits by distance, ties by triangle id, so every method returns the same hit.
    #[inline(always)]
    pub fn closer_than(t: f32, id: u32, best: &Option<Hit>) -> bool {
        match best {
            None => true,
            Some(b) => t < b.t || (t == b.t && id < b.triangle),
        }
    }
}
