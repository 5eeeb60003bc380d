//! Front-to-back compositing of one tile, eight pixels at a time: the
//! lane-group counterpart of [`crate::cpu::forward::render_tile`], with the
//! same per-pixel rules (the same fragments blend, in the same order).

use super::math::pow;
use super::{Avx2, F32x8, I32x8, LANES, Mask8, each3};
use crate::cpu::binning::{TILE, TILE_PIXELS, TileGrid};
use crate::cpu::forward::{Background, Band, EntryStats, PixelRules, RowSpans, clip_to_tile};
use crate::cpu::preprocess::ScreenFace;

/// Per-pixel tile arrays are this long: a lane group starts at any pixel of a
/// row, so the last one may reach 7 slots past the tile (never blending there).
pub const PADDED_PIXELS: usize = TILE_PIXELS + LANES;

/// One lane group a face blended into (eight consecutive pixels of a tile
/// row from `first`): which lanes blended and, per lane, what the backward
/// pass cannot cheaply recompute.
#[derive(Debug, Clone, Copy)]
pub struct LaneChunk {
    /// The window value `G^σ`.
    pub intensity: [f32; LANES],
    /// The pixel's transmittance before this fragment.
    pub t_before: [f32; LANES],
    /// Tile pixel index of lane 0.
    pub first: u8,
    /// Bit `l` set: lane `l` blended a fragment.
    pub mask: u8,
}

/// What the eight-lane forward pass of one tile leaves for its backward pass.
#[derive(Default)]
pub struct TileChunks {
    /// Entry by entry, in blending order.
    pub chunks: Vec<LaneChunk>,
    /// Per visited entry (the pass stops once every pixel is saturated): one
    /// past its last chunk.
    pub entry_end: Vec<u32>,
    /// Per tile pixel ([`PADDED_PIXELS`] of them): the chunk that set its
    /// median depth (−1: none).
    pub median: Vec<i32>,
    /// Per tile pixel: the transmittance left after all its fragments.
    pub transmittance: Vec<f32>,
}

/// A face's constants broadcast to all lanes.
pub struct FaceLanes {
    pub origin: [F32x8; 2],
    pub lam: [[F32x8; 3]; 3],
    pub scale: [F32x8; 3],
    pub color: [[F32x8; 3]; 3],
    pub z: [F32x8; 3],
    pub opacity: F32x8,
    pub sigma: F32x8,
}

impl FaceLanes {
    #[inline(always)]
    pub fn new(t: Avx2, f: &ScreenFace<f32>) -> Self {
        let s = |v: f32| F32x8::splat(t, v);
        FaceLanes {
            origin: [s(f.origin[0]), s(f.origin[1])],
            lam: each3(|k| each3(|i| s(f.lam[k][i]))),
            scale: each3(|k| s(f.scale[k])),
            color: each3(|k| each3(|ch| s(f.color[k][ch]))),
            z: each3(|k| s(f.z[k])),
            opacity: s(f.opacity),
            sigma: s(f.sigma),
        }
    }

    /// Local position `q = p − origin` of the lane group whose lane 0 is
    /// pixel (`x`, `y`), and the screen-space barycentrics there.
    #[inline(always)]
    pub fn barycentrics(&self, t: Avx2, x: u32, y: u32) -> ([F32x8; 2], [F32x8; 3]) {
        // Pixel centres are exact in f32 (coordinates far below 2²³).
        let px = F32x8::splat(t, x as f32 + 0.5) + F32x8::lane_index(t);
        let py = F32x8::splat(t, y as f32 + 0.5);
        let q = [px - self.origin[0], py - self.origin[1]];
        let l = &self.lam;
        let lambda = each3(|k| l[k][0].mul_add(q[0], l[k][1].mul_add(q[1], l[k][2])));
        (q, lambda)
    }

    /// `Σ_k λ_k·v_k` for per-corner values `v`.
    #[inline(always)]
    pub fn interpolate(lambda: &[F32x8; 3], v: [F32x8; 3]) -> F32x8 {
        lambda[2].mul_add(v[2], lambda[1].mul_add(v[1], lambda[0] * v[0]))
    }

    #[inline(always)]
    pub fn color_at(&self, lambda: &[F32x8; 3]) -> [F32x8; 3] {
        let c = &self.color;
        each3(|ch| Self::interpolate(lambda, [c[0][ch], c[1][ch], c[2][ch]]))
    }

    /// α = min(o·I, alpha_max) (a NaN product stays NaN) and where it clamped.
    #[inline(always)]
    pub fn alpha(&self, intensity: F32x8, alpha_max: F32x8) -> (F32x8, Mask8) {
        let raw = self.opacity * intensity;
        (alpha_max.min(raw), raw.gt(alpha_max))
    }
}

/// The rules of [`PixelRules`] broadcast to all lanes.
pub struct RuleLanes {
    pub alpha_max: F32x8,
    pub alpha_min: F32x8,
    pub transmittance_min: F32x8,
    pub half: F32x8,
}

