//! Assigns faces to 16×16 tiles and sorts each tile's list front to back by
//! face centroid depth (ties by face index, so the order is total).

use super::preprocess::ScreenFace;
use crate::parallel::run_jobs;
use crate::real::Real;

pub const TILE: u32 = 16;
pub const TILE_PIXELS: usize = (TILE * TILE) as usize;

#[derive(Debug, Clone)]
pub struct TileGrid {
    pub width: u32,
    pub height: u32,
    pub tiles_x: u32,
    pub tiles_y: u32,
}

impl TileGrid {
    pub fn new(width: u32, height: u32) -> Self {
        TileGrid {
            width,
            height,
            tiles_x: width.div_ceil(TILE),
            tiles_y: height.div_ceil(TILE),
        }
    }

    pub fn tile_count(&self) -> usize {
        (self.tiles_x * self.tiles_y) as usize
    }

    /// Pixel rectangle `[x0, x1) × [y0, y1)` of tile `t`.
    pub fn tile_rect(&self, t: usize) -> [u32; 4] {
        let tx = t as u32 % self.tiles_x;
        let ty = t as u32 / self.tiles_x;
        [
            tx * TILE,
            ty * TILE,
            ((tx + 1) * TILE).min(self.width),
            ((ty + 1) * TILE).min(self.height),
        ]
    }
}

/// Per-tile lists of visible-face indices: tile `t` holds
/// `entries[offsets[t]..offsets[t + 1]]`, front to back.
#[derive(Debug, Clone, Default)]
pub struct TileLists {
    pub offsets: Vec<usize>,
    pub entries: Vec<u32>,
}

pub fn bin_faces<R: Real>(faces: &[ScreenFace<R>], grid: &TileGrid, threads: usize) -> TileLists {
    let tiles = grid.tile_count();
    let tile_range = |f: &ScreenFace<R>| {
        let [x0, y0, x1, y1] = f.pixels;
        (x0 / TILE, y0 / TILE, x1 / TILE, y1 / TILE)
    };
    let mut counts = vec![0usize; tiles + 1];
    for f in faces {
        let (tx0, ty0, tx1, ty1) = tile_range(f);
        for ty in ty0..=ty1 {
            for tx in tx0..=tx1 {
                counts[(ty * grid.tiles_x + tx) as usize + 1] += 1;
            }
        }
    }
    for t in 0..tiles {
        counts[t + 1] += counts[t];
    }
    let offsets = counts;
    let mut cursor = offsets.clone();
    // Sort keys: depth bits (positive floats order like their bit patterns) above the face slot.
    let mut keys = vec![0u64; offsets[tiles]];
    for (slot, f) in faces.iter().enumerate() {
        let depth_bits = (f.depth.f64() as f32).to_bits() as u64;
        let (tx0, ty0, tx1, ty1) = tile_range(f);
        for ty in ty0..=ty1 {
            for tx in tx0..=tx1 {
                let t = (ty * grid.tiles_x + tx) as usize;
                keys[cursor[t]] = (depth_bits << 32) | slot as u64;
                cursor[t] += 1;
            }
        }
    }
    let mut jobs = Vec::with_capacity(tiles);
    let mut rest: &mut [u64] = &mut keys;
    for t in 0..tiles {
        let (head, tail) = rest.split_at_mut(offsets[t + 1] - offsets[t]);
        jobs.push(head);
        rest = tail;
    }
    run_jobs(threads, jobs, || (), |_, segment| segment.sort_unstable());
    TileLists {
        offsets,
        entries: keys.into_iter().map(|k| k as u32).collect(),
    }
}
