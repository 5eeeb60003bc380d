//! Unusable LPIPS weights and inputs give errors that say what is wrong.
mod common;

use common::{formula_tensors, image};
use objectsplat_core::Image;
use objectsplat_metrics::Lpips;

#[test]
fn missing_misshapen_or_negative_tensors_are_rejected() {
    let mut t = formula_tensors();
    t.remove("net.slice3.6.bias");
    let e = Lpips::from_tensors(t).unwrap_err().to_string();
    assert!(e.contains("net.slice3.6.bias"), "{e}");

    let mut t = formula_tensors();
    t.get_mut("net.slice1.0.weight").unwrap().shape = vec![64, 3, 121];
    let e = Lpips::from_tensors(t).unwrap_err().to_string();
    assert!(e.contains("shape"), "{e}");

    let mut t = formula_tensors();
    t.get_mut("lin2.model.1.weight").unwrap().data[5] = -0.1;
    let e = Lpips::from_tensors(t).unwrap_err().to_string();
    assert!(e.contains("negative"), "{e}");

    let mut t = formula_tensors();
    t.get_mut("net.slice2.3.weight").unwrap().data[7] = f32::NAN;
    assert!(Lpips::from_tensors(t).is_err());

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("junk.safetensors");
    std::fs::write(&path, b"not a safetensors file").unwrap();
    let e = format!("{:#}", Lpips::load(&path).unwrap_err());
    assert!(e.contains("junk.safetensors"), "{e}");
}

#[test]
fn too_small_or_non_rgb_inputs_are_rejected() {
    let net = Lpips::from_tensors(formula_tensors()).unwrap();
    let small = Image::new(30, 40, 3);
    assert!(net.distance(&small, &small).is_err());
    let grey = image("astronaut_grey.png");
    assert!(net.distance(&grey, &grey).is_err());
}