impl RuleLanes {
    #[inline(always)]
    pub fn new(t: Avx2, r: &PixelRules<f32>) -> Self {
        RuleLanes {
            alpha_max: F32x8::splat(t, r.alpha_max),
            alpha_min: F32x8::splat(t, r.alpha_min),
            transmittance_min: F32x8::splat(t, r.transmittance_min),
            half: F32x8::splat(t, r.half),
        }
    }
}

/// Bits `lo..=hi` (both below 16).
#[inline(always)]
fn bit_range(lo: u32, hi: u32) -> u16 {
    ((0xffffu32 << lo) & (0xffffu32 >> (15 - hi))) as u16
}

/// Per-pixel state of a tile being composited, planar so a lane group is one load.
struct TileState {
    t: [f32; PADDED_PIXELS],
    color: [[f32; PADDED_PIXELS]; 3],
    depth: [f32; PADDED_PIXELS],
    median_depth: [f32; PADDED_PIXELS],
    median: [i32; PADDED_PIXELS],
}

/// Composites one tile; arguments as [`crate::cpu::forward::render_tile`],
/// with `kept` receiving lane chunks.
#[allow(clippy::too_many_arguments)]
pub fn render_tile(
    t: Avx2,
    grid: &TileGrid,
    tile: usize,
    faces: &[ScreenFace<f32>],
    entries: &[u32],
    background: &Background<'_, f32>,
    rules: &PixelRules<f32>,
    band: &mut Band<'_, f32>,
    stats: &mut [EntryStats<f32>],
    kept: &mut TileChunks,
) {
    // SAFETY: the token proves the CPU has AVX2, FMA and POPCNT.
    unsafe {
        let s = composite_avx2::<true>(t, grid, tile, faces, entries, rules, stats, kept);
        write_band(grid, tile, &s, background, band);
    }
}

/// Only `stats` of [`render_tile`]: the same blending, without colour, depth
/// or what a backward pass reads (for renders that only ask which faces show).
pub fn tile_weights(
    t: Avx2,
    grid: &TileGrid,
    tile: usize,
    faces: &[ScreenFace<f32>],
    entries: &[u32],
    rules: &PixelRules<f32>,
    stats: &mut [EntryStats<f32>],
) {
    // The weights-only pass records nothing: an empty record, never grown.
    let mut none = TileChunks::default();
    // SAFETY: the token proves the CPU has AVX2, FMA and POPCNT.
    unsafe {
        composite_avx2::<false>(t, grid, tile, faces, entries, rules, stats, &mut none);
    }
}

