//! The per-pixel window/opacity evaluation shared by both passes, and the
//! front-to-back compositing of one tile.

use super::binning::{TILE, TILE_PIXELS, TileGrid};
use super::preprocess::ScreenFace;
use crate::backend::RenderSettings;
use crate::real::Real;

/// The thresholds of the pixel loop in the renderer's scalar type.
#[derive(Debug, Clone, Copy)]
pub struct PixelRules<R: Real> {
    pub alpha_max: R,
    pub alpha_min: R,
    pub transmittance_min: R,
    pub half: R,
}

impl<R: Real> PixelRules<R> {
    pub fn new(s: &RenderSettings) -> Self {
        PixelRules {
            alpha_max: R::of(s.alpha_max),
            alpha_min: R::of(s.alpha_min),
            transmittance_min: R::of(s.transmittance_min),
            half: R::of(0.5),
        }
    }
}

/// One face's contribution at one pixel.
#[derive(Debug, Clone, Copy)]
pub struct Fragment<R: Real> {
    /// Local pixel position `p − origin`.
    pub q: [R; 2],
    /// Screen-space barycentrics.
    pub lambda: [R; 3],
    /// Window argument `G = min_k λ_k·P/L_k` (φ/φ(s)) and the corner attaining it.
    pub g: R,
    pub kstar: u8,
    /// Window value `G^σ`.
    pub intensity: R,
    pub alpha: R,
    /// `o·I > alpha_max`: α is the constant clamp there.
    pub clamped: bool,
}

impl<R: Real> Fragment<R> {
    #[inline(always)]
    pub fn color(&self, f: &ScreenFace<R>) -> [R; 3] {
        let l = self.lambda;
        [0, 1, 2].map(|ch| l[0] * f.color[0][ch] + l[1] * f.color[1][ch] + l[2] * f.color[2][ch])
    }

    #[inline(always)]
    pub fn depth(&self, f: &ScreenFace<R>) -> R {
        self.lambda[0] * f.z[0] + self.lambda[1] * f.z[1] + self.lambda[2] * f.z[2]
    }
}

/// Evaluates face `f` at the pixel centre `(px, py)`; `None` outside the
/// window's support or below the α threshold.
#[inline(always)]
pub fn evaluate<R: Real>(
    f: &ScreenFace<R>,
    px: R,
    py: R,
    rules: &PixelRules<R>,
) -> Option<Fragment<R>> {
    let (q, lambda, g, kstar) = window_argument(f, px, py);
    if !(g > R::zero()) {
        return None;
    }
    let frag = fragment(f, q, lambda, g, kstar, g.powf(f.sigma), rules);
    // Written as `<` so that a NaN α is kept and shows in the output (never dropped silently).
    if frag.alpha < rules.alpha_min {
        return None;
    }
    Some(frag)
}

/// The fragment [`evaluate`] returned at `(px, py)`, rebuilt from its window
/// value `intensity` (the one costly term): same arithmetic, same bits.
#[inline(always)]
pub fn reevaluate<R: Real>(
    f: &ScreenFace<R>,
    px: R,
    py: R,
    intensity: R,
    rules: &PixelRules<R>,
) -> Fragment<R> {
    let (q, lambda, g, kstar) = window_argument(f, px, py);
    fragment(f, q, lambda, g, kstar, intensity, rules)
}

/// The pixel's local position, barycentrics, `G = min_k λ_k·P/L_k` and its corner.
#[inline(always)]
fn window_argument<R: Real>(f: &ScreenFace<R>, px: R, py: R) -> ([R; 2], [R; 3], R, u8) {
    let q = [px - f.origin[0], py - f.origin[1]];
    let lambda = f.lam.map(|l| l[0] * q[0] + l[1] * q[1] + l[2]);
    let g = [
        lambda[0] * f.scale[0],
        lambda[1] * f.scale[1],
        lambda[2] * f.scale[2],
    ];
    let mut kstar = 0;
    if g[1] < g[kstar] {
        kstar = 1;
    }
    if g[2] < g[kstar] {
        kstar = 2;
    }
    (q, lambda, g[kstar], kstar as u8)
}

