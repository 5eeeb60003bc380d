//! The backward pass of one tile over the forward's lane chunks: the
//! eight-lane counterpart of [`crate::cpu::backward::backward_tile`], the same
//! per-fragment gradient with the face partial summed per lane and the lanes
//! summed at the end of each entry.

use super::forward::{FaceLanes, PADDED_PIXELS, RuleLanes, TileChunks};
use super::{Avx2, F32x8, I32x8, LANES, Mask8, each3};
use crate::cpu::backward::{FacePartial, GradBand, PixelGrads};
use crate::cpu::binning::{TILE, TileGrid};
use crate::cpu::forward::PixelRules;
use crate::cpu::preprocess::ScreenFace;

/// Per-lane sums of one entry's fragments, [`SUMS`] of them (see the offsets
/// below). The corner-position gradient `Σ d_k·(q_b − q)` is kept as `Σ d_k`
/// and `Σ d_k·q` (d_k = dL/dλ_k / A2), turned into the partial's `d_q` once
/// per entry.
struct LaneSums([F32x8; SUMS]);

/// `Σ d_k`, k = 0..3.
const D: usize = 0;
/// `Σ d_k·q_x`, `Σ d_k·q_y`.
const D_QX: usize = 3;
const D_QY: usize = 6;
const AREA_TERM: usize = 9;
const D_SCALE: usize = 10;
const D_Z: usize = 13;
/// `d_color[k][ch]` at `D_COLOR + 3k + ch`.
const D_COLOR: usize = 16;
const D_OPACITY: usize = 25;
/// Four groups of eight lanes (the last six unused), reduced eight at a time.
const SUMS: usize = 32;

impl LaneSums {
    #[inline(always)]
    fn new(t: Avx2) -> Self {
        LaneSums([F32x8::zero(t); SUMS])
    }

    #[inline(always)]
    fn add(&mut self, i: usize, v: F32x8) {
        self.0[i] = self.0[i] + v;
    }

    /// `self[i] += a·b`.
    #[inline(always)]
    fn add_product(&mut self, i: usize, a: F32x8, b: F32x8) {
        self.0[i] = a.mul_add(b, self.0[i]);
    }

    /// The face partial: lanes summed, `d_q` rebuilt from the corner positions in f64.
    #[inline(always)]
    fn partial(&self, f: &ScreenFace<f32>) -> FacePartial<f32> {
        let mut sum = [0.0f32; SUMS];
        for group in 0..SUMS / LANES {
            let v = &self.0[group * LANES..(group + 1) * LANES];
            let v: [F32x8; LANES] = v.try_into().expect("eight lanes");
            F32x8::sum_each(v).store(
                (&mut sum[group * LANES..(group + 1) * LANES])
                    .try_into()
                    .expect("eight lanes"),
            );
        }
        let mut d_q = [[0.0f64; 2]; 3];
        for k in 0..3 {
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            let (qa, qb) = (f.q[a].map(f64::from), f.q[b].map(f64::from));
            let [d, dx, dy] = [D, D_QX, D_QY].map(|i| sum[i + k] as f64);
            // λ_k = cross(q_a − q, q_b − q)/A2, differentiated in q_a and q_b.
            d_q[a][0] += qb[1] * d - dy;
            d_q[a][1] -= qb[0] * d - dx;
            d_q[b][0] -= qa[1] * d - dy;
            d_q[b][1] += qa[0] * d - dx;
        }
        FacePartial {
            d_q: d_q.map(|q| q.map(|v| v as f32)),
            d_area_term: sum[AREA_TERM],
            d_scale: [0, 1, 2].map(|k| sum[D_SCALE + k]),
            d_color: [0, 1, 2].map(|k| [0, 1, 2].map(|ch| sum[D_COLOR + 3 * k + ch])),
            d_z: [0, 1, 2].map(|k| sum[D_Z + k]),
            d_opacity: sum[D_OPACITY],
        }
    }
}

