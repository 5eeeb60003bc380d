//! A safetensors file laid out exactly as the Python export writes it loads and
//! gives the package's LPIPS values.
//!
//! The committed header (`lpips_alex_header.bin`) is the first bytes of the file
//! `make_lpips_fixtures.py` exported; the tensor bytes are the formula weights, so
//! the rebuilt file is checked against the exported file's SHA-256 before use.
mod common;

use common::{fixture, fixture_json, formula_tensors, image};
use objectsplat_metrics::Lpips;
use objectsplat_metrics::lpips::{DEFAULT_SCALE, DEFAULT_SHIFT};
use sha2::{Digest, Sha256};

fn rebuild_exported_file() -> Vec<u8> {
    let header = std::fs::read(fixture("lpips_alex_header.bin")).unwrap();
    let n = u64::from_le_bytes(header[..8].try_into().unwrap()) as usize;
    let meta: serde_json::Value = serde_json::from_slice(&header[8..8 + n]).unwrap();
    let mut tensors = formula_tensors();
    let scaling = |v: [f32; 3]| objectsplat_metrics::lpips::NamedTensor {
        shape: vec![1, 3, 1, 1],
        data: v.to_vec(),
    };
    tensors.insert("scaling_layer.shift".into(), scaling(DEFAULT_SHIFT));
    tensors.insert("scaling_layer.scale".into(), scaling(DEFAULT_SCALE));
    let mut file = header.clone();
    let body_len = meta
        .as_object()
        .unwrap()
        .values()
        .filter_map(|t| t["data_offsets"][1].as_u64())
        .max()
        .unwrap();
    file.resize(header.len() + body_len as usize, 0);
    for (name, info) in meta.as_object().unwrap() {
        if name == "__metadata__" {
            continue;
        }
        assert_eq!(info["dtype"], "F32");
        let t = &tensors[name];
        let shape: Vec<usize> = info["shape"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap() as usize)
            .collect();
        assert_eq!(shape, t.shape, "{name}");
        let start = header.len() + info["data_offsets"][0].as_u64().unwrap() as usize;
        for (i, v) in t.data.iter().enumerate() {
            file[start + 4 * i..start + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
        }
    }
    file
}

#[test]
fn exported_safetensors_file_loads_and_matches_the_package() {
    let fx = fixture_json("lpips.json");
    let bytes = rebuild_exported_file();
    assert_eq!(bytes.len() as u64, fx["safetensors_len"].as_u64().unwrap());
    let digest: String = Sha256::digest(&bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    assert_eq!(
        digest,
        fx["safetensors_sha256"].as_str().unwrap(),
        "rebuilt file differs from the exported one"
    );

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("alex.safetensors");
    std::fs::write(&path, &bytes).unwrap();
    let net = Lpips::load(&path).unwrap();
    let p = &fx["pairs"][0];
    let ours = net
        .distance(
            &image(p["reference"].as_str().unwrap()),
            &image(p["distorted"].as_str().unwrap()),
        )
        .unwrap();
    assert!((ours.total - p["lpips"].as_f64().unwrap()).abs() < 1e-5);
}