#[inline(always)]
fn fragment<R: Real>(
    f: &ScreenFace<R>,
    q: [R; 2],
    lambda: [R; 3],
    g: R,
    kstar: u8,
    intensity: R,
    rules: &PixelRules<R>,
) -> Fragment<R> {
    let raw = f.opacity * intensity;
    let clamped = raw > rules.alpha_max;
    Fragment {
        q,
        lambda,
        g,
        kstar,
        intensity,
        alpha: if clamped { rules.alpha_max } else { raw },
        clamped,
    }
}

/// Forward results of one pixel.
#[derive(Debug, Clone, Copy, Default)]
pub struct PixelOut<R: Real> {
    pub color: [R; 3],
    pub transmittance: R,
    pub depth: R,
    pub median_depth: R,
}

/// The output planes of one row of tiles: the rendered region's rows
/// `y0..y0 + 16` (fewer at its bottom), row-major, `width` pixels from column `x0`.
pub struct Band<'a, R: Real> {
    pub x0: u32,
    pub y0: u32,
    pub width: usize,
    pub color: &'a mut [R],
    pub alpha: &'a mut [R],
    pub depth: &'a mut [R],
    pub median_depth: &'a mut [R],
    /// The background under each pixel, kept for the backward pass.
    pub background: &'a mut [R],
}

impl<R: Real> Band<'_, R> {
    /// Stores image pixel (`x`, `y`)'s results, `p.color` without the
    /// background, which is added here as `T·b`.
    #[inline]
    pub fn write(&mut self, x: u32, y: u32, p: &PixelOut<R>, bg: [R; 3]) {
        let i = (y - self.y0) as usize * self.width + (x - self.x0) as usize;
        for ch in 0..3 {
            self.color[3 * i + ch] = p.color[ch] + p.transmittance * bg[ch];
            self.background[3 * i + ch] = bg[ch];
        }
        self.alpha[i] = R::one() - p.transmittance;
        self.depth[i] = p.depth;
        self.median_depth[i] = p.median_depth;
    }

    /// [`Self::write`] for a run of pixels of one image row from (`x`, `y`),
    /// given as planes (colour without the background, transmittance, depth,
    /// median depth): the same values, with one bounds check per plane
    /// instead of a dozen per pixel. `image_width` addresses `background`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn write_row(
        &mut self,
        x: u32,
        y: u32,
        color: [&[R]; 3],
        transmittance: &[R],
        depth: &[R],
        median_depth: &[R],
        background: &Background<'_, R>,
        image_width: usize,
    ) {
        let n = transmittance.len();
        let i = (y - self.y0) as usize * self.width + (x - self.x0) as usize;
        let out = &mut self.color[3 * i..3 * (i + n)];
        let kept = &mut self.background[3 * i..3 * (i + n)];
        let mut put = |j: usize, bg: [R; 3]| {
            for ch in 0..3 {
                out[3 * j + ch] = color[ch][j] + transmittance[j] * bg[ch];
                kept[3 * j + ch] = bg[ch];
            }
        };
        match background {
            Background::Image(b) => {
                let pixel = y as usize * image_width + x as usize;
                for (j, bg) in b[3 * pixel..3 * (pixel + n)].chunks_exact(3).enumerate() {
                    put(j, [bg[0], bg[1], bg[2]]);
                }
            }
            Background::Uniform(c) => {
                for j in 0..n {
                    put(j, *c);
                }
            }
        }
        for (a, &t) in self.alpha[i..i + n].iter_mut().zip(transmittance) {
            *a = R::one() - t;
        }
        self.depth[i..i + n].copy_from_slice(depth);
        self.median_depth[i..i + n].copy_from_slice(median_depth);
    }
}

/// Per (tile, face) entry: the largest blending weight and pixel count in this tile.
#[derive(Debug, Clone, Copy, Default)]
pub struct EntryStats<R: Real> {
    pub max_weight: R,
    pub pixels: u32,
}

