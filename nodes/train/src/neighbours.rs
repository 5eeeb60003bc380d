//! An object trained among its frozen neighbours (a table under the cup
//! resting on it): what they draw in each view, and the layer that puts it
//! over the targets.
//!
//! Where the object draws nothing, the composite of it and its neighbours is
//! their layer over what lies behind. That is the target of every pixel the
//! object does not own, so it may change nothing of its neighbours; and of
//! the own pixels surface completion adopted from the objects resting on it
//! (a table top under a cup, with inpainted colours), so it must stay behind
//! them there. Its other own pixels keep the image: a neighbour's layer does
//! not say whether it lies in front of the object or behind it.

use anyhow::{Result, bail};
use objectsplat_core::Camera;
use objectsplat_raster::backend::PixelRect;
use objectsplat_raster::{Model, RenderBackend, RenderOutput, RenderSettings, supersample};

/// What the frozen neighbours draw in one view, alone over black:
/// premultiplied colour and coverage per pixel of `rect`, 8 bits each (a
/// target's precision). Nothing is drawn outside `rect`.
pub struct NeighbourLayer {
    rect: PixelRect,
    rgba: Vec<[u8; 4]>,
}

impl NeighbourLayer {
    /// From a render over black: `color` RGB and `alpha` per pixel of `rect`.
    pub fn from_render(rect: PixelRect, color: &[f32], alpha: &[f32]) -> NeighbourLayer {
        let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        NeighbourLayer {
            rect,
            rgba: color
                .chunks_exact(3)
                .zip(alpha)
                .map(|(c, &a)| [byte(c[0]), byte(c[1]), byte(c[2]), byte(a)])
                .collect(),
        }
    }

    /// Premultiplied colour and coverage at pixel `(x, y)`; none outside the layer.
    #[inline]
    pub fn premultiplied(&self, x: u32, y: u32) -> Option<([f32; 3], f32)> {
        if !self.rect.contains(x, y) {
            return None;
        }
        let [r, g, b, a] = self.rgba[self.rect.index(x, y)].map(|v| v as f32 / 255.0);
        Some(([r, g, b], a))
    }

    /// The layer over colour `under` at pixel `(x, y)`.
    #[inline]
    pub fn over(&self, x: u32, y: u32, under: [f32; 3]) -> [f32; 3] {
        match self.premultiplied(x, y) {
            Some((c, a)) => {
                let t = 1.0 - a;
                [
                    c[0] + t * under[0],
                    c[1] + t * under[1],
                    c[2] + t * under[2],
                ]
            }
            None => under,
        }
    }
}

