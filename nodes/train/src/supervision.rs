//! What a component is trained on: its views, and what every pixel is
//! supervised toward.
//!
//! Objects keep their OWN pixels and pull every other pixel toward the
//! background colour `b` (weight 1 for OTHER pixels, 0 for IGNORE and unowned
//! ones, whose target is `b` too, so an object's targets differ from `b` only on
//! its own pixels); the background component keeps its OWN pixels and gives
//! every other pixel zero weight — unless it is trained behind the frozen,
//! already trained objects (`occluders`): then every valid pixel is
//! supervised by the composite, so nothing of the background may hang in
//! front of an object.

use anyhow::{Result, bail};
use objectsplat_core::component::{OTHER, OWN};
use objectsplat_core::{Camera, ComponentKind, Image, Split};
use objectsplat_raster::backend::PixelRect;
use std::path::Path;

/// One supervised view of a component.
pub struct View {
    pub name: String,
    pub camera: Camera,
    /// Target colours, H×W×3 (the frame image, or the component's replacement targets).
    pub target: Vec<f32>,
    /// Per-pixel ownership label (OWN / OTHER / IGNORE).
    pub labels: Vec<u8>,
    pub split: Split,
}

/// What a component is trained on.
pub struct ComponentData {
    pub name: String,
    pub kind: ComponentKind,
    pub views: Vec<View>,
    /// Trained objects rendered, frozen, with the background (their union, see
    /// `Model::union`); only for the background component.
    pub occluders: Option<objectsplat_raster::Model<f32>>,
    /// Measured points on this component's surfaces (its SfM or scanner points,
    /// not seeds), which supervise depth (see `crate::point_depth`).
    pub depth_points: Vec<[f32; 3]>,
}

impl ComponentData {
    /// Reads a Component folder: frames, images, masks and optional replacement targets.
    pub fn read(dir: &Path) -> Result<ComponentData> {
        let masks = crate::init::ComponentMasks::read(dir)?;
        let mut views = Vec::new();
        for (frame, labels) in masks.frames.frames.iter().zip(&masks.masks) {
            let mut target = masks.frames.load_rgb(frame)?.data;
            let replacement = objectsplat_core::component::target_path(dir, frame);
            if replacement.exists() {
                let img = Image::load(&replacement)?.to_rgb();
                if img.width != frame.width || img.height != frame.height {
                    bail!(
                        "{}: target is {}×{} but the frame is {}×{}",
                        replacement.display(),
                        img.width,
                        img.height,
                        frame.width,
                        frame.height
                    );
                }
                for (p, &l) in labels.iter().enumerate() {
                    if l == OWN {
                        target[3 * p..3 * p + 3].copy_from_slice(&img.data[3 * p..3 * p + 3]);
                    }
                }
            }
            if let Some(i) = target.iter().position(|v| !v.is_finite()) {
                bail!("frame {:?}: target value {i} is not finite", frame.name);
            }
            views.push(View {
                name: frame.name.clone(),
                camera: frame.camera(),
                target,
                labels: labels.clone(),
                split: frame.split,
            });
        }
        Ok(ComponentData {
            name: masks.info.name.clone(),
            kind: masks.info.kind,
            views,
            occluders: None,
            depth_points: Vec::new(),
        })
    }

    /// How this component's pixels are supervised.
    pub fn rule(&self) -> PixelRule {
        PixelRule {
            kind: self.kind,
            behind_occluders: self.occluders.is_some(),
        }
    }
}

/// How a component's pixels are supervised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelRule {
    pub kind: ComponentKind,
    /// The background trained behind frozen objects: the composite is supervised everywhere.
    pub behind_occluders: bool,
}

impl PixelRule {
    pub fn new(kind: ComponentKind) -> Self {
        PixelRule {
            kind,
            behind_occluders: false,
        }
    }

    /// A pixel's loss weight and whether its target is the background colour
    /// (instead of the image), from its label.
    #[inline]
    pub fn apply(&self, label: u8) -> (f32, bool) {
        match (label, self.kind) {
            (OWN, _) => (1.0, false),
            (OTHER, ComponentKind::Object) => (1.0, true),
            // IGNORE and unowned grey values: not supervised; for an object the
            // target is the background colour, what renders where it draws nothing.
            (_, ComponentKind::Object) => (0.0, true),
            (OTHER, ComponentKind::Background) if self.behind_occluders => (1.0, false),
            (_, ComponentKind::Background) => (0.0, false),
        }
    }
}

/// Pixel weights and targets of one view under background colour `b`.
pub fn supervision(view: &View, kind: ComponentKind, b: [f32; 3]) -> (Vec<f32>, Vec<f32>) {
    let (mut target, weights, from_background) = supervision_parts(view, PixelRule::new(kind));
    for p in (0..weights.len()).filter(|&p| from_background[p]) {
        target[3 * p..3 * p + 3].copy_from_slice(&b);
    }
    (target, weights)
}

/// The parts of [`supervision`] that do not depend on the background colour:
/// targets, weights, and which pixels take the background colour as target.
pub(crate) fn supervision_parts(view: &View, rule: PixelRule) -> (Vec<f32>, Vec<f32>, Vec<bool>) {
    let (weights, from_background) = view.labels.iter().map(|&l| rule.apply(l)).unzip();
    (view.target.clone(), weights, from_background)
}

/// What stays fixed about a view's supervision whatever the background colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewSummary {
    /// Bounding box of the pixels whose target is not the background colour.
    pub include: PixelRect,
    /// `Σ` of the pixel weights over the whole image.
    pub total_weight: f64,
}

impl ViewSummary {
    pub fn of(view: &View, rule: PixelRule) -> ViewSummary {
        let w = view.camera.width as usize;
        let (mut include, mut total_weight) = (PixelRect::default(), 0.0);
        for (p, &l) in view.labels.iter().enumerate() {
            let (weight, from_background) = rule.apply(l);
            total_weight += weight as f64;
            if !from_background {
                include = include.union(PixelRect::pixel(p, w));
            }
        }
        ViewSummary {
            include,
            total_weight,
        }
    }
}

/// Fills `target` (RGB) and `weights` for the pixels of `region` under
/// background colour `b`, reusing the buffers; returns the region's weight sum.
pub fn fill_region(
    view: &View,
    rule: PixelRule,
    b: [f32; 3],
    region: PixelRect,
    target: &mut Vec<f32>,
    weights: &mut Vec<f32>,
) -> f64 {
    target.clear();
    weights.clear();
    let w = view.camera.width as usize;
    let mut sum = 0.0;
    for y in region.y0 as usize..region.y1 as usize {
        for x in region.x0 as usize..region.x1 as usize {
            let p = y * w + x;
            let (weight, from_background) = rule.apply(view.labels[p]);
            weights.push(weight);
            sum += weight as f64;
            if from_background {
                target.extend_from_slice(&b);
            } else {
                target.extend_from_slice(&view.target[3 * p..3 * p + 3]);
            }
        }
    }
    sum
}
