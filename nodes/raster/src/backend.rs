//! The rendering interface every backend implements (the CPU reference
//! backend here; a wgpu backend later), with its settings, outputs and the
//! gradients it returns.

use crate::model::{Model, ModelGrads};
use crate::real::{Real, all_finite};
use anyhow::{Result, bail};
use objectsplat_core::{Camera, Image};
use std::any::Any;

/// A pixel rectangle `[x0, x1) × [y0, y1)` of an image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PixelRect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl PixelRect {
    /// The whole `width`×`height` image.
    pub fn full(width: u32, height: u32) -> Self {
        PixelRect {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// The one pixel at row-major `index` of an image `width` pixels wide.
    pub fn pixel(index: usize, width: usize) -> Self {
        let (x, y) = ((index % width) as u32, (index / width) as u32);
        PixelRect {
            x0: x,
            y0: y,
            x1: x + 1,
            y1: y + 1,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    pub fn pixels(&self) -> usize {
        self.width() as usize * self.height() as usize
    }

    /// Whether pixel (`x`, `y`) lies inside.
    pub fn contains(&self, x: u32, y: u32) -> bool {
        (self.x0..self.x1).contains(&x) && (self.y0..self.y1).contains(&y)
    }

    /// The smallest rectangle holding both (an empty one adds nothing).
    pub fn union(self, o: PixelRect) -> PixelRect {
        if self.is_empty() {
            return o;
        }
        if o.is_empty() {
            return self;
        }
        PixelRect {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }

    /// Grown by `margin` on every side, clipped to a `width`×`height` image,
    /// then rounded outwards to multiples of `tile` (still clipped). Empty stays empty.
    pub fn grown_to_tiles(self, margin: u32, tile: u32, width: u32, height: u32) -> PixelRect {
        if self.is_empty() {
            return PixelRect::default();
        }
        let tile = tile.max(1);
        let x0 = self.x0.saturating_sub(margin) / tile * tile;
        let y0 = self.y0.saturating_sub(margin) / tile * tile;
        let x1 = (self.x1.saturating_add(margin).min(width)).div_ceil(tile) * tile;
        let y1 = (self.y1.saturating_add(margin).min(height)).div_ceil(tile) * tile;
        PixelRect {
            x0: x0.min(width),
            y0: y0.min(height),
            x1: x1.min(width),
            y1: y1.min(height),
        }
    }

    /// Row-major index of image pixel `(x, y)` (inside the rectangle) in a buffer covering it.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> usize {
        (y - self.y0) as usize * self.width() as usize + (x - self.x0) as usize
    }
}

/// Which pixels of the camera's image a pass renders.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Region {
    /// Every pixel.
    #[default]
    Full,
    /// Only the pixels whose colour can differ from the background or from a
    /// supervised target: the bounding box of every drawn face's pixels and of
    /// `include`, grown by `margin` pixels and rounded out to whole 16-px
    /// tiles. Outside it the image is exactly the background. Pixel values
    /// inside it are bit-identical to a full render.
    Footprint { include: PixelRect, margin: u32 },
}

/// Rendering parameters. Every threshold of the reference renderer is a field,
/// with the reference value as default.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// Window sharpness σ (`I = (φ/φ(s))^σ`), scheduled by the trainer.
    pub sigma: f64,
    /// Active SH degree 0..=3.
    pub sh_degree: u32,
    /// Faces with any vertex at camera depth ≤ this are culled (they would
    /// project through or behind the camera plane).
    pub z_near: f64,
    /// Faces whose centroid depth is ≤ this are culled.
    pub min_centroid_depth: f64,
    /// Faces seen almost edge-on, |cos(normal, view ray to centroid)| below this, are culled.
    pub min_abs_cos: f64,
    /// Faces whose opacity (min of the corners') is below this are culled.
    pub min_opacity: f64,
    /// Faces whose largest centroid-to-vertex screen distance exceeds this (px) are culled.
    pub max_screen_extent: f64,
    /// Faces whose largest centroid-to-vertex screen distance is below this (px) are culled.
    pub min_screen_extent: f64,
    /// Faces whose 2D inradius is below this (px) are culled.
    pub min_inradius: f64,
    /// α clamp `α = min(alpha_max, o·I)`, identical in forward and backward.
    pub alpha_max: f64,
    /// Fragments with α below this are skipped (both passes).
    pub alpha_min: f64,
    /// Compositing stops once the transmittance falls below this (both passes).
    pub transmittance_min: f64,
    /// The pixels rendered; outputs cover [`RenderOutput::region`].
    pub region: Region,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            sigma: 1.0,
            sh_degree: 3,
            z_near: 0.01,
            min_centroid_depth: 0.2,
            min_abs_cos: 1e-3,
            min_opacity: 0.01,
            max_screen_extent: 1600.0,
            min_screen_extent: 1.0,
            min_inradius: 1.0,
            alpha_max: 0.999,
            alpha_min: 1.0 / 255.0,
            transmittance_min: 1e-4,
            region: Region::Full,
        }
    }
}

