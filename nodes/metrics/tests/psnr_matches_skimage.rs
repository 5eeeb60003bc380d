//! PSNR agrees with scikit-image (and its masked variant with numpy) on real photos.
mod common;

use common::{fixture_json, image};
use objectsplat_metrics::{Mask, psnr};

#[test]
fn psnr_matches_skimage_on_photo_pairs() {
    let fx = fixture_json("image_metrics.json");
    let mask = Mask::from_image(&image("region.png")).unwrap();
    let pairs = fx["pairs"].as_array().unwrap();
    assert!(pairs.len() >= 12);
    for p in pairs {
        let a = image(p["reference"].as_str().unwrap());
        let b = image(p["distorted"].as_str().unwrap());
        let full = psnr(&a, &b, None).unwrap();
        let masked = psnr(&a, &b, Some(&mask)).unwrap();
        let expect = |k: &str| p[k].as_f64().unwrap();
        assert!((full - expect("psnr")).abs() < 1e-6, "{p}: psnr {full}");
        assert!(
            (masked - expect("psnr_masked")).abs() < 1e-6,
            "{p}: masked psnr {masked}"
        );
    }
}

#[test]
fn identical_images_have_infinite_psnr() {
    let a = image("coffee.png");
    assert_eq!(psnr(&a, &a, None).unwrap(), f64::INFINITY);
}
