//! The analytic backward pass.
//!
//! Per tile, the forward pass kept every blended fragment's window value and
//! the transmittance before it ([`TileFragments`]); the faces are walked
//! back to front over them. Keeping T instead of recovering it by dividing
//! by (1 − α) keeps the backward exact even after many near-opaque
//! fragments. Gradients go to a partial per (tile, face)
//! entry; faces then sum their partials in tile order and vertices gather
//! from their faces in face order, so the result does not depend on the
//! thread count.

use super::binning::{TILE, TILE_PIXELS, TileGrid};
use super::forward::{EntryStats, Fragment, PixelRules, TileFragments, reevaluate};
use super::preprocess::ScreenFace;
use crate::real::Real;

/// Gradient of one face restricted to one tile.
#[derive(Debug, Clone, Copy, Default)]
pub struct FacePartial<R: Real> {
    /// dL/d(local corner position), excluding the area term.
    pub d_q: [[R; 2]; 3],
    /// `Σ dL/dλ_k·λ_k / A2`; times −∂A2/∂q_j it is the area term of dL/dq_j.
    pub d_area_term: R,
    /// dL/d(P/L_k).
    pub d_scale: [R; 3],
    pub d_color: [[R; 3]; 3],
    /// dL/d(corner camera depth).
    pub d_z: [R; 3],
    pub d_opacity: R,
}

impl<R: Real> FacePartial<R> {
    pub fn add(&mut self, o: &FacePartial<R>) {
        for j in 0..3 {
            for a in 0..2 {
                self.d_q[j][a] += o.d_q[j][a];
            }
            for ch in 0..3 {
                self.d_color[j][ch] += o.d_color[j][ch];
            }
            self.d_scale[j] += o.d_scale[j];
            self.d_z[j] += o.d_z[j];
        }
        self.d_area_term += o.d_area_term;
        self.d_opacity += o.d_opacity;
    }
}

/// Upstream gradients, row-major over the rendered region.
pub struct PixelGrads<'a, R: Real> {
    pub color: &'a [R],
    pub alpha: Option<&'a [R]>,
    pub depth: Option<&'a [R]>,
    pub median_depth: Option<&'a [R]>,
}

impl<'a, R: Real> PixelGrads<'a, R> {
    /// The same gradients as f32 when `R` is f32 (for the f32-only SIMD kernels).
    pub fn as_f32(&self) -> Option<PixelGrads<'a, f32>> {
        let plane = |v: Option<&'a [R]>| match v {
            None => Some(None),
            Some(s) => R::as_f32_slice(s).map(Some),
        };
        Some(PixelGrads {
            color: R::as_f32_slice(self.color)?,
            alpha: plane(self.alpha)?,
            depth: plane(self.depth)?,
            median_depth: plane(self.median_depth)?,
        })
    }
}

/// dL/d(background) of one row of tiles: the rendered region's rows from
/// `y0`, row-major, `width` pixels from column `x0`, RGB interleaved.
pub struct GradBand<'a, R: Real> {
    pub x0: u32,
    pub y0: u32,
    pub width: usize,
    pub background: &'a mut [R],
}

impl<R: Real> GradBand<'_, R> {
    #[inline]
    pub fn write(&mut self, x: u32, y: u32, g: [R; 3]) {
        let i = (y - self.y0) as usize * self.width + (x - self.x0) as usize;
        self.background[3 * i..3 * i + 3].copy_from_slice(&g);
    }
}

/// `background` covers the rendered region (as the gradients do); `kept` is
/// what the forward pass of this tile recorded and `stats` its entry statistics.
#[allow(clippy::too_many_arguments)]
pub fn backward_tile<R: Real>(
    grid: &TileGrid,
    tile: usize,
    faces: &[ScreenFace<R>],
    entries: &[u32],
    background: &[R],
    rules: &PixelRules<R>,
    kept: &TileFragments<R>,
    stats: &[EntryStats<R>],
    grads: &PixelGrads<'_, R>,
    partials: &mut [FacePartial<R>],
    d_background: &mut GradBand<'_, R>,
) {
    let rect = grid.tile_rect(tile);
    let [x0, y0, x1, y1] = rect;
    let local = |x: u32, y: u32| ((y - y0) * TILE + (x - x0)) as usize;
    let t = &kept.transmittance;

    // Per pixel: upstream gradients, the background gradient and the running
    // `behind` = Σ_{m>n} h_m w_m + T_final·(b·G_C) − G_A·T_final, where
    // h = c·G_C + z·G_D, so that dL/dα_n = T_n·h_n − behind/(1 − α_n).
    let mut gc = [[R::zero(); 3]; TILE_PIXELS];
    let mut gd = [R::zero(); TILE_PIXELS];
    let mut gm = [R::zero(); TILE_PIXELS];
    let mut behind = [R::zero(); TILE_PIXELS];
    for y in y0..y1 {
        for x in x0..x1 {
            let (i, pix) = (local(x, y), grid.rect.index(x, y));
            let g = [0, 1, 2].map(|ch| grads.color[pix * 3 + ch]);
            let ga = grads.alpha.map_or(R::zero(), |a| a[pix]);
            gd[i] = grads.depth.map_or(R::zero(), |d| d[pix]);
            gm[i] = grads.median_depth.map_or(R::zero(), |m| m[pix]);
            let bg = [0, 1, 2].map(|ch| background[pix * 3 + ch]);
            gc[i] = g;
            d_background.write(x, y, g.map(|v| v * t[i]));
            behind[i] = t[i] * (bg[0] * g[0] + bg[1] * g[1] + bg[2] * g[2]) - ga * t[i];
        }
    }

    // Back to front, entry by entry; an entry's fragments touch distinct
    // pixels, so their order inside the entry (the forward's) does not
    // change any pixel's `behind`.
    let mut end = kept.frags.len();
    for slot in (0..kept.visited).rev() {
        let start = end - stats[slot].pixels as usize;
        if start == end {
            continue;
        }
        let f = &faces[entries[slot] as usize];
        let mut part = FacePartial::<R>::default();
        for (idx, k) in kept.frags[start..end].iter().enumerate() {
            let i = k.pixel as u32;
            let (x, y) = (x0 + i % TILE, y0 + i / TILE);
            let frag = reevaluate(
                f,
                R::of(x as f64 + 0.5),
                R::of(y as f64 + 0.5),
                k.intensity,
                rules,
            );
            let is_median = kept.median[i as usize] == (start + idx) as u32;
            let i = i as usize;
            accumulate_fragment(
                f,
                &frag,
                k.t_before,
                gc[i],
                gd[i],
                if is_median { gm[i] } else { R::zero() },
                &mut behind[i],
                &mut part,
            );
        }
        partials[slot] = part;
        end = start;
    }
}

