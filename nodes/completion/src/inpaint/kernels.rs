//! Per-pixel weighted averages of the two methods, replayed in fill order over an
//! interleaved buffer of `C` channels.
//!
//! While the pixel at rank `r` is computed, a cell is "known" exactly when its rank
//! is below `r` (see [`FillOrder::rank`]); this reproduces OpenCV's INSIDE/KNOWN
//! flags at that moment without shared mutable state, so any subset of pixels that
//! does not interact (see `partition`) can be replayed on its own. Channels share
//! the geometry (flags, distance and Telea's direction weights) but keep their own
//! sums, accumulated in OpenCV's raster order.

use super::march::FillOrder;
use super::sample::Sample;
use super::window::{Disc, Offset, Tap};

/// Everything a kernel needs about the image geometry.
pub(crate) struct Geometry<'a> {
    pub width: usize,
    pub height: usize,
    pub order: &'a FillOrder,
    pub disc: &'a Disc,
    /// Indexed by padded row.
    pub row_taps: &'a [Tap],
    /// Indexed by padded column.
    pub col_taps: &'a [Tap],
}

/// Which neighbours of a sample were known when the current pixel was computed.
#[derive(Clone, Copy)]
struct KnownAround {
    up: bool,
    down: bool,
    left: bool,
    right: bool,
}

impl Geometry<'_> {
    /// Calls `visit(offset, padded row, padded column, flags)` for every known image
    /// cell of the disc around `cell` in raster order, as seen at rank `now`.
    #[inline(always)]
    fn for_each_known(
        &self,
        cell: usize,
        now: u32,
        mut visit: impl FnMut(&Offset, usize, usize, KnownAround),
    ) {
        let stride = self.order.stride;
        let rank = &self.order.rank[..];
        let (i, j) = (cell / stride, cell % stride);
        let range = self.disc.range;
        for (row, &hw) in self.disc.half_width.iter().enumerate() {
            // i + row − range is the padded row; image rows are padded 1..=height.
            let k = i + row;
            if k < range + 1 || k > range + self.height {
                continue;
            }
            let k = k - range;
            let l_lo = (j.saturating_sub(hw)).max(1);
            let l_hi = (j + hw).min(self.width);
            if l_lo > l_hi {
                continue;
            }
            let first = self.disc.row_start[row] + (l_lo + hw - j);
            let offsets = &self.disc.offsets[first..first + (l_hi - l_lo + 1)];
            let base = k * stride;
            let above = &rank[base - stride + l_lo..=base - stride + l_hi];
            let below = &rank[base + stride + l_lo..=base + stride + l_hi];
            let line = &rank[base + l_lo - 1..=base + l_hi + 1];
            for (n, off) in offsets.iter().enumerate() {
                if line[n + 1] >= now {
                    continue;
                }
                let known = KnownAround {
                    up: above[n] < now,
                    down: below[n] < now,
                    left: line[n] < now,
                    right: line[n + 2] < now,
                };
                visit(off, k, l_lo + n, known);
            }
        }
    }
}

/// Reads channel `ch` of unpadded pixel (row, col) from an interleaved buffer.
#[inline(always)]
fn at<T: Sample, const C: usize>(data: &[T], width: usize, row: usize, col: usize, ch: usize) -> T {
    data[(row * width + col) * C + ch]
}

/// OpenCV's `INPAINT_NS` for the hole pixels `pixels` (padded cells, in fill order).
pub(crate) fn fill_ns<T: Sample, const C: usize>(data: &mut [T], pixels: &[u32], geo: &Geometry) {
    let stride = geo.order.stride;
    let width = geo.width;
    for &cell in pixels {
        let cell = cell as usize;
        let now = geo.order.rank[cell];
        let mut weighted = [0.0f32; C];
        let mut total = [1.0e-20f32; C];
        geo.for_each_known(cell, now, |off, k, l, known| {
            let (rt, ct) = (geo.row_taps[k], geo.col_taps[l]);
            let (km, lm) = (rt.at_m, ct.at_m);
            for ch in 0..C {
                let o = |row: usize, col: usize| at::<T, C>(data, width, row, col, ch);
                let across_rows = match (known.down, known.up) {
                    (true, true) => T::abs_diff_sum(o(rt.next, lm), o(rt.at_p, lm), o(rt.prev, lm)),
                    (true, false) => T::abs_diff(o(rt.next, lm), o(rt.at_p, lm)) * 2.0,
                    (false, true) => T::abs_diff(o(rt.at_p, lm), o(rt.prev, lm)) * 2.0,
                    (false, false) => 0.0,
                };
                let across_cols = match (known.right, known.left) {
                    (true, true) => T::abs_diff_sum(o(km, ct.next), o(km, ct.at_m), o(km, ct.prev)),
                    (true, false) => T::abs_diff(o(km, ct.next), o(km, ct.at_m)) * 2.0,
                    (false, true) => T::abs_diff(o(km, ct.at_m), o(km, ct.prev)) * 2.0,
                    (false, false) => 0.0,
                };
                // The isophote direction (−g_row, g_col) in (column, row) order.
                let (gx, gy) = (-across_rows, across_cols);
                let dot = off.dx * gx + off.dy * gy;
                let dir = if (dot.abs() as f64) <= 0.01 {
                    1.0e-6
                } else {
                    (dot / (off.len2 * (gx * gx + gy * gy)).sqrt()).abs()
                };
                let w = off.ns_dst * dir;
                weighted[ch] += w * o(k - 1, l - 1).as_f32();
                total[ch] += w;
            }
        });
        let (i, j) = (cell / stride, cell % stride);
        for ch in 0..C {
            data[((i - 1) * width + (j - 1)) * C + ch] =
                T::from_f64_saturating(weighted[ch] as f64 / total[ch] as f64);
        }
    }
}