/// How far ahead of the chunk being differentiated the next is prefetched.
const CHUNKS_AHEAD: usize = 8;

/// Per-pixel state of the tile's backward pass, planar for lane-group loads.
struct TileGrads {
    color: [[f32; PADDED_PIXELS]; 3],
    depth: [f32; PADDED_PIXELS],
    median_depth: [f32; PADDED_PIXELS],
    /// `Σ_{m>n} h_m w_m + T_final·(b·G_C) − G_A·T_final`, as in the scalar pass.
    behind: [f32; PADDED_PIXELS],
}

/// Arguments as [`crate::cpu::backward::backward_tile`], over `kept`'s lane chunks.
#[allow(clippy::too_many_arguments)]
pub fn backward_tile(
    t: Avx2,
    grid: &TileGrid,
    tile: usize,
    faces: &[ScreenFace<f32>],
    entries: &[u32],
    background: &[f32],
    rules: &PixelRules<f32>,
    kept: &TileChunks,
    grads: &PixelGrads<'_, f32>,
    partials: &mut [FacePartial<f32>],
    d_background: &mut GradBand<'_, f32>,
) {
    // SAFETY: the token proves the CPU has AVX2, FMA and POPCNT.
    unsafe {
        backward_tile_avx2(
            t,
            grid,
            tile,
            faces,
            entries,
            background,
            rules,
            kept,
            grads,
            partials,
            d_background,
        )
    }
}

