//! The per-ray loops: a batch of render-space rays in, one answer (and optionally one work count)
//! per ray out, the batch split over the pool's threads in chunks. Each chunk goes through one
//! function taking a slice of rays, the place a batch query of the trees will plug in.

use antumbra_core::geometry::Ray;
use antumbra_core::trace::{ClosestHitQuery, Counters, Hit, OcclusionQuery};
use rayon::prelude::*;

/// Rays per chunk: enough to amortise the scheduling, small enough to balance the threads.
const CHUNK: usize = 256;

/// The closest hit of each ray, with `stats[i]` counting ray i's work.
pub(crate) fn closest_hits<Q: ClosestHitQuery, C: Counters + Default + Clone + Send>(
    query: &Q,
    rays: &[Ray],
) -> (Vec<Option<Hit>>, Vec<C>) {
    let mut hits = vec![None; rays.len()];
    let mut stats = vec![C::default(); rays.len()];
    rays.par_chunks(CHUNK)
        .zip(hits.par_chunks_mut(CHUNK))
        .zip(stats.par_chunks_mut(CHUNK))
        .for_each(|((r, h), s)| closest_hit_chunk(query, r, h, s));
    (hits, stats)
}

/// Whether each ray is blocked, with `stats[i]` counting ray i's work.
pub(crate) fn occlusion<Q: OcclusionQuery, C: Counters + Default + Clone + Send>(
    query: &Q,
    rays: &[Ray],
) -> (Vec<bool>, Vec<C>) {
    let mut blocked = vec![false; rays.len()];
    let mut stats = vec![C::default(); rays.len()];
    rays.par_chunks(CHUNK)
        .zip(blocked.par_chunks_mut(CHUNK))
        .zip(stats.par_chunks_mut(CHUNK))
        .for_each(|((r, b), s)| occlusion_chunk(query, r, b, s));
    (blocked, stats)
}

fn closest_hit_chunk<Q: ClosestHitQuery, C: Counters>(
    query: &Q,
    rays: &[Ray],
    hits: &mut [Option<Hit>],
    stats: &mut [C],
) {
    for ((ray, hit), s) in rays.iter().zip(hits).zip(stats) {
        *hit = query.closest_hit(ray, s);
    }
}

fn occlusion_chunk<Q: OcclusionQuery, C: Counters>(
    query: &Q,
    rays: &[Ray],
    blocked: &mut [bool],
    stats: &mut [C],
) {
    for ((ray, b), s) in rays.iter().zip(blocked).zip(stats) {
        *b = query.occluded(ray, s);
    }
}