/// Front-to-back blending of a tile's entries into its pixels' state. With
/// `FULL` false only transmittance and `stats` are kept (the face colours
/// need not be shaded); the blending, and so `stats`, are the same.
#[target_feature(enable = "avx2,fma,popcnt")]
#[allow(clippy::too_many_arguments)]
fn composite_avx2<const FULL: bool>(
    t: Avx2,
    grid: &TileGrid,
    tile: usize,
    faces: &[ScreenFace<f32>],
    entries: &[u32],
    rules: &PixelRules<f32>,
    stats: &mut [EntryStats<f32>],
    kept: &mut TileChunks,
) -> TileState {
    let rect = grid.tile_rect(tile);
    let [x0, y0, x1, y1] = rect;
    let mut s = TileState {
        t: [1.0; PADDED_PIXELS],
        color: [[0.0; PADDED_PIXELS]; 3],
        depth: [0.0; PADDED_PIXELS],
        median_depth: [0.0; PADDED_PIXELS],
        median: [-1; PADDED_PIXELS],
    };
    kept.chunks.clear();
    kept.entry_end.clear();
    let lanes = RuleLanes::new(t, rules);
    let (one, zero) = (F32x8::splat(t, 1.0), F32x8::zero(t));
    // Per tile row, bit c: pixel c is inside the tile's rectangle and not
    // saturated (T ≥ transmittance_min; a NaN T never saturates, as in the
    // scalar pass). Faces and rows over saturated pixels only are skipped.
    let mut active = [0u16; TILE as usize];
    let width_bits = bit_range(0, x1 - x0 - 1);
    for row in active.iter_mut().take((y1 - y0) as usize) {
        *row = width_bits;
    }
    let mut remaining = (x1 - x0) * (y1 - y0);
    for (slot, &fi) in entries.iter().enumerate() {
        if remaining == 0 {
            break;
        }
        let f = &faces[fi as usize];
        if let Some(&next) = entries.get(slot + 1) {
            t.prefetch(&faces[next as usize]);
        }
        let Some((xa, xb, ya, yb)) = clip_to_tile(f, rect) else {
            if FULL {
                kept.entry_end.push(kept.chunks.len() as u32);
            }
            continue;
        };
        let columns = bit_range(xa - x0, xb - x0);
        let rows = (ya - y0) as usize..=(yb - y0) as usize;
        if active[rows.clone()].iter().all(|&a| a & columns == 0) {
            if FULL {
                kept.entry_end.push(kept.chunks.len() as u32);
            }
            continue;
        }
        let face = FaceLanes::new(t, f);
        let mut spans = None;
        let mut max_weight = zero;
        let mut blended = 0u32;
        for (r, y) in rows.zip(ya..=yb) {
            let mut live = u32::from(active[r] & columns);
            if live == 0 {
                continue;
            }
            if 31 - live.leading_zeros() - live.trailing_zeros() >= LANES as u32 {
                // More than one lane group: narrow to the face's span on this row first.
                let spans = spans.get_or_insert_with(|| RowSpans::new(f));
                let Some((xs, xe)) = spans.span(y, xa, xb) else {
                    continue;
                };
                live &= u32::from(bit_range(xs - x0, xe - x0));
            }
            let row = r as u32 * TILE;
            while live != 0 {
                let gx = live.trailing_zeros();
                let group_bits = (live >> gx) as u8;
                live &= !(0xffu32 << gx);
                let first = (row + gx) as usize;
                let t_old = F32x8::load_at(t, &s.t, first);
                let (_, lambda) = face.barycentrics(t, x0 + gx, y);
                let g = (lambda[0] * face.scale[0])
                    .min(lambda[1] * face.scale[1])
                    .min(lambda[2] * face.scale[2]);
                let inside = Mask8::from_bits(t, group_bits) & g.gt(zero);
                if !inside.any() {
                    continue;
                }
                let intensity = pow(t, g, face.sigma);
                let (alpha, _) = face.alpha(intensity, lanes.alpha_max);
                // Written as "not below" so that a NaN α is kept and shows in the output.
                let m = inside.and_not(alpha.lt(lanes.alpha_min));
                let bits = m.bits();
                if bits == 0 {
                    continue;
                }
                // Lanes outside `m` get α = w = 0, so the updates below leave
                // them exactly as they were (colour and depth are finite
                // there). Arithmetic instead of a select before each store:
                // the compiler turns "load, select, store back" into masked
                // stores, which are slow on AMD CPUs.
                let alpha = m.keep(alpha);
                let w = alpha * t_old;
                if FULL {
                    let c = face.color_at(&lambda);
                    let z = FaceLanes::interpolate(&lambda, face.z);
                    for ch in 0..3 {
                        let old = F32x8::load_at(t, &s.color[ch], first);
                        w.mul_add(c[ch], old).store_at(&mut s.color[ch], first);
                    }
                    let old = F32x8::load_at(t, &s.depth, first);
                    w.mul_add(z, old).store_at(&mut s.depth, first);
                    let median = m & t_old.gt(lanes.half);
                    // Only the first fragments of a pixel can set it: rarely taken deeper down.
                    if median.any() {
                        let chunk = kept.chunks.len() as i32;
                        let old = F32x8::load_at(t, &s.median_depth, first);
                        median.select(z, old).store_at(&mut s.median_depth, first);
                        let old = I32x8::load_at(t, &s.median, first);
                        median
                            .select_i32(I32x8::splat(t, chunk), old)
                            .store_at(&mut s.median, first);
                    }
                }
                let t_new = t_old * (one - alpha);
                t_new.store_at(&mut s.t, first);
                let saturated = (m & t_new.lt(lanes.transmittance_min)).bits();
                // The group lies inside the row (its lanes are in `live`), so the shift keeps them.
                active[r] &= !((u32::from(saturated) << gx) as u16);
                remaining -= saturated.count_ones();
                // NaN weights do not count, as in f32::max.
                max_weight = w.max(max_weight);
                blended += bits.count_ones();
                if FULL {
                    kept.chunks.push(LaneChunk {
                        intensity: intensity.to_array(),
                        t_before: t_old.to_array(),
                        // A tile has 256 pixels.
                        first: first as u8,
                        mask: bits,
                    });
                }
            }
        }
        stats[slot] = EntryStats {
            max_weight: max_weight.max_lane(),
            pixels: blended,
        };
        if FULL {
            kept.entry_end.push(kept.chunks.len() as u32);
        }
    }
    if FULL {
        kept.median.clear();
        kept.median.extend_from_slice(&s.median);
        kept.transmittance.clear();
        kept.transmittance.extend_from_slice(&s.t[..TILE_PIXELS]);
    }
    s
}

/// Writes a composited tile's pixels into `band`.
fn write_band(
    grid: &TileGrid,
    tile: usize,
    s: &TileState,
    background: &Background<'_, f32>,
    band: &mut Band<'_, f32>,
) {
    let [x0, y0, x1, y1] = grid.tile_rect(tile);
    let n = (x1 - x0) as usize;
    for y in y0..y1 {
        let row = ((y - y0) * TILE) as usize..((y - y0) * TILE) as usize + n;
        band.write_row(
            x0,
            y,
            [
                &s.color[0][row.clone()],
                &s.color[1][row.clone()],
                &s.color[2][row.clone()],
            ],
            &s.t[row.clone()],
            &s.depth[row.clone()],
            &s.median_depth[row],
            background,
            grid.image_width as usize,
        );
    }
}
