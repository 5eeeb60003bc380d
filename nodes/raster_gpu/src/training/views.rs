//! A component's views on the device: per pixel the target colour and loss
//! weight and the flags (target is the step's background colour; the
//! component's own pixel), and the measured points the view sees.

use anyhow::{Context, Result, bail};
use objectsplat_core::Camera;
use objectsplat_gpu::GpuContext;
use objectsplat_raster::backend::PixelRect;

/// Bits of a view pixel's flags word (status.wgsl's FLAG_*); with
/// FLAG_LAYERED the high 16 bits hold the background colour's share of a
/// FLAG_BACKGROUND target.
const FLAG_BACKGROUND: u32 = 1;
const FLAG_OWN: u32 = 2;
const FLAG_LAYERED: u32 = 4;
const SHARE_SHIFT: u32 = 16;
const SHARE_ONE: f32 = 65535.0;

/// One training view: its camera and supervision. `target` is RGB per pixel,
/// `weights` the per-pixel loss weight (0 = not supervised), and where
/// `from_background` is set the target is the step's background colour
/// instead — or, when `background_share` is not empty, `target` plus the
/// background colour times the pixel's share (frozen neighbours drawn over
/// the background: `target` is what they draw, premultiplied). `own` marks
/// the component's own pixels (the planar prior's domain; empty: none) and
/// `points` the measured points the view sees, as (pixel index in the image,
/// camera depth), one per pixel at most.
#[derive(Debug, Clone)]
pub struct TrainingView {
    pub camera: Camera,
    pub target: Vec<f32>,
    pub weights: Vec<f32>,
    pub from_background: Vec<bool>,
    pub background_share: Vec<f32>,
    pub own: Vec<bool>,
    pub points: Vec<(u32, f32)>,
}

impl TrainingView {
    /// A view with no own pixels and no points (photometric supervision only).
    pub fn photometric(
        camera: Camera,
        target: Vec<f32>,
        weights: Vec<f32>,
        from_background: Vec<bool>,
    ) -> Self {
        TrainingView {
            camera,
            target,
            weights,
            from_background,
            background_share: Vec::new(),
            own: Vec::new(),
            points: Vec::new(),
        }
    }

    fn validate(&self, index: usize) -> Result<()> {
        self.camera
            .validate()
            .map_err(anyhow::Error::msg)
            .with_context(|| format!("training view {index}"))?;
        let pixels = self.camera.width as usize * self.camera.height as usize;
        if self.target.len() != pixels * 3
            || self.weights.len() != pixels
            || self.from_background.len() != pixels
            || !(self.own.is_empty() || self.own.len() == pixels)
            || !(self.background_share.is_empty() || self.background_share.len() == pixels)
        {
            bail!(
                "training view {index}: {} target values, {} weights, {} background flags, \
                 {} background shares and {} own flags for {pixels} pixels",
                self.target.len(),
                self.weights.len(),
                self.from_background.len(),
                self.background_share.len(),
                self.own.len()
            );
        }
        if let Some(i) = self
            .background_share
            .iter()
            .position(|s| !(0.0..=1.0).contains(s))
        {
            bail!(
                "training view {index}: background share {i} is {} (expected 0 to 1)",
                self.background_share[i]
            );
        }
        if let Some(i) = self.target.iter().position(|v| !v.is_finite()) {
            bail!("training view {index}: target value {i} is not finite");
        }
        if let Some(i) = self
            .weights
            .iter()
            .position(|w| !(w.is_finite() && *w >= 0.0))
        {
            bail!(
                "training view {index}: weight {i} is {} (expected finite and ≥ 0)",
                self.weights[i]
            );
        }
        let mut seen = vec![false; pixels];
        for &(pixel, depth) in &self.points {
            if pixel as usize >= pixels || !(depth.is_finite() && depth > 0.0) {
                bail!(
                    "training view {index}: measured point at pixel {pixel}, depth {depth} \
                     (expected a pixel below {pixels} and a finite positive depth)"
                );
            }
            if std::mem::replace(&mut seen[pixel as usize], true) {
                bail!("training view {index}: two measured points at pixel {pixel}");
            }
        }
        Ok(())
    }

