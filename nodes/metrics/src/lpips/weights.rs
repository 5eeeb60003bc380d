//! Reading LPIPS weights from safetensors.
//!
//! Format: a safetensors file whose tensors are named as in torch's
//! `lpips.LPIPS(net='alex').state_dict()`:
//! - `net.slice1.0.{weight,bias}` `[64,3,11,11]`, `net.slice2.3.*` `[192,64,5,5]`,
//!   `net.slice3.6.*` `[384,192,3,3]`, `net.slice4.8.*` `[256,384,3,3]`,
//!   `net.slice5.10.*` `[256,256,3,3]` (biases `[out]`);
//! - `lin{0..4}.model.1.weight` `[1,C,1,1]`, non-negative;
//! - optional `scaling_layer.shift` / `scaling_layer.scale` `[1,3,1,1]`.
//!
//! dtypes F32, F16, BF16 and F64 are accepted (converted to f32); other tensors are ignored.

use anyhow::{Context, Result, bail};
use safetensors::{Dtype, SafeTensors};
use std::collections::BTreeMap;

/// One AlexNet conv layer as lpips names and shapes it.
#[derive(Debug, Clone, Copy)]
pub struct LayerSpec {
    pub conv_key: &'static str,
    pub in_channels: usize,
    pub out_channels: usize,
    pub kernel: usize,
    pub stride: usize,
    pub padding: usize,
}

/// torchvision `alexnet().features` conv layers under lpips's `slice1..5` names.
pub const LAYERS: [LayerSpec; 5] = [
    LayerSpec {
        conv_key: "net.slice1.0",
        in_channels: 3,
        out_channels: 64,
        kernel: 11,
        stride: 4,
        padding: 2,
    },
    LayerSpec {
        conv_key: "net.slice2.3",
        in_channels: 64,
        out_channels: 192,
        kernel: 5,
        stride: 1,
        padding: 2,
    },
    LayerSpec {
        conv_key: "net.slice3.6",
        in_channels: 192,
        out_channels: 384,
        kernel: 3,
        stride: 1,
        padding: 1,
    },
    LayerSpec {
        conv_key: "net.slice4.8",
        in_channels: 384,
        out_channels: 256,
        kernel: 3,
        stride: 1,
        padding: 1,
    },
    LayerSpec {
        conv_key: "net.slice5.10",
        in_channels: 256,
        out_channels: 256,
        kernel: 3,
        stride: 1,
        padding: 1,
    },
];

#[derive(Debug, Clone, PartialEq)]
pub struct NamedTensor {
    pub shape: Vec<usize>,
    pub data: Vec<f32>,
}

/// All floating-point tensors of a safetensors file, converted to f32.
pub fn read_safetensors(bytes: &[u8]) -> Result<BTreeMap<String, NamedTensor>> {
    let file = SafeTensors::deserialize(bytes).context("not a safetensors file")?;
    let mut out = BTreeMap::new();
    for name in file.names() {
        let view = file
            .tensor(name)
            .with_context(|| format!("cannot read tensor {name:?}"))?;
        let raw = view.data();
        let data: Vec<f32> = match view.dtype() {
            Dtype::F32 => raw
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect(),
            Dtype::F64 => raw
                .chunks_exact(8)
                .map(|b| {
                    f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]) as f32
                })
                .collect(),
            Dtype::F16 => raw
                .chunks_exact(2)
                .map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32())
                .collect(),
            Dtype::BF16 => raw
                .chunks_exact(2)
                .map(|b| half::bf16::from_le_bytes([b[0], b[1]]).to_f32())
                .collect(),
            _ => continue,
        };
        let shape = view.shape().to_vec();
        if data.len() != shape.iter().product::<usize>() {
            bail!(
                "tensor {name:?}: {} values for shape {:?}",
                data.len(),
                shape
            );
        }
        out.insert(name.to_string(), NamedTensor { shape, data });
    }
    Ok(out)
}
