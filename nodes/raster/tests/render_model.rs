//! `render_model` is the forward pass with the model's own σ and SH degree
//! over a uniform background.

mod common;

use common::*;
use objectsplat_raster::{CpuBackend, RenderBackend, RenderSettings, render_model};

#[test]
fn render_model_equals_the_forward_colour() {
    let (mut model, camera) = gradient_scene(3);
    model.sigma = 0.3;
    model.sh_degree = 2;
    let model = model.cast::<f32>();
    let img = render_model(&model, &camera, [0.2, 0.4, 0.6], 2).unwrap();
    let bg: Vec<f32> = (0..img.data.len())
        .map(|i| [0.2f32, 0.4, 0.6][i % 3])
        .collect();
    let settings = RenderSettings {
        sigma: 0.3,
        sh_degree: 2,
        ..Default::default()
    };
    let (out, _) = CpuBackend::new(1)
        .forward(&model, &camera, &settings, &bg)
        .unwrap();
    assert_eq!(
        (img.width, img.height, img.channels),
        (camera.width, camera.height, 3)
    );
    assert_eq!(img.data, out.color);
    assert!(out.face_pixel_count.iter().any(|&c| c > 0));
}
