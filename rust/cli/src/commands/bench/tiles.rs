//! A frame's rays grouped as the render passes group them, tile by tile: the batches both
//! antumbra and Embree's packet and stream calls are handed, so both trace the same groups.
//!
//! The core exposes no tile iterator, so the shape is chosen here in one place ([`TILE_SIDE`],
//! [`tile_pixels`]): square blocks of 8x8 pixels, row-major inside a block, blocks row-major.

use std::ops::Range;

use antumbra_core::geometry::Ray;
use antumbra_core::render::{PrimaryPass, PrimaryRays};
use rayon::prelude::*;

use crate::shadow_lights::ShadowLight;

/// The side of a tile in pixels (a tile of the render passes holds up to 8x8 pixels).
pub(super) const TILE_SIDE: u32 = 8;

/// Rays per group of a ray file, which has no pixels: a full tile's worth of camera rays.
pub(super) const FILE_TILE: usize = (TILE_SIDE * TILE_SIDE) as usize;

/// Each tile's pixel indices (row-major in the image), tile after tile; edge tiles are cut.
pub(super) fn tile_pixels(width: u32, height: u32) -> impl Iterator<Item = Vec<usize>> {
    let side = TILE_SIDE;
    (0..height.div_ceil(side)).flat_map(move |ty| {
        (0..width.div_ceil(side)).map(move |tx| {
            let rows = ty * side..((ty + 1) * side).min(height);
            rows.flat_map(|y| {
                (tx * side..((tx + 1) * side).min(width)).map(move |x| (y * width + x) as usize)
            })
            .collect()
        })
    })
}

/// Rays stored tile after tile, and each tile's range in `rays`.
#[derive(Default)]
pub(super) struct TiledRays {
    pub rays: Vec<Ray>,
    pub tiles: Vec<Range<usize>>,
}

impl TiledRays {
    /// Every pixel's camera ray, tile by tile.
    pub fn camera(camera: &PrimaryRays) -> TiledRays {
        let mut tiled = TiledRays::default();
        for tile in tile_pixels(camera.width, camera.height) {
            let start = tiled.rays.len();
            tiled.rays.extend(tile.iter().map(|&p| {
                let (x, y) = (p as u32 % camera.width, p as u32 / camera.width);
                camera.ray(x, y)
            }));
            tiled.tiles.push(start..tiled.rays.len());
        }
        tiled
    }

    /// One light's shadow rays from the pixels the camera rays hit, tile by tile (the rays of
    /// `antumbra_core::render::shadow_rays`, regrouped).
    pub fn shadow(pass: &PrimaryPass, light: &ShadowLight) -> TiledRays {
        let mut tiled = TiledRays::default();
        let mut scratch = Vec::new();
        for tile in tile_pixels(pass.width, pass.height) {
            let start = tiled.rays.len();
            for p in tile {
                if let Some(s) = &pass.surfaces[p] {
                    light
                        .plan
                        .for_each_ray(s, p, &light.sampler, &mut scratch, |r| tiled.rays.extend(r));
                }
            }
            if tiled.rays.len() > start {
                tiled.tiles.push(start..tiled.rays.len());
            }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_every_pixel_once_in_8x8_blocks() {
        let (w, h) = (19, 10);
        let tiles: Vec<Vec<usize>> = tile_pixels(w, h).collect();
        assert_eq!(tiles.len(), 3 * 2);
        assert_eq!(tiles[0][..9], [0, 1, 2, 3, 4, 5, 6, 7, 19]);
        assert_eq!(tiles[2].len(), 3 * 8, "the right edge tile is 3 wide");
        assert_eq!(tiles[5].len(), 3 * 2, "the corner tile is 3x2");
        let mut all: Vec<usize> = tiles.concat();
        all.sort();
        assert_eq!(all, (0..(w * h) as usize).collect::<Vec<_>>());
    }
}