/// The pixels of tile rectangle `tile` (`[x0, y0, x1, y1)`) that face `f` may cover:
/// its pixel box clipped to the tile, as inclusive `(xa, xb, ya, yb)`.
#[inline]
pub fn clip_to_tile<R: Real>(f: &ScreenFace<R>, tile: [u32; 4]) -> Option<(u32, u32, u32, u32)> {
    let xa = f.pixels[0].max(tile[0]);
    let xb = f.pixels[2].min(tile[2] - 1);
    let ya = f.pixels[1].max(tile[1]);
    let yb = f.pixels[3].min(tile[3] - 1);
    (xa <= xb && ya <= yb).then_some((xa, xb, ya, yb))
}

/// The pixels of each row whose centres may lie inside a face: `λ_k > −ε`
/// for all k, solved for x in f64. ε = 1e-3 is far above the rounding error
/// of the kernels' `λ_k > 0` (≈ 1e-6 in f32), so a span never drops a pixel
/// a kernel accepts. The edges' slopes are inverted once per face, so a row
/// costs no division.
pub struct RowSpans {
    /// Per corner k: `λ_k(x) = a·(x + 0.5 − ox) + b(y)` with `b(y) = by·qy + bc`,
    /// and `1/a` (0 where a = 0).
    edges: [[f64; 4]; 3],
    origin: [f64; 2],
}

impl RowSpans {
    const EPS: f64 = 1e-3;

    #[inline]
    pub fn new<R: Real>(f: &ScreenFace<R>) -> Self {
        RowSpans {
            edges: f.lam.map(|l| {
                let a = l[0].f64();
                [
                    a,
                    if a != 0.0 { 1.0 / a } else { 0.0 },
                    l[1].f64(),
                    l[2].f64(),
                ]
            }),
            origin: [f.origin[0].f64(), f.origin[1].f64()],
        }
    }

    /// Narrows the inclusive pixel range `[xa, xb]` of row `y` to the pixels
    /// whose centres may lie inside the face.
    #[inline]
    pub fn span(&self, y: u32, xa: u32, xb: u32) -> Option<(u32, u32)> {
        let qy = y as f64 + 0.5 - self.origin[1];
        let ox = self.origin[0];
        let (mut lo, mut hi) = (xa as f64, xb as f64);
        for &[a, inv_a, by, bc] in &self.edges {
            let b = by * qy + bc;
            // λ(x) = a·(x + 0.5 − ox) + b > −ε.
            if a > 0.0 {
                lo = lo.max(ox - 0.5 + (-Self::EPS - b) * inv_a);
            } else if a < 0.0 {
                hi = hi.min(ox - 0.5 + (-Self::EPS - b) * inv_a);
            } else if b < -Self::EPS {
                return None;
            }
        }
        if !(lo <= hi) {
            return None;
        }
        // Both ends now lie in [xa, xb] ⊂ [0, 2³²): integer rounding by casts.
        let (lo, hi) = (lo.max(xa as f64), hi.min(xb as f64));
        let lo_int = lo as u32 + u32::from((lo as u32 as f64) < lo);
        Some((lo_int, hi as u32))
    }
}

/// What shows through where the faces leave transmittance.
#[derive(Debug, Clone, Copy)]
pub enum Background<'a, R: Real> {
    /// A colour per pixel of the whole image (H×W×3, row-major).
    Image(&'a [R]),
    /// One colour everywhere.
    Uniform([R; 3]),
}

impl<'a, R: Real> Background<'a, R> {
    /// The same background as f32 when `R` is f32 (for the f32-only SIMD kernels).
    pub fn as_f32(&self) -> Option<Background<'a, f32>> {
        match *self {
            Background::Image(b) => R::as_f32_slice(b).map(Background::Image),
            Background::Uniform(c) => {
                R::as_f32_slice(&c).map(|c| Background::Uniform([c[0], c[1], c[2]]))
            }
        }
    }

    /// The colour at row-major image pixel `pixel`.
    #[inline]
    pub fn at(&self, pixel: usize) -> [R; 3] {
        match self {
            Background::Image(b) => [b[3 * pixel], b[3 * pixel + 1], b[3 * pixel + 2]],
            Background::Uniform(c) => *c,
        }
    }
}

/// No fragment (a pixel nothing was blended into has no median fragment).
const NONE: u32 = u32::MAX;