impl RenderSettings {
    /// Default thresholds with the model's own σ and SH degree.
    pub fn for_model<R: Real>(model: &Model<R>) -> Self {
        RenderSettings {
            sigma: model.sigma,
            sh_degree: model.sh_degree,
            ..Default::default()
        }
    }

    /// Scales the world-unit thresholds (depths) by `s`, for scenes not in metres.
    pub fn with_world_scale(mut self, s: f64) -> Self {
        self.z_near *= s;
        self.min_centroid_depth *= s;
        self
    }

    pub fn validate(&self) -> Result<()> {
        let named = [
            ("sigma", self.sigma),
            ("z_near", self.z_near),
            ("min_centroid_depth", self.min_centroid_depth),
            ("min_abs_cos", self.min_abs_cos),
            ("min_opacity", self.min_opacity),
            ("max_screen_extent", self.max_screen_extent),
            ("min_screen_extent", self.min_screen_extent),
            ("min_inradius", self.min_inradius),
            ("alpha_max", self.alpha_max),
            ("alpha_min", self.alpha_min),
            ("transmittance_min", self.transmittance_min),
        ];
        for (name, v) in named {
            if !v.is_finite() || v < 0.0 {
                bail!("render setting {name} = {v} must be finite and non-negative");
            }
        }
        if self.sigma <= 0.0 {
            bail!("render setting sigma = {} must be positive", self.sigma);
        }
        if self.z_near <= 0.0 {
            bail!("render setting z_near = {} must be positive", self.z_near);
        }
        if self.sh_degree > crate::model::MAX_SH_DEGREE {
            bail!("render setting sh_degree = {} exceeds 3", self.sh_degree);
        }
        if !(self.alpha_max > 0.0 && self.alpha_max < 1.0) {
            bail!(
                "render setting alpha_max = {} must lie in (0, 1)",
                self.alpha_max
            );
        }
        if self.alpha_min > self.alpha_max {
            bail!(
                "render setting alpha_min {} exceeds alpha_max {}",
                self.alpha_min,
                self.alpha_max
            );
        }
        if self.min_inradius <= 0.0 {
            // The barycentric weights divide by the doubled area; a positive
            // inradius floor keeps that away from zero.
            bail!(
                "render setting min_inradius = {} must be positive",
                self.min_inradius
            );
        }
        Ok(())
    }
}

/// What a forward pass produces. Images cover `region` (the whole image unless
/// [`RenderSettings::region`] asked for less), row-major; colour is interleaved RGB.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RenderOutput<R: Real = f32> {
    /// The camera's image size.
    pub width: u32,
    pub height: u32,
    /// The pixels the images hold.
    pub region: PixelRect,
    /// `Σ c_n w_n + T·b`.
    pub color: Vec<R>,
    /// `1 − T` (final transmittance).
    pub alpha: Vec<R>,
    /// Expected depth `Σ z_n w_n` (not normalised by alpha), camera z.
    pub depth: Vec<R>,
    /// Depth of the last contributor while the transmittance is still > 0.5; 0 where none.
    pub median_depth: Vec<R>,
    /// Per model face: the largest blending weight `α·T` over all pixels (0 when culled).
    pub face_max_weight: Vec<R>,
    /// Per model face: the number of pixels it contributed to.
    pub face_pixel_count: Vec<u32>,
}

impl<R: Real> RenderOutput<R> {
    /// The colour as an f32 RGB image of the rendered region.
    pub fn color_image(&self) -> Image {
        Image {
            width: self.region.width(),
            height: self.region.height(),
            channels: 3,
            data: self.color.iter().map(|v| v.f64() as f32).collect(),
        }
    }

