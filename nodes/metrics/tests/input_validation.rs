//! Malformed inputs to the image metrics are errors naming the problem, never panics or NaN.
use objectsplat_core::Image;
use objectsplat_metrics::{Mask, SsimMode, psnr, ssim};

#[test]
fn mismatched_shapes_non_finite_values_and_bad_masks_are_errors() {
    let a = Image::new(20, 16, 3);
    let b = Image::new(20, 15, 3);
    assert!(
        psnr(&a, &b, None)
            .unwrap_err()
            .to_string()
            .contains("shape")
    );
    assert!(ssim(&a, &b, SsimMode::Gs3d, None).is_err());

    let mut nan = a.clone();
    nan.set(3, 2, 1, f32::NAN);
    let e = ssim(&a, &nan, SsimMode::Gs3d, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("(3, 2)"), "{e}");

    let wrong_size = Mask::new(4, 4, vec![true; 16]).unwrap();
    assert!(psnr(&a, &a, Some(&wrong_size)).is_err());
    let empty = Mask::new(20, 16, vec![false; 320]).unwrap();
    assert!(psnr(&a, &a, Some(&empty)).is_err());
    assert!(ssim(&a, &a, SsimMode::Gs3d, Some(&empty)).is_err());
    assert!(Mask::new(20, 16, vec![true; 3]).is_err());

    let tiny = Image::new(8, 8, 1);
    assert!(ssim(&tiny, &tiny, SsimMode::Cropped, None).is_err());
    assert_eq!(ssim(&tiny, &tiny, SsimMode::Gs3d, None).unwrap(), 1.0);
}
