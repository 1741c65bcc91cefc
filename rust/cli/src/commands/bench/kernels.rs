//! Embree's calls one after another on the same tiled rays as antumbra (`--compare embree`,
//! `--ray-files`): each call's Mrays/s, its ratio to antumbra's and the rays on which its answer
//! differs from antumbra's; every call's timed runs alternate with antumbra's.

use antumbra_core::geometry::Ray;
use rayon::prelude::*;
use serde::Serialize;

use super::reference::{Kernel, Reference};
use super::tiles::TiledRays;
use super::{mrays, timed};

/// One Embree call on one kind of rays.
#[derive(Clone, Debug, Serialize)]
pub struct KernelRow {
    /// `any_hit` (a scene's shadow rays) or `closest_hit` (its camera rays).
    pub query: &'static str,
    /// Embree's function, e.g. `rtcOccluded16`.
    pub kernel: &'static str,
    /// The context flag: `incoherent` or `coherent`.
    pub context: &'static str,
    pub mrays: f64,
    /// antumbra's Mrays/s over this call's (above 1: antumbra is faster).
    pub antumbra_ratio: f64,
    /// Rays whose answer differs from antumbra's: occluded or not; hit or miss, or a different
    /// triangle hit (ties in t between triangles count too).
    pub disagreements: usize,
}

/// Which query the rays ask.
#[derive(Clone, Copy)]
pub(super) enum Query {
    /// Any hit; antumbra's answers.
    Occlusion,
    /// Closest hit, the triangle id; antumbra's answers.
    ClosestHit,
}

/// antumbra's answers, for the disagreement counts.
pub(super) enum Answers<'a> {
    Occluded(&'a [bool]),
    Triangles(&'a [Option<u32>]),
}

impl Answers<'_> {
    fn query(&self) -> Query {
        match self {
            Answers::Occluded(_) => Query::Occlusion,
            Answers::Triangles(_) => Query::ClosestHit,
        }
    }
}

/// antumbra's best ms (`ours`, timed first in each round) and one row per Embree call, each
/// call timed right after antumbra in every round of `repeat`, tile by tile on the current
/// pool.
pub(super) fn time_in_turn(
    reference: &Reference,
    tiled: &TiledRays,
    answers: Answers,
    repeat: u32,
    mut ours: impl FnMut(),
) -> (f64, Vec<KernelRow>) {
    let kernels = Kernel::all();
    let query = answers.query();
    let mut best = f64::INFINITY;
    let mut theirs = vec![f64::INFINITY; kernels.len()];
    for _ in 0..repeat.max(1) {
        best = best.min(timed(&mut ours).1);
        for (k, b) in kernels.iter().zip(theirs.iter_mut()) {
            *b = b.min(timed(|| trace_tiles(reference, *k, query, tiled)).1);
        }
    }
    let ours_mrays = mrays(tiled.len(), best);
    let rows = kernels
        .iter()
        .zip(theirs)
        .map(|(k, ms)| {
            let mrays = mrays(tiled.len(), ms);
            KernelRow {
                query: match query {
                    Query::Occlusion => "any_hit",
                    Query::ClosestHit => "closest_hit",
                },
                kernel: match query {
                    Query::Occlusion => k.occluded_name(),
                    Query::ClosestHit => k.intersect_name(),
                },
                context: k.context(),
                mrays,
                antumbra_ratio: ours_mrays / mrays,
                disagreements: disagreements(reference, *k, tiled, &answers),
            }
        })
        .collect();
    (best, rows)
}

/// Every tile's rays in one call of `kernel` (a packet call per 8 or 16 of them), answers into
/// a buffer per thread.
fn trace_tiles(reference: &Reference, kernel: Kernel, query: Query, tiled: &TiledRays) {
    match query {
        Query::Occlusion => {
            tiled
                .tile_rays()
                .for_each_init(Vec::new, |out: &mut Vec<bool>, rays| {
                    out.resize(rays.len(), false);
                    reference.occluded_with(kernel, rays, out);
                    std::hint::black_box(out);
                })
        }
        Query::ClosestHit => {
            tiled
                .tile_rays()
                .for_each_init(Vec::new, |out: &mut Vec<Option<(f32, u32)>>, rays| {
                    out.resize(rays.len(), None);
                    reference.intersect_with(kernel, rays, out);
                    std::hint::black_box(out);
                })
        }
    }
}

/// Rays on which `kernel`, called tile by tile, answers otherwise than antumbra.
fn disagreements(
    reference: &Reference,
    kernel: Kernel,
    tiled: &TiledRays,
    answers: &Answers,
) -> usize {
    let per_tile = |rays: &[Ray], first: usize| match answers {
        Answers::Occluded(ours) => {
            let mut out = vec![false; rays.len()];
            reference.occluded_with(kernel, rays, &mut out);
            out.iter()
                .zip(&ours[first..])
                .filter(|(a, b)| a != b)
                .count()
        }
        Answers::Triangles(ours) => {
            let mut out = vec![None; rays.len()];
            reference.intersect_with(kernel, rays, &mut out);
            out.iter()
                .zip(&ours[first..])
                .filter(|(a, b)| a.map(|h| h.1) != **b)
                .count()
        }
    };
    tiled
        .tiles
        .par_iter()
        .map(|t| per_tile(&tiled.rays[t.clone()], t.start))
        .sum()
}

/// The kernel table under the main one: per row of `rows` (a label such as scene and frame,
/// and a thread count), each call's figures.
pub(super) fn print_kernel_table<'a>(rows: impl Iterator<Item = (String, usize, &'a [KernelRow])>) {
    let rows: Vec<_> = rows.collect();
    let w = rows.iter().map(|r| r.0.len()).max().unwrap_or(0);
    println!(
        "{:<w$} {:>3} {:<11} {:<15} {:<10} {:>9} {:>10} {:>9}",
        "", "thr", "query", "Embree call", "context", "Mrays/s", "antumbra x", "disagree"
    );
    for (label, threads, kernels) in rows {
        for k in kernels {
            println!(
                "{:<w$} {:>3} {:<11} {:<15} {:<10} {:>9.2} {:>10.2} {:>9}",
                label,
                threads,
                k.query,
                k.kernel,
                k.context,
                k.mrays,
                k.antumbra_ratio,
                k.disagreements
            );
        }
    }
    println!(
        "Embree's calls on antumbra's rays, grouped as antumbra traces them (tiles of {0}x{0} pixels; a ray file's rays in groups of {1}); each call timed in turn with antumbra; antumbra x = antumbra Mrays/s / the call's; disagree = rays answered otherwise than antumbra (closest hit: another triangle or hit/miss); a scene's any_hit rays are its shadow rays, closest_hit its camera rays",
        antumbra_core::render::tiles::TILE_SIDE,
        super::tiles::FILE_TILE
    );
}