/// One blended fragment as its backward pass needs it: the rest is cheap to
/// recompute from the face and the pixel ([`reevaluate`]).
#[derive(Clone, Copy)]
pub struct Kept<R: Real> {
    pub intensity: R,
    /// The pixel's transmittance before this fragment.
    pub t_before: R,
    /// Row-major index inside the 16×16 tile.
    pub pixel: u8,
}

/// What the forward pass of one tile leaves for its backward pass: its
/// fragments in blending order, entry by entry (entry `e` blended
/// `EntryStats::pixels` of them), so the backward walks exactly what the
/// forward blended without scanning or evaluating pixels again.
#[derive(Default)]
pub struct TileFragments<R: Real> {
    pub frags: Vec<Kept<R>>,
    /// Per tile pixel: the fragment that set its median depth.
    pub median: Vec<u32>,
    /// Per tile pixel: the transmittance left after all its fragments.
    pub transmittance: Vec<R>,
    /// Entries the pass visited (it stops once every pixel is saturated).
    pub visited: usize,
}

/// Composites one tile front to back. Faces are walked in depth order and
/// each visits only the tile pixels it can cover, keeping per-pixel state;
/// every pixel therefore sees its fragments in exactly the per-pixel order.
/// The results go to `band`, `stats` parallels the tile's entries, and
/// `kept` receives the fragments.
#[allow(clippy::too_many_arguments)]
pub fn render_tile<R: Real>(
    grid: &TileGrid,
    tile: usize,
    faces: &[ScreenFace<R>],
    entries: &[u32],
    background: &Background<'_, R>,
    rules: &PixelRules<R>,
    band: &mut Band<'_, R>,
    stats: &mut [EntryStats<R>],
    kept: &mut TileFragments<R>,
) {
    let rect = grid.tile_rect(tile);
    let [x0, y0, x1, y1] = rect;
    let mut t = [R::one(); TILE_PIXELS];
    let mut done = [false; TILE_PIXELS];
    let mut pixels = [PixelOut::<R>::default(); TILE_PIXELS];
    kept.frags.clear();
    kept.median.clear();
    kept.median.resize(TILE_PIXELS, NONE);
    kept.visited = 0;
    let mut remaining = ((x1 - x0) * (y1 - y0)) as usize;
    for (slot, &fi) in entries.iter().enumerate() {
        if remaining == 0 {
            break;
        }
        kept.visited = slot + 1;
        let f = &faces[fi as usize];
        let Some((xa, xb, ya, yb)) = clip_to_tile(f, rect) else {
            continue;
        };
        let mut st = EntryStats::<R>::default();
        let spans = RowSpans::new(f);
        for y in ya..=yb {
            let Some((xs, xe)) = spans.span(y, xa, xb) else {
                continue;
            };
            let py = R::of(y as f64 + 0.5);
            for x in xs..=xe {
                let i = ((y - y0) * TILE + (x - x0)) as usize;
                if done[i] {
                    continue;
                }
                let Some(frag) = evaluate(f, R::of(x as f64 + 0.5), py, rules) else {
                    continue;
                };
                let out = &mut pixels[i];
                let w = frag.alpha * t[i];
                let c = frag.color(f);
                let z = frag.depth(f);
                for ch in 0..3 {
                    out.color[ch] += w * c[ch];
                }
                out.depth += w * z;
                let idx = kept.frags.len() as u32;
                if t[i] > rules.half {
                    out.median_depth = z;
                    kept.median[i] = idx;
                }
                kept.frags.push(Kept {
                    intensity: frag.intensity,
                    t_before: t[i],
                    // A tile has 256 pixels.
                    pixel: i as u8,
                });
                st.max_weight = st.max_weight.max(w);
                st.pixels += 1;
                t[i] *= R::one() - frag.alpha;
                if t[i] < rules.transmittance_min {
                    done[i] = true;
                    remaining -= 1;
                }
            }
        }
        stats[slot] = st;
    }
    kept.transmittance.clear();
    kept.transmittance.extend_from_slice(&t);
    for y in y0..y1 {
        for x in x0..x1 {
            let i = ((y - y0) * TILE + (x - x0)) as usize;
            let bg = background.at(y as usize * grid.image_width as usize + x as usize);
            pixels[i].transmittance = t[i];
            band.write(x, y, &pixels[i], bg);
        }
    }
}
