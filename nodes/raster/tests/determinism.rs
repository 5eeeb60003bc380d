//! Forward outputs and every gradient are bitwise identical for 1, 2 and 3
//! threads: per-tile work is independent, per-face partials are summed in
//! tile order and per-vertex gradients gathered in face order.

mod common;

use common::*;
use objectsplat_raster::{CpuBackend, OutputGrads, RenderBackend, RenderSettings};

#[test]
fn results_are_bitwise_identical_for_any_thread_count() {
    let (model, camera, bg) = random_soup_f32(17, 3000, 96, 72);
    let settings = RenderSettings {
        sigma: 0.3,
        sh_degree: 3,
        ..Default::default()
    };
    let pixels = (camera.width * camera.height) as usize;
    let mut rng = Rng(4);
    let gc: Vec<f32> = (0..pixels * 3)
        .map(|_| rng.uniform(-1.0, 1.0) as f32)
        .collect();
    let ga: Vec<f32> = (0..pixels).map(|_| rng.uniform(-1.0, 1.0) as f32).collect();
    let gd: Vec<f32> = (0..pixels).map(|_| rng.uniform(-1.0, 1.0) as f32).collect();
    let grads = OutputGrads {
        color: &gc,
        alpha: Some(&ga),
        depth: Some(&gd),
        median_depth: Some(&gd),
    };
    let run = |threads: usize| {
        let backend = CpuBackend::new(threads);
        let (out, saved) = backend
            .forward(&model, &camera, &settings, &bg)
            .expect("valid scene");
        let g = backend
            .backward(&model, &saved, &grads)
            .expect("valid gradients");
        (out, g)
    };
    let (out1, g1) = run(1);
    let drawn = out1.face_pixel_count.iter().filter(|&&c| c > 0).count();
    assert!(drawn > 800, "a busy scene: {drawn} faces drawn");
    for threads in [2, 3] {
        let (out, g) = run(threads);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&out.color),
            bits(&out1.color),
            "{threads} threads: colour differs"
        );
        assert_eq!(bits(&out.alpha), bits(&out1.alpha));
        assert_eq!(bits(&out.depth), bits(&out1.depth));
        assert_eq!(bits(&out.median_depth), bits(&out1.median_depth));
        assert_eq!(bits(&out.face_max_weight), bits(&out1.face_max_weight));
        assert_eq!(out.face_pixel_count, out1.face_pixel_count);
        let flat = |g: &objectsplat_raster::ModelGrads<f32>| {
            let mut v: Vec<u32> = g.vertices.iter().flatten().map(|x| x.to_bits()).collect();
            v.extend(g.sh.iter().flatten().flatten().map(|x| x.to_bits()));
            v.extend(g.opacity_logits.iter().map(|x| x.to_bits()));
            v.extend(g.background.iter().map(|x| x.to_bits()));
            v
        };
        assert_eq!(flat(&g), flat(&g1), "{threads} threads: gradients differ");
    }
}