/// OpenCV's `INPAINT_TELEA`: distance-, level- and direction-weighted average plus a
/// normalised gradient correction. `wide_distance` selects the distance weight of
/// OpenCV's 3-channel 8-bit code (product in double) over its 1-channel code.
pub(crate) fn fill_telea<T: Sample, const C: usize>(
    data: &mut [T],
    pixels: &[u32],
    geo: &Geometry,
    wide_distance: bool,
) {
    let FillOrder {
        stride, rank, time, ..
    } = geo.order;
    let stride = *stride;
    let width = geo.width;
    for &cell in pixels {
        let cell = cell as usize;
        let now = rank[cell];
        let tp = time[cell];
        let grad_t = |prev: usize, next: usize| match (rank[next] < now, rank[prev] < now) {
            (true, true) => (time[next] - time[prev]) * 0.5,
            (true, false) => time[next] - tp,
            (false, true) => tp - time[prev],
            (false, false) => 0.0,
        };
        let (gtx, gty) = (
            grad_t(cell - 1, cell + 1),
            grad_t(cell - stride, cell + stride),
        );
        let mut weighted = [0.0f32; C];
        let mut jx = [0.0f32; C];
        let mut jy = [0.0f32; C];
        let mut total = [1.0e-20f32; C];
        geo.for_each_known(cell, now, |off, k, l, known| {
            let (rt, ct) = (geo.row_taps[k], geo.col_taps[l]);
            // Telea's code uses r = p − q.
            let (rx, ry) = (-off.dx, -off.dy);
            let dst = if wide_distance {
                off.telea_dst_f64
            } else {
                off.telea_dst_f32
            };
            let lev = (1.0 / (1.0 + (time[k * stride + l] - tp).abs() as f64)) as f32;
            let mut dir = rx * gtx + ry * gty;
            if (dir.abs() as f64) <= 0.01 {
                dir = 1.0e-6;
            }
            let w = (dst * lev * dir).abs();
            let (km, lm) = (rt.at_m, ct.at_m);
            for ch in 0..C {
                let o = |row: usize, col: usize| at::<T, C>(data, width, row, col, ch);
                let gix = match (known.right, known.left) {
                    (true, true) => T::diff(o(km, ct.next), o(km, ct.prev)) * 2.0,
                    (true, false) => T::diff(o(km, ct.next), o(km, ct.at_m)),
                    (false, true) => T::diff(o(km, ct.at_p), o(km, ct.prev)),
                    (false, false) => 0.0,
                };
                let giy = match (known.down, known.up) {
                    (true, true) => T::diff(o(rt.next, lm), o(rt.prev, lm)) * 2.0,
                    (true, false) => T::diff(o(rt.next, lm), o(km, lm)),
                    (false, true) => T::diff(o(rt.at_p, lm), o(rt.prev, lm)),
                    (false, false) => 0.0,
                };
                weighted[ch] += w * o(k - 1, l - 1).as_f32();
                jx[ch] -= w * (gix * rx);
                jy[ch] -= w * (giy * ry);
                total[ch] += w;
            }
        });
        let (i, j) = (cell / stride, cell % stride);
        for ch in 0..C {
            let (jx, jy) = (jx[ch], jy[ch]);
            let value =
                weighted[ch] / total[ch] + (jx + jy) / ((jx * jx + jy * jy).sqrt() + 1.0e-20);
            data[((i - 1) * width + (j - 1)) * C + ch] = T::from_telea(value);
        }
    }
}