    /// The alpha as an f32 single-channel image of the rendered region.
    pub fn alpha_image(&self) -> Image {
        Image {
            width: self.region.width(),
            height: self.region.height(),
            channels: 1,
            data: self.alpha.iter().map(|v| v.f64() as f32).collect(),
        }
    }

    /// True when no output holds NaN or ±Inf.
    pub fn all_finite(&self) -> bool {
        [
            &self.color,
            &self.alpha,
            &self.depth,
            &self.median_depth,
            &self.face_max_weight,
        ]
        .into_iter()
        .all(|plane| all_finite(plane))
    }
}

/// Upstream gradients of the loss with respect to the forward outputs.
/// Colour is required; the others are optional (treated as zero).
#[derive(Debug, Clone, Copy)]
pub struct OutputGrads<'a, R: Real = f32> {
    pub color: &'a [R],
    pub alpha: Option<&'a [R]>,
    pub depth: Option<&'a [R]>,
    pub median_depth: Option<&'a [R]>,
}

impl<'a, R: Real> OutputGrads<'a, R> {
    pub fn color_only(color: &'a [R]) -> Self {
        OutputGrads {
            color,
            alpha: None,
            depth: None,
            median_depth: None,
        }
    }

    /// Checks sizes and finiteness for a rendered region of `pixels` pixels.
    pub fn validate(&self, pixels: usize) -> Result<()> {
        check_buffer("dL/dcolor", self.color, pixels * 3)?;
        for (name, buf) in [
            ("dL/dalpha", self.alpha),
            ("dL/ddepth", self.depth),
            ("dL/dmedian_depth", self.median_depth),
        ] {
            if let Some(b) = buf {
                check_buffer(name, b, pixels)?;
            }
        }
        Ok(())
    }
}

/// Checks that a buffer has `len` finite values.
pub fn check_buffer<R: Real>(name: &str, buf: &[R], len: usize) -> Result<()> {
    if buf.len() != len {
        bail!("{name} has {} values, expected {len}", buf.len());
    }
    // Branch-free first (it vectorizes), the search only on a failure.
    if !all_finite(buf)
        && let Some(i) = buf.iter().position(|v| !v.is_finite())
    {
        bail!("{name} value {i} is {} (not finite)", buf[i]);
    }
    Ok(())
}

/// Whatever a backend keeps from a forward pass for its backward pass.
pub struct SavedForward {
    /// The backend that produced it (checked by `backward`).
    pub backend: &'static str,
    pub state: Box<dyn Any + Send + Sync>,
}

impl SavedForward {
    pub fn new<T: Any + Send + Sync>(backend: &'static str, state: T) -> Self {
        SavedForward {
            backend,
            state: Box::new(state),
        }
    }

    /// The state as `backend` saved it; an error when another backend, or the
    /// same backend at another scalar type, produced it.
    pub fn state_of<T: Any>(&self, backend: &'static str) -> Result<&T> {
        if self.backend != backend {
            bail!(
                "the {backend} backend cannot use state saved by the {:?} backend",
                self.backend
            );
        }
        self.state.downcast_ref::<T>().ok_or_else(|| {
            anyhow::anyhow!(
                "the saved forward state is not this {backend} backend's (another scalar type?)"
            )
        })
    }
}

/// A differentiable renderer. Object-safe: trainers hold `Box<dyn RenderBackend<f32>>`.
pub trait RenderBackend<R: Real>: Send + Sync {
    fn name(&self) -> &'static str;

    /// Renders `model` from `camera` over a per-pixel `background` (H×W×3 interleaved).
    fn forward(
        &self,
        model: &Model<R>,
        camera: &Camera,
        settings: &RenderSettings,
        background: &[R],
    ) -> Result<(RenderOutput<R>, SavedForward)>;

    /// Back-propagates output gradients to the model parameters and the
    /// background. `model` must be the one passed to the forward pass.
    fn backward(
        &self,
        model: &Model<R>,
        saved: &SavedForward,
        grads: &OutputGrads<'_, R>,
    ) -> Result<ModelGrads<R>>;

    /// The concrete backend, for callers that use abilities beyond this trait
    /// when they are there (a trainer keeping its iterations on a GPU).
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        None
    }
}