#[target_feature(enable = "avx2,fma,popcnt")]
#[allow(clippy::too_many_arguments)]
fn backward_tile_avx2(
    t: Avx2,
    grid: &TileGrid,
    tile: usize,
    faces: &[ScreenFace<f32>],
    entries: &[u32],
    background: &[f32],
    rules: &PixelRules<f32>,
    kept: &TileChunks,
    grads: &PixelGrads<'_, f32>,
    partials: &mut [FacePartial<f32>],
    d_background: &mut GradBand<'_, f32>,
) {
    let [x0, y0, x1, y1] = grid.tile_rect(tile);
    let tf = &kept.transmittance;
    let mut s = TileGrads {
        color: [[0.0; PADDED_PIXELS]; 3],
        depth: [0.0; PADDED_PIXELS],
        median_depth: [0.0; PADDED_PIXELS],
        behind: [0.0; PADDED_PIXELS],
    };
    for y in y0..y1 {
        for x in x0..x1 {
            let i = ((y - y0) * TILE + (x - x0)) as usize;
            let pix = grid.rect.index(x, y);
            let g = [0, 1, 2].map(|ch| grads.color[pix * 3 + ch]);
            let ga = grads.alpha.map_or(0.0, |a| a[pix]);
            let bg = [0, 1, 2].map(|ch| background[pix * 3 + ch]);
            for ch in 0..3 {
                s.color[ch][i] = g[ch];
            }
            s.depth[i] = grads.depth.map_or(0.0, |d| d[pix]);
            s.median_depth[i] = grads.median_depth.map_or(0.0, |m| m[pix]);
            d_background.write(x, y, g.map(|v| v * tf[i]));
            s.behind[i] = tf[i] * (bg[0] * g[0] + bg[1] * g[1] + bg[2] * g[2]) - ga * tf[i];
        }
    }

    let lanes = RuleLanes::new(t, rules);
    let one = F32x8::splat(t, 1.0);
    let mut end = kept.entry_end.len();
    while end > 0 {
        let slot = end - 1;
        end = slot;
        let start = if slot == 0 {
            0
        } else {
            kept.entry_end[slot - 1] as usize
        };
        let stop = kept.entry_end[slot] as usize;
        if start == stop {
            continue;
        }
        let f = &faces[entries[slot] as usize];
        if let Some(&next) = slot.checked_sub(1).and_then(|s| entries.get(s)) {
            t.prefetch(&faces[next as usize]);
        }
        let face = FaceLanes::new(t, f);
        let o_sigma = face.opacity * face.sigma;
        let inv_area2 = F32x8::splat(t, f.inv_area2);
        let mut sums = LaneSums::new(t);
        // An entry's chunks cover distinct pixels, so their order does not
        // change any pixel's `behind`. Walking them backwards too makes the
        // whole pass one descending stream through the chunks (written by the
        // forward pass long before, out of cache): the prefetcher follows it,
        // helped by a prefetch some chunks ahead.
        for c in (start..stop).rev() {
            let chunk = &kept.chunks[c];
            if let Some(ahead) = c.checked_sub(CHUNKS_AHEAD) {
                t.prefetch(&kept.chunks[ahead]);
            }
            let first = chunk.first as usize;
            let (row, col) = (first as u32 / TILE, first as u32 % TILE);
            let (q, lambda) = face.barycentrics(t, x0 + col, y0 + row);
            let g = each3(|k| lambda[k] * face.scale[k]);
            // The corner attaining the minimum, first on ties (as the scalar pass).
            let over_0 = g[1].lt(g[0]);
            let g01 = over_0.select(g[1], g[0]);
            let is_2 = g[2].lt(g01);
            let g_min = is_2.select(g[2], g01);
            let is_1 = over_0.and_not(is_2);
            let is_k = [Mask8::from_bits(t, 0xff).and_not(over_0 | is_2), is_1, is_2];

            let m = Mask8::from_bits(t, chunk.mask);
            let intensity = F32x8::load(t, &chunk.intensity);
            let t_before = F32x8::load(t, &chunk.t_before);
            let (alpha, clamped) = face.alpha(intensity, lanes.alpha_max);
            let color = face.color_at(&lambda);
            let z = FaceLanes::interpolate(&lambda, face.z);
            // Zero outside the chunk's lanes (whose records are not fragments),
            // so the updates below leave those pixels as they were.
            let w = m.keep(alpha * t_before);
            let gc = each3(|ch| F32x8::load_at(t, &s.color[ch], first));
            let gd = F32x8::load_at(t, &s.depth, first);
            let h = FaceLanes::interpolate(&color, gc) + z * gd;
            let behind = F32x8::load_at(t, &s.behind, first);
            let d_alpha = t_before.mul_sub(h, behind.div(one - alpha));
            // Arithmetic, not a select: see the forward kernel's updates.
            h.mul_add(w, behind).store_at(&mut s.behind, first);

            let d_c = each3(|ch| gc[ch] * w);
            let median = I32x8::load_at(t, &kept.median, first).eq(I32x8::splat(t, c as i32));
            let gm = median.keep(F32x8::load_at(t, &s.median_depth, first));
            let d_zpix = m.keep(w.mul_add(gd, gm));
            let live = m.and_not(clamped);
            // α = o·G^σ: dα/dG = o·σ·G^σ / G.
            sums.add_product(D_OPACITY, live.keep(d_alpha), intensity);
            let d_g = live.keep((d_alpha * o_sigma * intensity).div(g_min));
            for k in 0..3 {
                let d_g_k = is_k[k].keep(d_g);
                let d_lambda = d_g_k.mul_add(
                    face.scale[k],
                    FaceLanes::interpolate(&d_c, face.color[k]) + face.z[k] * d_zpix,
                );
                for ch in 0..3 {
                    sums.add_product(D_COLOR + 3 * k + ch, lambda[k], d_c[ch]);
                }
                sums.add_product(D_Z + k, lambda[k], d_zpix);
                sums.add_product(D_SCALE + k, d_g_k, lambda[k]);
                let d = d_lambda * inv_area2;
                sums.add(D + k, d);
                sums.add_product(D_QX + k, d, q[0]);
                sums.add_product(D_QY + k, d, q[1]);
                sums.add_product(AREA_TERM, d, lambda[k]);
            }
        }
        partials[slot] = sums.partial(f);
    }
}
