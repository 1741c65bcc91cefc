//! A frame's rays grouped as the render passes group them, tile by tile (the core's
//! `render::tiles`: 8x8 pixels, 16 consecutive rays a 4x4 block): the batches both antumbra
//! and Embree's packet and stream calls are handed, so both trace the same groups.

use std::ops::Range;

use antumbra_core::geometry::Ray;
use antumbra_core::render::tiles::TILE_SIDE;
use antumbra_core::render::{shadow_ray_batches, PrimaryPass, PrimaryRays};
use rayon::prelude::*;

use crate::shadow_lights::ShadowLight;

/// Rays per group of a ray file, which has no pixels: a full tile's worth of camera rays.
pub(super) const FILE_TILE: usize = (TILE_SIDE * TILE_SIDE) as usize;

/// Rays stored tile after tile, and each tile's range in `rays`.
#[derive(Default)]
pub(super) struct TiledRays {
    pub rays: Vec<Ray>,
    pub tiles: Vec<Range<usize>>,
}

impl TiledRays {
    /// Every pixel's camera ray, tile by tile, as the primary pass batches them.
    pub fn camera(camera: &PrimaryRays) -> TiledRays {
        TiledRays::from_batches(camera.batches())
    }

    /// One light's shadow rays from the pixels the camera rays hit, tile by tile, as the shadow
    /// pass batches them (tiles with no ray left out).
    pub fn shadow(pass: &PrimaryPass, light: &ShadowLight) -> TiledRays {
        TiledRays::from_batches(shadow_ray_batches(pass, &light.sampler, light.plan))
    }

    fn from_batches(batches: Vec<Vec<Ray>>) -> TiledRays {
        let mut tiled = TiledRays::default();
        for batch in batches.into_iter().filter(|b| !b.is_empty()) {
            let start = tiled.rays.len();
            tiled.rays.extend(batch);
            tiled.tiles.push(start..tiled.rays.len());
        }
        tiled
    }

    /// Rays with no pixels, in consecutive groups of [`FILE_TILE`].
    pub fn in_groups(rays: Vec<Ray>) -> TiledRays {
        let tiles = (0..rays.len())
            .step_by(FILE_TILE)
            .map(|s| s..(s + FILE_TILE).min(rays.len()))
            .collect();
        TiledRays { rays, tiles }
    }

    /// `others` after these, their tiles after these tiles.
    pub fn append(&mut self, others: &TiledRays) {
        let offset = self.rays.len();
        self.rays.extend_from_slice(&others.rays);
        self.tiles.extend(
            others
                .tiles
                .iter()
                .map(|t| t.start + offset..t.end + offset),
        );
    }

    pub fn len(&self) -> usize {
        self.rays.len()
    }

    /// Each tile's rays.
    pub fn tile_rays(&self) -> impl IndexedParallelIterator<Item = &[Ray]> {
        self.tiles.par_iter().map(|t| &self.rays[t.clone()])
    }
}
