//! The passes' batches: square tiles of pixels, and the order of the pixels inside a tile, so
//! that a packet of 8 or 16 consecutive rays of a batch is a compact block of neighbours.
//!
//! Images stay row-major; only the order in which a pass hands pixels to the tree's batch query
//! follows the tiles. Tiles run row by row over the image (a band of [`TILE_SIDE`] rows is the
//! unit of parallel work); inside an 8x8 tile the pixels run as four 4x4 quadrants, each row by
//! row, so rays 0-15, 16-31, ... are 4x4 blocks and rays 0-7, 8-15, ... are 4x2 blocks. Tiles
//! on the right and bottom edges are cut to the image and keep the same order, less the pixels
//! outside it.

/// Side of the square tiles the passes trace, one batch of rays per tile (Embree's and
/// Cycles' 8x8).
pub const TILE_SIDE: u32 = 8;

/// Pixels of a whole tile: the most camera rays of one batch.
pub const TILE_PIXELS: usize = (TILE_SIDE * TILE_SIDE) as usize;

/// Side of the quadrants inside a tile: a 4x4 block is a 16-ray packet.
const QUADRANT: u32 = 4;

/// Offsets (x, y) of a whole tile's pixels in batch order: quadrants row by row, row-major
/// inside each.
const ORDER: [(u8, u8); TILE_PIXELS] = {
    let mut order = [(0u8, 0u8); TILE_PIXELS];
    let per_side = TILE_SIDE / QUADRANT;
    let mut i = 0;
    while i < TILE_PIXELS {
        let (q, k) = (
            i as u32 / (QUADRANT * QUADRANT),
            i as u32 % (QUADRANT * QUADRANT),
        );
        let x = (q % per_side) * QUADRANT + k % QUADRANT;
        let y = (q / per_side) * QUADRANT + k / QUADRANT;
        order[i] = (x as u8, y as u8);
        i += 1;
    }
    order
};

/// One tile of an image: the rectangle `x0..x0 + width`, `y0..y0 + height` (cut at the edges).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
}

impl Tile {
    /// The tile's pixels in batch order, as (x, y) in the image.
    pub fn pixels(self) -> impl Iterator<Item = (u32, u32)> {
        ORDER
            .iter()
            .filter(move |&&(dx, dy)| (dx as u32) < self.width && (dy as u32) < self.height)
            .map(move |&(dx, dy)| (self.x0 + dx as u32, self.y0 + dy as u32))
    }

    /// The tile's pixels in batch order, as row-major indices into its band of rows (the rows
    /// from `y0`, `image_width` pixels each): where a pass writes each pixel's answer.
    pub fn band_indices(self, image_width: u32) -> impl Iterator<Item = usize> {
        let y0 = self.y0;
        self.pixels()
            .map(move |(x, y)| ((y - y0) * image_width + x) as usize)
    }
}

/// The tiles of one band of rows (`y0` to at most `y0 + TILE_SIDE`), left to right.
pub fn band_tiles(width: u32, height: u32, y0: u32) -> impl Iterator<Item = Tile> {
    let rows = height.saturating_sub(y0).min(TILE_SIDE);
    (0..width.div_ceil(TILE_SIDE)).map(move |t| {
        let x0 = t * TILE_SIDE;
        Tile {
            x0,
            y0,
            width: (width - x0).min(TILE_SIDE),
            height: rows,
        }
    })
}

/// Every tile of a `width` x `height` image in the order the passes trace them: band by band,
/// left to right.
pub fn tiles(width: u32, height: u32) -> impl Iterator<Item = Tile> {
    (0..height.div_ceil(TILE_SIDE)).flat_map(move |b| band_tiles(width, height, b * TILE_SIDE))
}

/// Pixels of one band of rows: the slice of a row-major image a band's tiles write.
pub fn band_pixels(width: u32) -> usize {
    (width * TILE_SIDE) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_pixel_once_for_any_size() {
        for (w, h) in [
            (1, 1),
            (7, 3),
            (8, 8),
            (9, 17),
            (13, 8),
            (64, 1),
            (1, 33),
            (23, 29),
        ] {
            let mut seen = vec![0u32; (w * h) as usize];
            for tile in tiles(w, h) {
                assert!(tile.width >= 1 && tile.height >= 1);
                for (x, y) in tile.pixels() {
                    assert!(x < w && y < h, "{w}x{h}: ({x}, {y})");
                    seen[(y * w + x) as usize] += 1;
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "{w}x{h}: {seen:?}");
        }
    }

    #[test]
    fn band_indices_are_the_pixels_in_their_band() {
        let (w, h) = (21u32, 19u32);
        for b in 0..h.div_ceil(TILE_SIDE) {
            let y0 = b * TILE_SIDE;
            let mut seen = vec![false; band_pixels(w).min(((h - y0) * w) as usize)];
            for tile in band_tiles(w, h, y0) {
                for (i, (x, y)) in tile.band_indices(w).zip(tile.pixels()) {
                    assert_eq!(i, ((y - y0) * w + x) as usize);
                    assert!(!std::mem::replace(&mut seen[i], true));
                }
            }
            assert!(seen.iter().all(|&s| s));
        }
    }

    #[test]
    fn packets_of_a_whole_tile_are_compact_blocks() {
        let tile = tiles(16, 16).next().unwrap();
        let pixels: Vec<(u32, u32)> = tile.pixels().collect();
        assert_eq!(pixels.len(), TILE_PIXELS);
        for (size, (bw, bh)) in [(16, (4, 4)), (8, (4, 2))] {
            for packet in pixels.chunks(size) {
                let (x0, y0) = packet[0];
                assert_eq!((x0 % bw, y0 % bh), (0, 0), "a packet starts on its block");
                for (k, &(x, y)) in packet.iter().enumerate() {
                    assert_eq!((x, y), (x0 + k as u32 % bw, y0 + k as u32 / bw));
                }
            }
        }
    }
}
