//! LPIPS v0.1 with the AlexNet backbone (Zhang et al. 2018), weights from a file.
//!
//! Network: inputs in [0, 1] are mapped to [−1, 1], shifted and scaled per channel
//! (the "scaling layer"), and run through torchvision's AlexNet `features`
//! (conv 11×11/4 pad 2 → 64, max-pool 3/2, conv 5×5 pad 2 → 192, max-pool 3/2,
//! conv 3×3 → 384, conv 3×3 → 256, conv 3×3 → 256, each conv followed by ReLU).
//! At each of the five ReLU outputs, every feature vector is divided by its
//! channel norm (+1e-10), the two images' features are subtracted and squared, a
//! non-negative 1×1 linear head reduces the channels, and the result is averaged
//! over space. LPIPS is the sum over the five layers.
//!
//! Weights file: safetensors (see [`weights`]) with tensor names as in the torch
//! `lpips.LPIPS(net='alex').state_dict()`; `tests/fixtures/export_lpips_weights.py`
//! writes one.

mod ops;
pub mod weights;

use ops::{Conv2d, Tensor};
pub use weights::{LAYERS, NamedTensor};

use crate::validate::check_pair;
use anyhow::{Context, Result, bail};
use objectsplat_core::Image;
use std::collections::BTreeMap;
use std::path::Path;

/// LPIPS v0.1 scaling-layer constants (used when the file does not carry them).
pub const DEFAULT_SHIFT: [f32; 3] = [-0.030, -0.088, -0.188];
pub const DEFAULT_SCALE: [f32; 3] = [0.458, 0.448, 0.450];
const NORM_EPS: f64 = 1e-10;
/// The smallest side AlexNet's five layers accept (each stage must leave ≥ 1 pixel).
pub const MIN_SIDE: usize = 31;

/// The loaded LPIPS network.
#[derive(Debug, Clone)]
pub struct Lpips {
    convs: [Conv2d; 5],
    heads: [Vec<f32>; 5],
    shift: [f32; 3],
    scale: [f32; 3],
}

/// LPIPS and its five per-layer terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LpipsValue {
    pub total: f64,
    pub layers: [f64; 5],
}

impl Lpips {
    /// Reads a safetensors weights file.
    pub fn load(path: &Path) -> Result<Lpips> {
        let bytes = std::fs::read(path)
            .with_context(|| format!("{}: cannot read LPIPS weights", path.display()))?;
        Self::from_safetensors(&bytes)
            .with_context(|| format!("{}: not usable LPIPS AlexNet weights", path.display()))
    }

    pub fn from_safetensors(bytes: &[u8]) -> Result<Lpips> {
        Self::from_tensors(weights::read_safetensors(bytes)?)
    }

    /// Builds the network from named tensors (torch `state_dict` names); tensors
    /// not belonging to LPIPS-AlexNet are ignored.
    pub fn from_tensors(mut tensors: BTreeMap<String, NamedTensor>) -> Result<Lpips> {
        let mut convs = Vec::with_capacity(5);
        let mut heads = Vec::with_capacity(5);
        for (i, layer) in LAYERS.iter().enumerate() {
            let (o, c, k) = (layer.out_channels, layer.in_channels, layer.kernel);
            let weight = take(
                &mut tensors,
                &format!("{}.weight", layer.conv_key),
                &[o, c, k, k],
            )?;
            let bias = take(&mut tensors, &format!("{}.bias", layer.conv_key), &[o])?;
            convs.push(Conv2d {
                out_channels: o,
                in_channels: c,
                kernel: k,
                stride: layer.stride,
                padding: layer.padding,
                weight,
                bias,
            });
            let head_name = format!("lin{i}.model.1.weight");
            let head = take(&mut tensors, &head_name, &[1, o, 1, 1])?;
            if let Some(j) = head.iter().position(|&v| v < 0.0) {
                bail!(
                    "linear head {head_name:?} has a negative weight at channel {j}; LPIPS heads are non-negative"
                );
            }
            heads.push(head);
        }
        let mut constant = |name: &str, default: [f32; 3]| -> Result<[f32; 3]> {
            if !tensors.contains_key(name) {
                return Ok(default);
            }
            let v = take(&mut tensors, name, &[1, 3, 1, 1])?;
            Ok([v[0], v[1], v[2]])
        };
        let shift = constant("scaling_layer.shift", DEFAULT_SHIFT)?;
        let scale = constant("scaling_layer.scale", DEFAULT_SCALE)?;
        if scale.contains(&0.0) {
            bail!("scaling_layer.scale has a zero entry");
        }
        // Invariant: exactly five entries were pushed above.
        let convs: [Conv2d; 5] = convs.try_into().expect("five conv layers");
        let heads: [Vec<f32>; 5] = heads.try_into().expect("five heads");
        Ok(Lpips {
            convs,
            heads,
            shift,
            scale,
        })
    }

