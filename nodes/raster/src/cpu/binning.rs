//! Assigns faces to 16×16 tiles and sorts each tile's list front to back by
//! face centroid depth (ties by face slot, so the order is total).
//!
//! Tiles are aligned to the image: a grid may cover only a tile-aligned
//! rectangle of it (a rendered region), and then every tile, every face's
//! tile range and every per-pixel fragment order is the same as in the
//! full image's grid.

use super::preprocess::ScreenFace;
use crate::backend::PixelRect;
use crate::parallel::run_iter;
use crate::real::Real;

pub const TILE: u32 = 16;
pub const TILE_PIXELS: usize = (TILE * TILE) as usize;

#[derive(Debug, Clone, Default)]
pub struct TileGrid {
    /// The camera's image size (pixel boxes and backgrounds are in its coordinates).
    pub image_width: u32,
    pub image_height: u32,
    /// The tile-aligned part of the image the grid covers (clipped to the image).
    pub rect: PixelRect,
    pub tiles_x: u32,
    pub tiles_y: u32,
}

impl TileGrid {
    /// The grid over `rect` of a `width`×`height` image; `rect.x0`/`y0` must be tile multiples.
    pub fn new(width: u32, height: u32, rect: PixelRect) -> Self {
        debug_assert!(rect.x0.is_multiple_of(TILE) && rect.y0.is_multiple_of(TILE));
        TileGrid {
            image_width: width,
            image_height: height,
            rect,
            tiles_x: rect.width().div_ceil(TILE),
            tiles_y: rect.height().div_ceil(TILE),
        }
    }

    pub fn tile_count(&self) -> usize {
        (self.tiles_x * self.tiles_y) as usize
    }

    /// Pixel rectangle `[x0, x1) × [y0, y1)` of tile `t`, in image coordinates.
    pub fn tile_rect(&self, t: usize) -> [u32; 4] {
        let tx = t as u32 % self.tiles_x;
        let ty = t as u32 / self.tiles_x;
        let (x0, y0) = (self.rect.x0 + tx * TILE, self.rect.y0 + ty * TILE);
        [
            x0,
            y0,
            (x0 + TILE).min(self.rect.x1),
            (y0 + TILE).min(self.rect.y1),
        ]
    }

    /// Tiles touched by a face's inclusive pixel box, clipped to the grid:
    /// `(tx0, ty0, tx1, ty1)` inclusive, or `None` when it lies outside.
    #[inline]
    pub fn tile_range(&self, pixels: [u32; 4]) -> Option<(u32, u32, u32, u32)> {
        let r = &self.rect;
        if r.is_empty()
            || pixels[2] < r.x0
            || pixels[3] < r.y0
            || pixels[0] >= r.x1
            || pixels[1] >= r.y1
        {
            return None;
        }
        let tx0 = (pixels[0].max(r.x0) - r.x0) / TILE;
        let ty0 = (pixels[1].max(r.y0) - r.y0) / TILE;
        let tx1 = (pixels[2].min(r.x1 - 1) - r.x0) / TILE;
        let ty1 = (pixels[3].min(r.y1 - 1) - r.y0) / TILE;
        Some((tx0, ty0, tx1, ty1))
    }
}

/// Per-tile lists of visible-face slots: tile `t` holds
/// `entries[offsets[t]..offsets[t + 1]]`, front to back.
#[derive(Debug, Clone, Default)]
pub struct TileLists {
    pub offsets: Vec<usize>,
    pub entries: Vec<u32>,
    /// Sort keys, kept to reuse their allocation.
    keys: Vec<u64>,
    cursor: Vec<usize>,
}

impl TileLists {
    /// Fills the lists for `faces` on `grid`, reusing the buffers.
    pub fn bin<R: Real>(&mut self, faces: &[ScreenFace<R>], grid: &TileGrid, threads: usize) {
        let tiles = grid.tile_count();
        self.offsets.clear();
        self.offsets.resize(tiles + 1, 0);
        for f in faces {
            if let Some((tx0, ty0, tx1, ty1)) = grid.tile_range(f.pixels) {
                for ty in ty0..=ty1 {
                    for tx in tx0..=tx1 {
                        self.offsets[(ty * grid.tiles_x + tx) as usize + 1] += 1;
                    }
                }
            }
        }
        for t in 0..tiles {
            self.offsets[t + 1] += self.offsets[t];
        }
        self.cursor.clear();
        self.cursor.extend_from_slice(&self.offsets);
        // Sort keys: depth bits (positive floats order like their bit patterns) above the face slot.
        self.keys.clear();
        self.keys.resize(self.offsets[tiles], 0);
        for (slot, f) in faces.iter().enumerate() {
            let Some((tx0, ty0, tx1, ty1)) = grid.tile_range(f.pixels) else {
                continue;
            };
            let depth_bits = (f.depth.f64() as f32).to_bits() as u64;
            for ty in ty0..=ty1 {
                for tx in tx0..=tx1 {
                    let t = (ty * grid.tiles_x + tx) as usize;
                    self.keys[self.cursor[t]] = (depth_bits << 32) | slot as u64;
                    self.cursor[t] += 1;
                }
            }
        }
        let offsets = &self.offsets;
        let segments = SplitBy::new(&mut self.keys[..], offsets);
        run_iter(
            threads,
            segments,
            || (),
            |_, segment| segment.sort_unstable(),
        );
        self.entries.clear();
        self.entries.extend(self.keys.iter().map(|&k| k as u32));
    }

    /// Into `out`: where each row of `grid`'s tiles starts in the lists, and their end.
    pub fn row_offsets(&self, grid: &TileGrid, out: &mut Vec<usize>) {
        out.clear();
        let tiles_x = grid.tiles_x as usize;
        out.extend((0..=grid.tiles_y as usize).map(|row| self.offsets[row * tiles_x]));
    }
}

/// Splits a slice into consecutive pieces of the lengths `offsets` gives
/// (piece `t` = `offsets[t]..offsets[t + 1]`), lazily, so no list of pieces is built.
pub struct SplitBy<'a, T> {
    rest: &'a mut [T],
    offsets: &'a [usize],
    next: usize,
}

impl<'a, T> SplitBy<'a, T> {
    pub fn new(data: &'a mut [T], offsets: &'a [usize]) -> Self {
        SplitBy {
            rest: data,
            offsets,
            next: 0,
        }
    }
}

impl<'a, T> Iterator for SplitBy<'a, T> {
    type Item = &'a mut [T];

    fn next(&mut self) -> Option<&'a mut [T]> {
        if self.next + 1 >= self.offsets.len() {
            return None;
        }
        let len = self.offsets[self.next + 1] - self.offsets[self.next];
        self.next += 1;
        let rest = std::mem::take(&mut self.rest);
        let (head, tail) = rest.split_at_mut(len);
        self.rest = tail;
        Some(head)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.offsets.len().saturating_sub(self.next + 1);
        (left, Some(left))
    }
}
