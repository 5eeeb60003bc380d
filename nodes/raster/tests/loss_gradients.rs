//! L1, SSIM and the combined photometric loss: gradients with respect to the
//! rendered image agree with f64 central differences, and per-pixel weights
//! behave as documented (weight 0 = pixel not supervised).

mod common;

use common::Lcg;
use objectsplat_raster::loss::{Dims, LossGrad, l1, photometric, ssim};

fn images(seed: u64, dims: Dims) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut r = Lcg(seed);
    let n = dims.width * dims.height;
    let x = (0..n * dims.channels).map(|_| r.unit()).collect();
    let y = (0..n * dims.channels).map(|_| r.unit()).collect();
    let w = (0..n)
        .map(|i| if i % 5 == 0 { 0.0 } else { r.unit() })
        .collect();
    (x, y, w)
}

type LossFn = fn(Dims, &[f64], &[f64], Option<&[f64]>) -> anyhow::Result<LossGrad<f64>>;

fn check(name: &str, f: LossFn, weighted: bool) {
    let dims = Dims::rgb(15, 12);
    let (mut x, y, w) = images(3, dims);
    let weights = weighted.then_some(w.as_slice());
    let g = f(dims, &x, &y, weights).unwrap().grad;
    let h = 1e-6;
    let (mut err2, mut norm2) = (0.0, 0.0);
    for i in 0..x.len() {
        let orig = x[i];
        x[i] = orig + h;
        let p = f(dims, &x, &y, weights).unwrap().value;
        x[i] = orig - h;
        let m = f(dims, &x, &y, weights).unwrap().value;
        x[i] = orig;
        let fd = (p - m) / (2.0 * h);
        err2 += (fd - g[i]).powi(2);
        norm2 += g[i] * g[i];
        // Neither term learns anything about an unsupervised pixel, SSIM included:
        // its neighbours' windows see its target, not its render.
        if weighted && i / 3 % 5 == 0 {
            assert_eq!(g[i], 0.0, "unsupervised pixel has a {name} gradient");
            assert_eq!(fd, 0.0, "the {name} value depends on an unsupervised pixel");
        }
    }
    assert!(norm2 > 0.0);
    let rel = (err2 / norm2).sqrt();
    assert!(
        rel < 1e-6,
        "{name} (weighted: {weighted}): relative error {rel:.3e}"
    );
}

#[test]
fn l1_gradient_matches_finite_differences() {
    check("L1", l1, false);
    check("L1", l1, true);
}

#[test]
fn ssim_gradient_matches_finite_differences() {
    check("SSIM", ssim, false);
    check("SSIM", ssim, true);
}

#[test]
fn photometric_gradient_matches_finite_differences() {
    let combined: LossFn = |d, x, y, w| photometric(d, x, y, w, 0.2);
    check("0.8 L1 + 0.2 (1 - SSIM)", combined, false);
    check("0.8 L1 + 0.2 (1 - SSIM)", combined, true);
}

#[test]
fn weighted_l1_is_the_weighted_mean_of_absolute_errors() {
    let dims = Dims::rgb(7, 5);
    let (x, y, w) = images(9, dims);
    let got = l1(dims, &x, &y, Some(&w)).unwrap().value;
    let mut num = 0.0;
    for p in 0..35 {
        for c in 0..3 {
            num += w[p] * (x[p * 3 + c] - y[p * 3 + c]).abs();
        }
    }
    let want = num / (3.0 * w.iter().sum::<f64>());
    assert!((got - want).abs() < 1e-14);
    let plain = l1(dims, &x, &y, None).unwrap().value;
    let mean = x.iter().zip(&y).map(|(a, b)| (a - b).abs()).sum::<f64>() / x.len() as f64;
    assert!((plain - mean).abs() < 1e-14);
}

#[test]
fn all_zero_weights_give_zero_loss_and_gradient() {
    let dims = Dims::rgb(6, 4);
    let (x, y, _) = images(1, dims);
    let zeros = vec![0.0; 24];
    let l = photometric(dims, &x, &y, Some(&zeros), 0.2).unwrap();
    assert_eq!(l.value, 0.0);
    assert!(l.grad.iter().all(|&g| g == 0.0));
}

#[test]
fn invalid_loss_inputs_are_rejected_with_a_message() {
    let dims = Dims::rgb(6, 4);
    let (mut x, y, mut w) = images(1, dims);
    w[3] = -1.0;
    let e = l1(dims, &x, &y, Some(&w)).unwrap_err().to_string();
    assert!(e.contains("weight") && e.contains("negative"), "{e}");
    x[7] = f64::NAN;
    let e = ssim(dims, &x, &y, None).unwrap_err().to_string();
    assert!(e.contains("rendered image") && e.contains("7"), "{e}");
    let e = l1(dims, &x[1..], &y, None).unwrap_err().to_string();
    assert!(e.contains("expected"), "{e}");
}