    /// LPIPS distance between two RGB images with values in [0, 1] (lower = more similar).
    pub fn distance(&self, a: &Image, b: &Image) -> Result<LpipsValue> {
        check_pair(a, b)?;
        if a.channels != 3 {
            bail!("LPIPS needs RGB images, got {} channels", a.channels);
        }
        let (w, h) = (a.width as usize, a.height as usize);
        if w < MIN_SIDE || h < MIN_SIDE {
            bail!("LPIPS (AlexNet) needs images of at least {MIN_SIDE}×{MIN_SIDE}, got {w}×{h}");
        }
        let fa = self.features(a);
        let fb = self.features(b);
        let mut layers = [0.0; 5];
        for (i, ((x, y), head)) in fa.iter().zip(&fb).zip(&self.heads).enumerate() {
            layers[i] = layer_distance(x, y, head);
        }
        Ok(LpipsValue {
            total: layers.iter().sum(),
            layers,
        })
    }

    /// The five tapped ReLU outputs of AlexNet for one image.
    fn features(&self, img: &Image) -> Vec<Tensor> {
        let (w, h) = (img.width as usize, img.height as usize);
        let mut data = vec![0.0f32; 3 * w * h];
        for (c, plane) in data.chunks_exact_mut(w * h).enumerate() {
            for (i, v) in plane.iter_mut().enumerate() {
                // Same f32 operation order as lpips: 2x − 1, then (x − shift) / scale.
                let x = 2.0 * img.data[i * 3 + c] - 1.0;
                *v = (x - self.shift[c]) / self.scale[c];
            }
        }
        let mut x = Tensor {
            channels: 3,
            height: h,
            width: w,
            data,
        };
        let mut taps = Vec::with_capacity(5);
        for (i, conv) in self.convs.iter().enumerate() {
            if i == 1 || i == 2 {
                x = ops::max_pool_3x3_s2(&x);
            }
            x = conv.forward_relu(&x);
            taps.push(x.clone());
        }
        taps
    }
}

/// Removes a tensor, checking its shape and values.
fn take(
    tensors: &mut BTreeMap<String, NamedTensor>,
    name: &str,
    shape: &[usize],
) -> Result<Vec<f32>> {
    let t = tensors
        .remove(name)
        .with_context(|| format!("missing tensor {name:?}"))?;
    if t.shape != shape {
        bail!(
            "tensor {name:?} has shape {:?}, expected {:?}",
            t.shape,
            shape
        );
    }
    if let Some(i) = t.data.iter().position(|v| !v.is_finite()) {
        bail!("tensor {name:?} has a non-finite value at flat index {i}");
    }
    Ok(t.data)
}

/// Spatial mean of the head-weighted squared difference of channel-normalised features.
fn layer_distance(x: &Tensor, y: &Tensor, head: &[f32]) -> f64 {
    let n = x.height * x.width;
    let mut norm_x = vec![0.0f64; n];
    let mut norm_y = vec![0.0f64; n];
    for c in 0..x.channels {
        for p in 0..n {
            norm_x[p] += (x.data[c * n + p] as f64).powi(2);
            norm_y[p] += (y.data[c * n + p] as f64).powi(2);
        }
    }
    let inv = |v: &mut Vec<f64>| v.iter_mut().for_each(|s| *s = 1.0 / (s.sqrt() + NORM_EPS));
    inv(&mut norm_x);
    inv(&mut norm_y);
    let mut sum = 0.0;
    for (c, &wc) in head.iter().enumerate() {
        let wc = wc as f64;
        for p in 0..n {
            let d = x.data[c * n + p] as f64 * norm_x[p] - y.data[c * n + p] as f64 * norm_y[p];
            sum += wc * d * d;
        }
    }
    sum / n as f64
}
