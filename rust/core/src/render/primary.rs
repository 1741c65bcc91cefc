//! Primary rays: one closest-hit ray through each pixel centre.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use super::PrimaryRays;
use crate::cancel::CancelToken;
use crate::geometry::triangle_normal;
use crate::image::ImagePlane;
use crate::scene::TriangleSet;
use crate::trace::{ClosestHitQuery, Counters, NoStats, TraversalStats};
use crate::Result;

/// What a primary ray found: the hit point and the unit geometric normal turned to face the
/// camera (so "the light's side" is well defined for both faces of a triangle).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub position: Vec3,
    pub normal: Vec3,
    /// The unit normal whose side light samples must be on ([`super::Facing`]): `normal`, or
    /// the shading normal turned with it.
    pub facing: Vec3,
    pub triangle: u32,
}

/// The result of the primary pass.
#[derive(Clone, Debug)]
pub struct PrimaryPass {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first; `None` where the ray hit nothing.
    pub surfaces: Vec<Option<SurfacePoint>>,
    /// Per-pixel work (empty when not counted).
    pub work: Vec<TraversalStats>,
    pub totals: TraversalStats,
    pub trace_ms: f64,
}

impl PrimaryPass {
    /// Traces with exact counters.
    pub fn counted(
        rays: &PrimaryRays,
        bvh: &impl ClosestHitQuery,
        triangles: &TriangleSet,
    ) -> Self {
        Self::counted_cancellable(rays, bvh, triangles, &CancelToken::new())
            .expect("a new token is never cancelled")
    }

    /// As [`counted`](Self::counted), stopping with [`crate::Error::Cancelled`] once `cancel`
    /// is set (read once per tile of [`TILE`] pixels).
    pub fn counted_cancellable(
        rays: &PrimaryRays,
        bvh: &impl ClosestHitQuery,
        triangles: &TriangleSet,
        cancel: &CancelToken,
    ) -> Result<Self> {
        let start = Instant::now();
        let (surfaces, work): (Vec<_>, Vec<_>) = pixels(rays)
            .map_init(
                || false,
                |stopped, (i, x, y)| {
                    let mut stats = TraversalStats::default();
                    if tile_stopped(i, stopped, cancel) {
                        return (None, stats);
                    }
                    let s = trace_pixel(rays, bvh, triangles, x, y, &mut stats);
                    (s, stats)
                },
            )
            .unzip();
        cancel.check()?;
        let trace_ms = start.elapsed().as_secs_f64() * 1e3;
        let mut totals = TraversalStats::default();
        for w in &work {
            totals += *w;
        }
        Ok(PrimaryPass {
            width: rays.width,
            height: rays.height,
            surfaces,
            work,
            totals,
            trace_ms,
        })
    }

    /// Traces with counters compiled out: the timed path.
    pub fn timed(rays: &PrimaryRays, bvh: &impl ClosestHitQuery, triangles: &TriangleSet) -> Self {
        Self::timed_cancellable(rays, bvh, triangles, &CancelToken::new())
            .expect("a new token is never cancelled")
    }

    /// As [`timed`](Self::timed), stopping with [`crate::Error::Cancelled`] once `cancel` is set.
    pub fn timed_cancellable(
        rays: &PrimaryRays,
        bvh: &impl ClosestHitQuery,
        triangles: &TriangleSet,
        cancel: &CancelToken,
    ) -> Result<Self> {
        let start = Instant::now();
        let surfaces: Vec<_> = pixels(rays)
            .map_init(
                || false,
                |stopped, (i, x, y)| {
                    if tile_stopped(i, stopped, cancel) {
                        return None;
                    }
                    trace_pixel(rays, bvh, triangles, x, y, &mut NoStats)
                },
            )
            .collect();
        cancel.check()?;
        Ok(PrimaryPass {
            width: rays.width,
            height: rays.height,
            surfaces,
            work: Vec::new(),
            totals: TraversalStats::default(),
            trace_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    pub fn ray_count(&self) -> u64 {
        self.surfaces.len() as u64
    }

    /// Heat maps of N_B, N_L and N_T per pixel (empty if the pass was not counted).
    pub fn heat_maps(&self, prefix: &str) -> [ImagePlane; 3] {
        heat_planes(prefix, self.width, self.height, &self.work)
    }
}

pub(crate) fn heat_planes(
    prefix: &str,
    width: u32,
    height: u32,
    work: &[TraversalStats],
) -> [ImagePlane; 3] {
    let plane = |name: &str, f: fn(&TraversalStats) -> u64| {
        let mut p = ImagePlane::new(format!("{prefix}.{name}"), width, height);
        if work.len() == p.data.len() {
            for (d, w) in p.data.iter_mut().zip(work) {
                *d = f(w) as f32;
            }
        }
        p
    };
    [
        plane("N_B", |w| w.inner),
        plane("N_L", |w| w.leaves),
        plane("N_T", |w| w.triangles),
    ]
}

/// Pixels a pass traces between two reads of its cancel flag (and the least a thread takes).
pub(crate) const TILE: usize = 64;

/// Whether the pass was cancelled, as seen at the first pixel of pixel `i`'s tile: one atomic
/// load per tile, so a cancelled pass skips its remaining pixels within a tile of work.
#[inline]
pub(crate) fn tile_stopped(i: usize, stopped: &mut bool, cancel: &CancelToken) -> bool {
    if i.is_multiple_of(TILE) && !*stopped {
        *stopped = cancel.is_cancelled();
    }
    *stopped
}

/// Each pixel as (index, x, y), row-major.
fn pixels(rays: &PrimaryRays) -> impl IndexedParallelIterator<Item = (usize, u32, u32)> {
    let w = rays.width;
    (0..rays.width * rays.height)
        .into_par_iter()
        .with_min_len(TILE)
        .map(move |i| (i as usize, i % w, i / w))
}

#[inline]
fn trace_pixel<C: Counters>(
    rays: &PrimaryRays,
    bvh: &impl ClosestHitQuery,
    triangles: &TriangleSet,
    x: u32,
    y: u32,
    stats: &mut C,
) -> Option<SurfacePoint> {
    let ray = rays.ray(x, y);
    let hit = bvh.closest_hit(&ray, stats)?;
    let v = &triangles.vertices[hit.triangle as usize];
    // The barycentric point is what Wächter & Binder's offset assumes: its error is bounded by
    // the vertices' magnitude, not by the ray's length.
    let position = v[0] * hit.b0 + v[1] * hit.b1 + v[2] * hit.b2;
    let mut normal = triangle_normal(v).normalize();
    if normal.dot(ray.direction) > 0.0 {
        normal = -normal;
    }
    Some(SurfacePoint {
        position,
        normal,
        facing: normal,
        triangle: hit.triangle,
    })
}
