//! Primary rays: one closest-hit ray through each pixel centre.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use super::tiles::{band_pixels, band_tiles, Tile, TILE_SIDE};
use super::PrimaryRays;
use super::TwoLevelTrees;
use crate::cancel::CancelToken;
use crate::geometry::{triangle_normal, Ray};
use crate::image::ImagePlane;
use crate::scene::{Object, TriangleRef, TriangleSet};
#[cfg(doc)]
use crate::trace::NoStats;
use crate::trace::{Counters, Hit, RayQuery, TraversalStats};
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
    /// The hit's id in the tree traced: in the flat frame's `TriangleSet`, or in the hit
    /// object's mesh tree on two levels.
    pub triangle: u32,
    /// The hit's instance on two levels ([`Hit::instance`]): with `triangle`, what finds the
    /// triangle again ([`HitGeometry::triangle`]).
    pub instance: u32,
    /// The object and the triangle of its mesh that was hit: the same on every tree.
    pub reference: TriangleRef,
}

/// Where the passes find a hit's triangle: the flat frame's render-space set, or a two-level
/// frame's mesh trees placed by the hit object's transform.
#[derive(Clone, Copy)]
pub enum HitGeometry<'a> {
    Flat(&'a TriangleSet),
    TwoLevel {
        trees: &'a TwoLevelTrees,
        objects: &'a [Object],
    },
}

impl<'a> From<&'a TriangleSet> for HitGeometry<'a> {
    fn from(set: &'a TriangleSet) -> Self {
        HitGeometry::Flat(set)
    }
}

impl HitGeometry<'_> {
    /// The render-space vertices and the reference of triangle `triangle` of the traced tree
    /// (of object `instance`'s mesh tree on two levels; a flat tree's ids need no object).
    #[inline]
    pub fn triangle(&self, instance: u32, triangle: u32) -> ([Vec3; 3], TriangleRef) {
        match self {
            HitGeometry::Flat(set) => {
                (set.vertices[triangle as usize], set.refs[triangle as usize])
            }
            HitGeometry::TwoLevel { trees, objects } => {
                trees.hit_triangle(objects, instance, triangle)
            }
        }
    }
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
    /// Alpha evaluations of a pass counted in [`crate::trace::AlphaStats`] (else 0).
    pub alpha_lookups: u64,
}

