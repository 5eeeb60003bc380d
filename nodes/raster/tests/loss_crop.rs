//! The photometric loss on a crop equals the whole image's when render and
//! target agree outside the crop's inner part (`CROP_MARGIN` pixels from its
//! border): same value, same gradient inside, and a whole-image gradient that
//! vanishes outside. Also: the row passes give bit-identical results for any
//! thread count, and asking for no gradient changes nothing but the gradient.

mod common;

use common::Lcg;
use objectsplat_raster::loss::{CROP_MARGIN, Dims, Normalization, PhotometricLoss};

fn rgb(width: usize, height: usize) -> Dims {
    Dims {
        width,
        height,
        channels: 3,
    }
}

/// A w×h scene whose target and render differ only inside `[x0, x1) × [y0, y1)`;
/// elsewhere both are the background colour `b` (what an object's view looks like).
fn scene(
    seed: u64,
    w: usize,
    h: usize,
    rect: [usize; 4],
    b: [f32; 3],
) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let mut r = Lcg(seed);
    let mut x = vec![0.0f32; w * h * 3];
    let mut y = vec![0.0f32; w * h * 3];
    let mut wt = vec![1.0f32; w * h];
    for py in 0..h {
        for px in 0..w {
            let p = py * w + px;
            let inside = px >= rect[0] && px < rect[2] && py >= rect[1] && py < rect[3];
            for c in 0..3 {
                x[3 * p + c] = if inside { r.unit() as f32 } else { b[c] };
                y[3 * p + c] = if inside { r.unit() as f32 } else { b[c] };
            }
            // Some unsupervised pixels, inside and outside.
            if (px * 7 + py * 3) % 11 == 0 {
                wt[p] = 0.0;
            }
        }
    }
    (x, y, wt)
}

fn crop(img: &[f32], w: usize, ch: usize, c: [usize; 4]) -> Vec<f32> {
    let mut v = Vec::new();
    for y in c[1]..c[3] {
        v.extend_from_slice(&img[(y * w + c[0]) * ch..(y * w + c[2]) * ch]);
    }
    v
}

#[test]
fn a_crop_gives_the_whole_images_loss_and_gradient() {
    let (w, h) = (90, 70);
    let m = CROP_MARGIN as usize;
    for (seed, rect) in [
        (1u64, [30, 20, 52, 41]),
        (2, [0, 0, 14, 9]),
        (3, [70, 50, 90, 70]),
        (4, [40, 30, 41, 31]),
    ] {
        let b = [0.3, 0.7, 0.1];
        let (x, y, wt) = scene(seed, w, h, rect, b);
        let c = [
            rect[0].saturating_sub(m),
            rect[1].saturating_sub(m),
            (rect[2] + m).min(w),
            (rect[3] + m).min(h),
        ];
        let total: f64 = wt.iter().map(|&v| v as f64).sum();
        let (cx, cy, cw) = (crop(&x, w, 3, c), crop(&y, w, 3, c), crop(&wt, w, 1, c));
        let inside: f64 = cw.iter().map(|&v| v as f64).sum();
        let mut full = PhotometricLoss::<f32>::new();
        let vf = full
            .evaluate(
                rgb(w, h),
                &x,
                &y,
                Some(&wt),
                Normalization::whole(total),
                0.2,
                true,
                2,
            )
            .unwrap();
        let mut part = PhotometricLoss::<f32>::new();
        let norm = Normalization {
            total_weight: total,
            outside_weight: total - inside,
        };
        let cdims = rgb(c[2] - c[0], c[3] - c[1]);
        let vc = part
            .evaluate(cdims, &cx, &cy, Some(&cw), norm, 0.2, true, 2)
            .unwrap();
        assert!(
            (vf.total - vc.total).abs() < 1e-6,
            "seed {seed}: loss {} vs {}",
            vf.total,
            vc.total
        );
        assert!((vf.ssim - vc.ssim).abs() < 1e-6 && (vf.l1 - vc.l1).abs() < 1e-7);
        let gf_in = crop(&full.grad, w, 3, c);
        let scale = gf_in.iter().fold(0.0f32, |a, g| a.max(g.abs()));
        assert!(scale > 0.0);
        for (i, (a, b)) in gf_in.iter().zip(&part.grad).enumerate() {
            assert!(
                (a - b).abs() <= 1e-5 * scale,
                "seed {seed}: gradient {i}: {a} vs {b}"
            );
        }
        // Outside the crop the whole image's gradient is float noise only.
        for py in 0..h {
            for px in 0..w {
                if px < c[0] || px >= c[2] || py < c[1] || py >= c[3] {
                    for ch in 0..3 {
                        let g = full.grad[(py * w + px) * 3 + ch];
                        assert!(g.abs() <= 1e-5 * scale, "seed {seed}: ({px}, {py}) {g}");
                    }
                }
            }
        }
    }
}

#[test]
fn thread_count_and_gradient_flag_change_nothing_else() {
    let (w, h) = (64, 45);
    let (x, y, wt) = scene(9, w, h, [5, 7, 60, 40], [0.5, 0.5, 0.5]);
    let dims = rgb(w, h);
    let norm = Normalization::whole(wt.iter().map(|&v| v as f64).sum());
    let mut one = PhotometricLoss::<f32>::new();
    let v1 = one
        .evaluate(dims, &x, &y, Some(&wt), norm, 0.2, true, 1)
        .unwrap();
    for threads in [2, 3] {
        let mut many = PhotometricLoss::<f32>::new();
        let v = many
            .evaluate(dims, &x, &y, Some(&wt), norm, 0.2, true, threads)
            .unwrap();
        assert_eq!(v, v1);
        let bits = |g: &[f32]| g.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&many.grad), bits(&one.grad));
        // The same object reused for a value-only call: same value, no gradient.
        let v_only = many
            .evaluate(dims, &x, &y, Some(&wt), norm, 0.2, false, threads)
            .unwrap();
        assert_eq!(v_only, v1);
        assert!(many.grad.is_empty());
    }
    // A crop with no pixels is all outside: zero L1, SSIM 1, loss 0.
    let mut empty = PhotometricLoss::<f32>::new();
    let v = empty
        .evaluate(
            rgb(0, 0),
            &[],
            &[],
            Some(&[]),
            Normalization {
                total_weight: 10.0,
                outside_weight: 10.0,
            },
            0.2,
            true,
            1,
        )
        .unwrap();
    assert_eq!((v.l1, v.ssim, v.total), (0.0, 1.0, 0.0));
}