    /// Bounding box of the pixels whose target is not the background colour
    /// (the supervision a crop must keep; `ViewSummary::include` of the trainer).
    pub fn include(&self) -> PixelRect {
        let w = self.camera.width as usize;
        let mut include = PixelRect::default();
        for (p, _) in self
            .from_background
            .iter()
            .enumerate()
            .filter(|(_, b)| !**b)
        {
            include = include.union(PixelRect::pixel(p, w));
        }
        include
    }
}

/// A view's buffers and what the host keeps of it.
pub(crate) struct ViewBuffers {
    pub camera: Camera,
    /// Per pixel: target RGB and weight.
    pub targets: wgpu::Buffer,
    /// Per pixel: FLAG_BACKGROUND, FLAG_OWN.
    pub flags: wgpu::Buffer,
    /// Per measured point: pixel, depth (f32 bits); one dummy entry when there is none.
    pub points: wgpu::Buffer,
    pub point_count: usize,
    /// 1 / (3·Σ weights), 0 without supervised pixels.
    pub norm: f32,
    pub supervised: bool,
    /// `Σ` weights over the view.
    pub total_weight: f64,
    /// Bounding box of the pixels whose target is not the background colour.
    pub include: PixelRect,
}

impl ViewBuffers {
    /// Validates view `index` and uploads it.
    pub fn upload(ctx: &GpuContext, view: &TrainingView, index: usize) -> Result<Self> {
        view.validate(index)?;
        let targets: Vec<[f32; 4]> = view
            .target
            .chunks_exact(3)
            .zip(&view.weights)
            .map(|(rgb, &w)| [rgb[0], rgb[1], rgb[2], w])
            .collect();
        let flags: Vec<u32> = (0..view.from_background.len())
            .map(|p| {
                let own = view.own.get(p).copied().unwrap_or(false);
                let layered = match view.background_share.get(p) {
                    Some(&share) if view.from_background[p] => {
                        FLAG_LAYERED + (((share * SHARE_ONE).round() as u32) << SHARE_SHIFT)
                    }
                    _ => 0,
                };
                view.from_background[p] as u32 * FLAG_BACKGROUND + own as u32 * FLAG_OWN + layered
            })
            .collect();
        let mut points: Vec<[u32; 2]> = view
            .points
            .iter()
            .map(|&(pixel, depth)| [pixel, depth.to_bits()])
            .collect();
        let point_count = points.len();
        if points.is_empty() {
            points.push([0, 0]);
        }
        let total_weight: f64 = view.weights.iter().map(|&w| w as f64).sum();
        let supervised = total_weight > 0.0;
        Ok(ViewBuffers {
            camera: view.camera,
            targets: crate::kernels::storage_from(ctx, "view targets", &targets),
            flags: crate::kernels::storage_from(ctx, "view pixel flags", &flags),
            points: crate::kernels::storage_from(ctx, "measured points", &points),
            point_count,
            norm: if supervised {
                (1.0 / (3.0 * total_weight)) as f32
            } else {
                0.0
            },
            supervised,
            total_weight,
            include: view.include(),
        })
    }

    pub fn pixels(&self) -> usize {
        self.camera.width as usize * self.camera.height as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flag_bits_are_those_of_the_kernels() {
        let wgsl = include_str!("status.wgsl");
        assert!(wgsl.contains(&format!("const FLAG_BACKGROUND: u32 = {FLAG_BACKGROUND}u;")));
        assert!(wgsl.contains(&format!("const FLAG_OWN: u32 = {FLAG_OWN}u;")));
        assert!(wgsl.contains(&format!("const FLAG_LAYERED: u32 = {FLAG_LAYERED}u;")));
        assert!(wgsl.contains(&format!("const SHARE_SHIFT: u32 = {SHARE_SHIFT}u;")));
        assert!(wgsl.contains(&format!("const SHARE_ONE: f32 = {SHARE_ONE:.1};")));
    }
}