/// Adds one fragment's gradient to its face partial and updates the pixel's `behind` sum.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn accumulate_fragment<R: Real>(
    f: &ScreenFace<R>,
    fr: &Fragment<R>,
    t_before: R,
    gc: [R; 3],
    gd: R,
    gm: R,
    behind: &mut R,
    part: &mut FacePartial<R>,
) {
    let c = fr.color(f);
    let z = fr.depth(f);
    let w = fr.alpha * t_before;
    let h = c[0] * gc[0] + c[1] * gc[1] + c[2] * gc[2] + z * gd;
    let d_alpha = t_before * h - *behind / (R::one() - fr.alpha);
    *behind += h * w;

    let d_c = gc.map(|g| g * w);
    let d_zpix = w * gd + gm;
    let mut d_lambda = [R::zero(); 3];
    for k in 0..3 {
        d_lambda[k] = f.color[k][0] * d_c[0]
            + f.color[k][1] * d_c[1]
            + f.color[k][2] * d_c[2]
            + f.z[k] * d_zpix;
        for ch in 0..3 {
            part.d_color[k][ch] += fr.lambda[k] * d_c[ch];
        }
        part.d_z[k] += fr.lambda[k] * d_zpix;
    }
    if !fr.clamped {
        // α = o·G^σ.
        part.d_opacity += d_alpha * fr.intensity;
        let d_g = d_alpha * f.opacity * f.sigma * fr.intensity / fr.g;
        let k = fr.kstar as usize;
        d_lambda[k] += d_g * f.scale[k];
        part.d_scale[k] += d_g * fr.lambda[k];
    }
    // λ_k = cross(q_{k+1} − q, q_{k+2} − q)/A2 with A2 the doubled area.
    let q = fr.q;
    let mut area_term = R::zero();
    for k in 0..3 {
        let d = d_lambda[k] * f.inv_area2;
        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
        let (qa, qb) = (f.q[a], f.q[b]);
        part.d_q[a][0] += d * (qb[1] - q[1]);
        part.d_q[a][1] -= d * (qb[0] - q[0]);
        part.d_q[b][0] -= d * (qa[1] - q[1]);
        part.d_q[b][1] += d * (qa[0] - q[0]);
        area_term += d * fr.lambda[k];
    }
    part.d_area_term += area_term;
}

/// Per-corner gradient of one face, after its partials are summed.
#[derive(Debug, Clone, Copy, Default)]
pub struct CornerGrads<R: Real> {
    /// dL/d(screen position).
    pub d_screen: [[R; 2]; 3],
    pub d_z: [R; 3],
    pub d_color: [[R; 3]; 3],
    pub d_opacity: [R; 3],
}

/// Back-propagates a face's summed partial through the area, edge lengths and perimeter.
pub fn face_backward<R: Real>(f: &ScreenFace<R>, p: &FacePartial<R>) -> CornerGrads<R> {
    let mut d_q = p.d_q;
    // ∂A2/∂q_j = (q_{j+1}.y − q_{j−1}.y, q_{j−1}.x − q_{j+1}.x).
    for j in 0..3 {
        let (n, prev) = (f.q[(j + 1) % 3], f.q[(j + 2) % 3]);
        d_q[j][0] -= p.d_area_term * (n[1] - prev[1]);
        d_q[j][1] -= p.d_area_term * (prev[0] - n[0]);
    }
    // scale_k = P/L_k, P = Σ L_m.
    let mut d_len = [R::zero(); 3];
    let mut d_perimeter = R::zero();
    for k in 0..3 {
        d_perimeter += p.d_scale[k] / f.len[k];
        d_len[k] -= p.d_scale[k] * f.perimeter / (f.len[k] * f.len[k]);
    }
    for k in 0..3 {
        let dl = d_len[k] + d_perimeter;
        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
        let e = [
            (f.q[b][0] - f.q[a][0]) / f.len[k],
            (f.q[b][1] - f.q[a][1]) / f.len[k],
        ];
        for i in 0..2 {
            d_q[b][i] += dl * e[i];
            d_q[a][i] -= dl * e[i];
        }
    }
    let mut d_opacity = [R::zero(); 3];
    d_opacity[f.argmin_corner as usize] = p.d_opacity;
    CornerGrads {
        d_screen: d_q,
        d_z: p.d_z,
        d_color: p.d_color,
        d_opacity,
    }
}
