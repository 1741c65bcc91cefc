//! A batch of render-space rays in, one answer (and optionally one work count) per ray out: the
//! batch split over the pool's threads in chunks, each chunk one call of core's batch query face
//! ([`RayQuery`]), where a packet kernel plugs in.

use antumbra_core::geometry::Ray;
use antumbra_core::trace::{Counters, Hit, RayQuery};
use rayon::prelude::*;

/// Rays per chunk: enough to amortise the scheduling, small enough to balance the threads.
const CHUNK: usize = 256;

/// The closest hit of each ray, with `stats[i]` counting ray i's work.
pub(crate) fn closest_hits<Q: RayQuery, C: Counters>(
    query: &Q,
    rays: &[Ray],
) -> (Vec<Option<Hit>>, Vec<C>) {
    let mut hits = vec![None; rays.len()];
    let mut stats = vec![C::default(); rays.len()];
    rays.par_chunks(CHUNK)
        .zip(hits.par_chunks_mut(CHUNK))
        .zip(stats.par_chunks_mut(CHUNK))
        .for_each(|((r, h), s)| query.closest_hit_batch(r, h, s));
    (hits, stats)
}

/// Whether each ray is blocked, with `stats[i]` counting ray i's work.
pub(crate) fn occlusion<Q: RayQuery, C: Counters>(query: &Q, rays: &[Ray]) -> (Vec<bool>, Vec<C>) {
    let mut blocked = vec![false; rays.len()];
    let mut stats = vec![C::default(); rays.len()];
    rays.par_chunks(CHUNK)
        .zip(blocked.par_chunks_mut(CHUNK))
        .zip(stats.par_chunks_mut(CHUNK))
        .for_each(|((r, b), s)| query.occluded_batch(r, b, s));
    (blocked, stats)
}
