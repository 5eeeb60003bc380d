//! Helpers shared by the integration tests: fixture paths and the synthetic LPIPS weights.
#![allow(dead_code)]

use objectsplat_core::Image;
use objectsplat_metrics::lpips::{LAYERS, NamedTensor};
use std::collections::BTreeMap;
use std::path::PathBuf;

pub fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

pub fn fixture_json(name: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(fixture(name)).unwrap();
    serde_json::from_str(&text).unwrap()
}

pub fn image(name: &str) -> Image {
    Image::load(&fixture(&format!("images/{name}"))).unwrap()
}

/// Raw little-endian f64 N×3 points, as make_fscore_fixtures.py writes them.
pub fn points(name: &str) -> Vec<[f64; 3]> {
    let bytes = std::fs::read(fixture(&format!("points/{name}"))).unwrap();
    bytes
        .chunks_exact(24)
        .map(|c| {
            std::array::from_fn(|k| f64::from_le_bytes(c[k * 8..k * 8 + 8].try_into().unwrap()))
        })
        .collect()
}

/// Tensor names in the order lpips_formula.py numbers them.
pub fn formula_names() -> Vec<String> {
    let mut names: Vec<String> = LAYERS
        .iter()
        .map(|l| format!("{}.weight", l.conv_key))
        .collect();
    names.extend(LAYERS.iter().map(|l| format!("{}.bias", l.conv_key)));
    names.extend((0..5).map(|i| format!("lin{i}.model.1.weight")));
    names
}

/// u in [0, 1) for tensor `t`, element `i` (murmur3 finaliser, see lpips_formula.py).
fn uniform(t: u32, i: u32) -> f64 {
    let mut x = i
        .wrapping_mul(0x9E37_79B1)
        .wrapping_add(t.wrapping_mul(0x85EB_CA77))
        .wrapping_add(0x1656_67B1);
    x ^= x >> 16;
    x = x.wrapping_mul(0x85EB_CA6B);
    x ^= x >> 13;
    x = x.wrapping_mul(0xC2B2_AE35);
    x ^= x >> 16;
    x as f64 / 4_294_967_296.0
}

/// The synthetic weights of lpips_formula.py, bit for bit.
pub fn formula_tensors() -> BTreeMap<String, NamedTensor> {
    let names = formula_names();
    let index = |name: &str| names.iter().position(|n| n == name).unwrap() as u32;
    let mut out = BTreeMap::new();
    for (k, l) in LAYERS.iter().enumerate() {
        let (o, c, ks) = (l.out_channels, l.in_channels, l.kernel);
        let scale = (6.0 / (c * ks * ks) as f64).sqrt();
        let name = format!("{}.weight", l.conv_key);
        let t = index(&name);
        let data = (0..o * c * ks * ks)
            .map(|i| ((2.0 * uniform(t, i as u32) - 1.0) * scale) as f32)
            .collect();
        out.insert(
            name,
            NamedTensor {
                shape: vec![o, c, ks, ks],
                data,
            },
        );
        let name = format!("{}.bias", l.conv_key);
        let t = index(&name);
        let data = (0..o)
            .map(|i| ((2.0 * uniform(t, i as u32) - 1.0) * 0.1) as f32)
            .collect();
        out.insert(
            name,
            NamedTensor {
                shape: vec![o],
                data,
            },
        );
        let name = format!("lin{k}.model.1.weight");
        let t = index(&name);
        let data = (0..o)
            .map(|i| (uniform(t, i as u32) * 0.2) as f32)
            .collect();
        out.insert(
            name,
            NamedTensor {
                shape: vec![1, o, 1, 1],
                data,
            },
        );
    }
    out
}
