//! SSIM agrees with scikit-image (cropped convention) and a numpy 3DGS SSIM
//! (zero padding), unmasked and masked, on real photos.
mod common;

use common::{fixture_json, image};
use objectsplat_metrics::{Mask, SsimMode, ssim};

#[test]
fn ssim_matches_skimage_and_3dgs_on_photo_pairs() {
    let fx = fixture_json("image_metrics.json");
    let mask = Mask::from_image(&image("region.png")).unwrap();
    for p in fx["pairs"].as_array().unwrap() {
        let a = image(p["reference"].as_str().unwrap());
        let b = image(p["distorted"].as_str().unwrap());
        let cases = [
            ("ssim_cropped", SsimMode::Cropped, None),
            ("ssim_cropped_masked", SsimMode::Cropped, Some(&mask)),
            ("ssim_gs3d", SsimMode::Gs3d, None),
            ("ssim_gs3d_masked", SsimMode::Gs3d, Some(&mask)),
        ];
        for (key, mode, m) in cases {
            let ours = ssim(&a, &b, mode, m).unwrap();
            let theirs = p[key].as_f64().unwrap();
            assert!(
                (ours - theirs).abs() < 1e-6,
                "{} vs {}: {key} ours {ours} oracle {theirs}",
                p["reference"],
                p["distorted"]
            );
        }
    }
}

#[test]
fn all_valid_mask_gives_the_unmasked_value() {
    let a = image("chelsea.png");
    let b = image("chelsea_jpeg.png");
    let all = Mask::new(a.width, a.height, vec![true; a.pixel_count()]).unwrap();
    for mode in [SsimMode::Gs3d, SsimMode::Cropped] {
        let plain = ssim(&a, &b, mode, None).unwrap();
        assert!((ssim(&a, &b, mode, Some(&all)).unwrap() - plain).abs() < 1e-12);
    }
    assert!((ssim(&a, &a, SsimMode::Gs3d, None).unwrap() - 1.0).abs() < 1e-12);
}
