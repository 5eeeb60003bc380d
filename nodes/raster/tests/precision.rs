//! The f32 path (used for training) agrees with the f64 path (validated by
//! finite differences) on outputs and gradients, up to single precision.

mod common;

use common::*;
use objectsplat_raster::{
    CpuBackend, Model, ModelGrads, OutputGrads, Real, RenderBackend, RenderOutput,
};

fn run<R: Real>(
    model: &Model<R>,
    camera: &objectsplat_core::Camera,
    bg: &[R],
    g: &[R],
) -> (RenderOutput<R>, ModelGrads<R>) {
    let backend = CpuBackend::new(2);
    let (out, saved) = backend
        .forward(model, camera, &settings(0.4, 3), bg)
        .expect("valid scene");
    let grads = backend
        .backward(
            model,
            &saved,
            &OutputGrads {
                color: g,
                alpha: None,
                depth: Some(&g[..g.len() / 3]),
                median_depth: None,
            },
        )
        .expect("valid");
    (out, grads)
}

fn flat<R: Real>(g: &ModelGrads<R>) -> Vec<f64> {
    let mut v: Vec<f64> = g.vertices.iter().flatten().map(|x| x.f64()).collect();
    v.extend(g.sh.iter().flatten().flatten().map(|x| x.f64()));
    v.extend(g.opacity_logits.iter().map(|x| x.f64()));
    v.extend(g.background.iter().map(|x| x.f64()));
    v
}

#[test]
fn f32_and_f64_paths_agree() {
    let (model, camera) = gradient_scene(41);
    let mut rng = Rng(8);
    let bg = random_background(&mut rng, &camera);
    let g: Vec<f64> = (0..bg.len()).map(|_| rng.uniform(-1.0, 1.0)).collect();
    let (out64, g64) = run(&model, &camera, &bg, &g);
    let to32 = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
    let (out32, g32) = run(&model.cast::<f32>(), &camera, &to32(&bg), &to32(&g));
    assert_eq!(out32.face_pixel_count, out64.face_pixel_count);
    for (a, b) in out32.color.iter().zip(&out64.color) {
        assert!((*a as f64 - b).abs() < 2e-5, "colour {a} vs {b}");
    }
    for (a, b) in out32.depth.iter().zip(&out64.depth) {
        assert!((*a as f64 - b).abs() < 1e-4, "depth {a} vs {b}");
    }
    let (a, b) = (flat(&g32), flat(&g64));
    let err: f64 = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt();
    let norm: f64 = b.iter().map(|y| y * y).sum::<f64>().sqrt();
    assert!(
        norm > 0.0 && err / norm < 1e-4,
        "f32 gradients deviate: relative {:.3e}",
        err / norm
    );
}
