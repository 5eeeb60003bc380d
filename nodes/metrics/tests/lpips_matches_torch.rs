//! LPIPS-AlexNet agrees with the `lpips` package run with the same synthetic weights.
mod common;

use common::{fixture_json, formula_tensors, image};
use objectsplat_metrics::Lpips;

#[test]
fn lpips_matches_the_python_package_to_1e_5() {
    let net = Lpips::from_tensors(formula_tensors()).unwrap();
    let fx = fixture_json("lpips.json");
    let pairs = fx["pairs"].as_array().unwrap();
    assert!(pairs.len() >= 10);
    let mut saw_large = false;
    for p in pairs {
        let a = image(p["reference"].as_str().unwrap());
        let b = image(p["distorted"].as_str().unwrap());
        let ours = net.distance(&a, &b).unwrap();
        let theirs = p["lpips"].as_f64().unwrap();
        assert!(
            (ours.total - theirs).abs() < 1e-5,
            "{p}: ours {}",
            ours.total
        );
        for (k, layer) in p["layers"].as_array().unwrap().iter().enumerate() {
            let theirs = layer.as_f64().unwrap();
            assert!(
                (ours.layers[k] - theirs).abs() < 1e-6,
                "{}: layer {k} ours {}",
                p["distorted"],
                ours.layers[k]
            );
        }
        saw_large |= theirs > 0.1;
    }
    assert!(
        saw_large,
        "the fixtures should include a clearly different pair"
    );
}