impl PrimaryPass {
    /// Traces `tree` tile by tile, one batch of camera rays per tile, counting each pixel's work
    /// in `C` ([`TraversalStats`], or [`NoStats`] timed: `work` is then empty); stops with
    /// [`crate::Error::Cancelled`] once `cancel` is set (read once per tile: [`super::tiles`]).
    pub fn trace<'g, C: Counters>(
        rays: &PrimaryRays,
        tree: &impl RayQuery,
        geometry: impl Into<HitGeometry<'g>>,
        cancel: &CancelToken,
    ) -> Result<Self> {
        let triangles = geometry.into();
        let start = Instant::now();
        let pixels = (rays.width * rays.height) as usize;
        let mut surfaces = vec![None; pixels];
        let mut work = vec![C::default(); pixels];
        let band = band_pixels(rays.width).max(1);
        surfaces
            .par_chunks_mut(band)
            .zip(work.par_chunks_mut(band))
            .enumerate()
            .for_each_init(TileHits::default, |buffers, (b, (surfaces, work))| {
                let y0 = b as u32 * TILE_SIDE;
                for tile in band_tiles(rays.width, rays.height, y0) {
                    if cancel.is_cancelled() {
                        return;
                    }
                    buffers.trace(rays, tile, tree, &triangles, surfaces, work);
                }
            });
        cancel.check()?;
        let trace_ms = start.elapsed().as_secs_f64() * 1e3;
        // Read only where counting: an uncounted pass keeps no loop over its pixels for it.
        let alpha_lookups = if C::COUNTING {
            work.iter().map(Counters::lookups).sum()
        } else {
            0
        };
        let work: Vec<TraversalStats> = if C::COUNTING {
            work.into_iter().map(Into::into).collect()
        } else {
            Vec::new()
        };
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
            alpha_lookups,
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

/// Heat maps of N_B, N_L and N_T per pixel from each pixel's work `W` (empty planes unless
/// `work` has one element per pixel).
pub(crate) fn heat_planes<W: Copy>(
    prefix: &str,
    width: u32,
    height: u32,
    work: &[W],
) -> [ImagePlane; 3]
where
    HeatWork: From<W>,
{
    let plane = |name: &str, f: fn(&HeatWork) -> u64| {
        let mut p = ImagePlane::new(format!("{prefix}.{name}"), width, height);
        if work.len() == p.data.len() {
            for (d, w) in p.data.iter_mut().zip(work) {
                *d = f(&HeatWork::from(*w)) as f32;
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

/// What a pixel's heat maps read of its rays' work: N_B, N_L and N_T ([`TraversalStats`]'s
/// `inner`, `leaves` and `triangles`), 24 bytes where the pixel's [`TraversalStats`] take 56.
/// A frame's shadow passes sum their lights' work per pixel in these.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct HeatWork {
    pub inner: u64,
    pub leaves: u64,
    pub triangles: u64,
}

impl From<TraversalStats> for HeatWork {
    #[inline]
    fn from(w: TraversalStats) -> Self {
        HeatWork {
            inner: w.inner,
            leaves: w.leaves,
            triangles: w.triangles,
        }
    }
}

impl std::ops::AddAssign<&TraversalStats> for HeatWork {
    #[inline]
    fn add_assign(&mut self, w: &TraversalStats) {
        self.inner += w.inner;
        self.leaves += w.leaves;
        self.triangles += w.triangles;
    }
}

/// One thread's buffers for a tile's camera rays, reused from tile to tile.
#[derive(Default)]
struct TileHits<C> {
    rays: Vec<Ray>,
    hits: Vec<Option<Hit>>,
    counters: Vec<C>,
}

impl<C: Counters> TileHits<C> {
    /// The camera rays of the tile's pixels in one batch, in the tile's order; their surface
    /// points and work written into the tile's band of rows.
    #[inline]
    fn trace(
        &mut self,
        rays: &PrimaryRays,
        tile: Tile,
        tree: &impl RayQuery,
        triangles: &HitGeometry,
        surfaces: &mut [Option<SurfacePoint>],
        work: &mut [C],
    ) {
        self.rays.clear();
        self.rays.extend(rays.tile_rays(tile));
        let n = self.rays.len();
        self.hits.resize(n, None);
        self.counters.clear();
        self.counters.resize(n, C::default());
        tree.closest_hit_batch(&self.rays, &mut self.hits, &mut self.counters);
        let answers = self.rays.iter().zip(&self.hits).zip(&self.counters);
        for (i, ((ray, hit), counter)) in tile.band_indices(rays.width).zip(answers) {
            surfaces[i] = hit.map(|h| surface_point(ray, &h, triangles));
            work[i] = *counter;
        }
    }
}

/// The surface point of a camera ray's hit.
#[inline]
fn surface_point(ray: &Ray, hit: &Hit, triangles: &HitGeometry) -> SurfacePoint {
    let (v, reference) = triangles.triangle(hit.instance, hit.triangle);
    // The barycentric point is what Wächter & Binder's offset assumes: its error is bounded by
    // the vertices' magnitude, not by the ray's length.
    let position = v[0] * hit.b0 + v[1] * hit.b1 + v[2] * hit.b2;
    let mut normal = triangle_normal(&v).normalize();
    if normal.dot(ray.direction) > 0.0 {
        normal = -normal;
    }
    SurfacePoint {
        position,
        normal,
        facing: normal,
        triangle: hit.triangle,
        instance: hit.instance,
        reference,
    }
}
