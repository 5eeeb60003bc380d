//! Assigns faces to 16×16 tiles and sorts each tile's list front to back by
//! face centroid depth (ties by face slot, so the order is total).
//!
//! Tiles are aligned to the image: a grid may cover only a tile-aligned
//! rectangle of it (a rendered region), and then every tile, every face's
//! tile range and every per-pixel fragment order is the same as in the
//! full image's grid.

use super::preprocess::ScreenFace;
use crate::backend::PixelRect;
use crate::parallel::{chunk_size, run_iter};
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
    /// One per run of faces binned by one job, kept to reuse their allocations.
    runs: Vec<RunBins>,
}

/// A run of consecutive faces' sort keys grouped by tile: tile `t`'s are
/// `keys[starts[t]..starts[t + 1]]`, in face order.
#[derive(Debug, Clone, Default)]
struct RunBins {
    starts: Vec<usize>,
    cursor: Vec<usize>,
    keys: Vec<u64>,
}

impl RunBins {
    /// A counting sort of `faces` (slots from `first_slot`) by tile.
    fn fill<R: Real>(&mut self, faces: &[ScreenFace<R>], first_slot: usize, grid: &TileGrid) {
        let tiles = grid.tile_count();
        let starts = &mut self.starts;
        starts.clear();
        starts.resize(tiles + 1, 0);
        for f in faces {
            if let Some((tx0, ty0, tx1, ty1)) = grid.tile_range(f.pixels) {
                for ty in ty0..=ty1 {
                    for tx in tx0..=tx1 {
                        starts[(ty * grid.tiles_x + tx) as usize + 1] += 1;
                    }
                }
            }
        }
        for t in 0..tiles {
            starts[t + 1] += starts[t];
        }
        self.cursor.clear();
        self.cursor.extend_from_slice(starts);
        // Every key below `starts[tiles]` is written once by the loop.
        self.keys.resize(starts[tiles], 0);
        for (i, f) in faces.iter().enumerate() {
            let Some((tx0, ty0, tx1, ty1)) = grid.tile_range(f.pixels) else {
                continue;
            };
            // Depth bits (positive floats order like their bit patterns) above the face slot.
            let key = (((f.depth.f64() as f32).to_bits() as u64) << 32) | (first_slot + i) as u64;
            for ty in ty0..=ty1 {
                for tx in tx0..=tx1 {
                    let t = (ty * grid.tiles_x + tx) as usize;
                    self.keys[self.cursor[t]] = key;
                    self.cursor[t] += 1;
                }
            }
        }
    }

    fn tile(&self, t: usize) -> &[u64] {
        &self.keys[self.starts[t]..self.starts[t + 1]]
    }
}

impl TileLists {
    /// Fills the lists for `faces` on `grid`, reusing the buffers, on up to
    /// `threads` threads: runs of faces are binned apart, then each row of
    /// tiles gathers its tiles' keys from every run and sorts them. A key
    /// (depth, slot) is unique, so the lists do not depend on the runs.
    pub fn bin<R: Real>(&mut self, faces: &[ScreenFace<R>], grid: &TileGrid, threads: usize) {
        let tiles = grid.tile_count();
        let run_len = chunk_size(faces.len(), threads, 4096);
        let run_count = faces.len().div_ceil(run_len).max(1);
        self.runs.resize_with(run_count, RunBins::default);
        let runs = &mut self.runs[..run_count];
        // No faces: one empty run, so that every tile's list is empty.
        let parts = faces.chunks(run_len).chain(std::iter::once(&faces[..0]));
        let jobs = runs.iter_mut().zip(parts);
        run_iter(
            threads,
            jobs.enumerate(),
            || (),
            |_, (r, (run, part))| run.fill(part, r * run_len, grid),
        );
        let runs = &self.runs[..run_count];
        self.offsets.clear();
        self.offsets.push(0);
        for t in 0..tiles {
            let listed: usize = runs.iter().map(|run| run.tile(t).len()).sum();
            self.offsets.push(self.offsets[t] + listed);
        }
        let total = self.offsets[tiles];
        // Every entry below `total` is written by its row's job.
        self.entries.resize(total, 0);
        let tiles_x = (grid.tiles_x as usize).max(1);
        let mut row_starts = Vec::new();
        self.row_offsets(grid, &mut row_starts);
        let offsets = &self.offsets;
        let rows = SplitBy::new(&mut self.entries[..], &row_starts).enumerate();
        run_iter(
            threads,
            rows,
            Vec::new,
            |keys: &mut Vec<u64>, (row, mut entries)| {
                for t in row * tiles_x..((row + 1) * tiles_x).min(tiles) {
                    keys.clear();
                    for run in runs {
                        keys.extend_from_slice(run.tile(t));
                    }
                    keys.sort_unstable();
                    let (these, rest) = entries.split_at_mut(offsets[t + 1] - offsets[t]);
                    for (e, &k) in these.iter_mut().zip(keys.iter()) {
                        *e = k as u32;
                    }
                    entries = rest;
                }
            },
        );
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

#[cfg(test)]
mod tests {
    use super::*;

    fn face(slot: u32, depth: f32, pixels: [u32; 4]) -> ScreenFace<f32> {
        ScreenFace {
            face: slot,
            origin: [0.0; 2],
            q: [[0.0; 2]; 3],
            lam: [[0.0; 3]; 3],
            scale: [0.0; 3],
            area2: 0.0,
            inv_area2: 0.0,
            len: [0.0; 3],
            perimeter: 0.0,
            sigma: 0.0,
            opacity: 0.0,
            argmin_corner: 0,
            color: [[0.0; 3]; 3],
            z: [0.0; 3],
            depth,
            pixels,
        }
    }

    #[test]
    fn lists_are_every_covering_face_front_to_back_on_any_thread_count() {
        // More faces than one job bins, boxes partly or wholly off the grid,
        // and depths that tie (then the slot orders them).
        let mut state = 12345u64;
        let mut next = |below: u32| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 33) % below as u64) as u32
        };
        let faces: Vec<_> = (0..10_000)
            .map(|slot| {
                let (x, y) = (next(260), next(200));
                let pixels = [x, y, x + next(40), y + next(30)];
                face(slot, 0.5 + next(50) as f32 * 0.25, pixels)
            })
            .collect();
        let grid = TileGrid::new(
            240,
            176,
            PixelRect {
                x0: 16,
                y0: 32,
                x1: 240,
                y1: 170,
            },
        );
        let mut expected = vec![Vec::new(); grid.tile_count()];
        for (slot, f) in faces.iter().enumerate() {
            if let Some((tx0, ty0, tx1, ty1)) = grid.tile_range(f.pixels) {
                for ty in ty0..=ty1 {
                    for tx in tx0..=tx1 {
                        expected[(ty * grid.tiles_x + tx) as usize].push((f.depth, slot as u32));
                    }
                }
            }
        }
        for list in &mut expected {
            list.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        }
        let mut lists = TileLists::default();
        for threads in [1, 2, 3, 1] {
            lists.bin(&faces, &grid, threads);
            for (t, want) in expected.iter().enumerate() {
                let got = &lists.entries[lists.offsets[t]..lists.offsets[t + 1]];
                let want: Vec<u32> = want.iter().map(|e| e.1).collect();
                assert_eq!(got, &want[..], "tile {t}, {threads} threads");
            }
            assert_eq!(lists.entries.len(), lists.offsets[grid.tile_count()]);
        }
        lists.bin::<f32>(&[], &grid, 2);
        assert!(lists.entries.is_empty() && lists.offsets.iter().all(|&o| o == 0));
    }
}