/// The neighbours `frozen` rendered alone over black from `camera` under
/// `settings` (its region: the pixels a step renders, which must cover every
/// pixel they draw) at `supersample²` samples per pixel, as the training
/// steps render them.
pub fn render_layer(
    backend: &dyn RenderBackend<f32>,
    frozen: &Model<f32>,
    camera: &Camera,
    settings: &RenderSettings,
    supersample: u32,
) -> Result<NeighbourLayer> {
    let settings = RenderSettings {
        sigma: frozen.sigma,
        sh_degree: frozen.sh_degree,
        ..settings.clone()
    };
    let (fine_camera, fine_settings) = supersample::fine_view(camera, &settings, supersample);
    let black = vec![0.0f32; 3 * fine_camera.width as usize * fine_camera.height as usize];
    let (fine, _) = backend.forward(frozen, &fine_camera, &fine_settings, &black)?;
    let out = if supersample > 1 {
        let mut coarse = RenderOutput::default();
        supersample::downsample_into(1, &fine, supersample, &mut coarse)?;
        coarse
    } else {
        fine
    };
    if !out.all_finite() {
        bail!("the render of the frozen neighbours is not finite");
    }
    Ok(NeighbourLayer::from_render(
        out.region, &out.color, &out.alpha,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::supervision::{PixelRule, View, fill_region, supervision_parts};
    use objectsplat_core::component::{IGNORE, OTHER, OWN};
    use objectsplat_core::{ComponentKind, LabelRuns, Split};

    /// A 6×4 view: OWN in the left half, IGNORE in the last row, OTHER
    /// elsewhere; image colour (x/8, y/8, 0.5); completion adopted its pixels
    /// (2, 0) and (2, 1). Its neighbours cover the middle columns 2..5 of rows
    /// 0..3 with colour (0.8, 0.4, 0.2) at coverage 0.5 (premultiplied: half
    /// of it), nothing elsewhere.
    fn fixture() -> (View, NeighbourLayer) {
        let (w, h) = (6u32, 4u32);
        let camera = Camera::look_at(
            w,
            h,
            5.0,
            5.0,
            glam::DVec3::new(0.0, 0.0, -2.0),
            glam::DVec3::ZERO,
            glam::DVec3::Y,
        );
        let labels: Vec<u8> = (0..w * h)
            .map(|p| match (p % w, p / w) {
                (_, 3) => IGNORE,
                (x, _) if x < 3 => OWN,
                _ => OTHER,
            })
            .collect();
        let target: Vec<f32> = (0..w * h)
            .flat_map(|p| [(p % w) as f32 / 8.0, (p / w) as f32 / 8.0, 0.5])
            .collect();
        let mut view = View::from_planes("v", camera, &target, &labels, Split::Train).unwrap();
        let adopted: Vec<u8> = (0..w * h).map(|p| u8::from(p == 2 || p == 8)).collect();
        view.completed = Some(LabelRuns::from_plane(w, h, &adopted).unwrap());
        let rect = PixelRect {
            x0: 2,
            y0: 0,
            x1: 5,
            y1: 3,
        };
        let n = rect.pixels();
        let color: Vec<f32> = (0..n).flat_map(|_| [0.4, 0.2, 0.1]).collect();
        (
            view,
            NeighbourLayer::from_render(rect, &color, &vec![0.5; n]),
        )
    }

    /// An object's targets and weights over the whole fixture view under `b`.
    fn filled(view: &View, layer: &NeighbourLayer, b: [f32; 3]) -> (Vec<f32>, Vec<f32>) {
        let (mut target, mut weights, mut labels) = (Vec::new(), Vec::new(), Vec::new());
        let full = PixelRect {
            x0: 0,
            y0: 0,
            x1: 6,
            y1: 4,
        };
        let rule = PixelRule::new(ComponentKind::Object);
        fill_region(
            view,
            rule,
            b,
            Some(layer),
            full,
            &mut target,
            &mut weights,
            &mut labels,
        );
        (target, weights)
    }

    #[test]
    fn foreign_and_completed_targets_take_the_neighbours_layer() {
        let (view, layer) = fixture();
        let b = [0.1f32, 0.9, 0.3];
        let (target, weights) = filled(&view, &layer, b);
        // 8-bit layer: 0.4 → 102/255, 0.5 → 128/255.
        let (c, a) = ([102.0 / 255.0, 51.0 / 255.0, 26.0 / 255.0], 128.0 / 255.0);
        for y in 0..4u32 {
            for x in 0..6u32 {
                let p = (y * 6 + x) as usize;
                let under = if x < 3 && y < 3 {
                    [x as f32 / 8.0, y as f32 / 8.0, 0.5]
                } else {
                    b
                };
                let own = x < 3 && y < 3;
                let adopted = own && x == 2 && y < 2;
                let covered = (2..5).contains(&x) && y < 3 && (!own || adopted);
                for k in 0..3 {
                    let want = if covered {
                        c[k] + (1.0 - a) * under[k]
                    } else {
                        under[k]
                    };
                    let got = target[3 * p + k];
                    assert!(
                        (got - want).abs() < 1e-6,
                        "({x}, {y})[{k}]: {got} vs {want}"
                    );
                }
                assert_eq!(weights[p], if y == 3 { 0.0 } else { 1.0 });
            }
        }
    }

    /// The device's planes (a fixed part plus the background colour times a
    /// share) make the same targets as the host's fill, for any background.
    #[test]
    fn the_device_planes_make_the_host_targets() {
        let (view, layer) = fixture();
        let rule = PixelRule::new(ComponentKind::Object);
        let planes = supervision_parts(&view, rule, Some(&layer));
        for b in [[0.0f32; 3], [1.0; 3], [0.25, 0.5, 0.75]] {
            let (target, weights) = filled(&view, &layer, b);
            for p in 0..24 {
                for k in 0..3 {
                    let device = if planes.from_background[p] {
                        planes.target[3 * p + k] + planes.background_share[p] * b[k]
                    } else {
                        planes.target[3 * p + k]
                    };
                    assert!((device - target[3 * p + k]).abs() < 1e-6, "pixel {p}");
                }
                assert_eq!(planes.weights[p], weights[p]);
            }
        }
    }
}
