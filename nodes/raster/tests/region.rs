//! Rendering only a model's footprint (`Region::Footprint`) is exact: inside
//! the region every output and every parameter gradient is bit-identical to a
//! full render's, and outside it a full render is exactly the background. This
//! is what lets the trainer crop an object's views.

mod common;

use common::*;
use objectsplat_core::glam::DVec3;
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::{
    CpuBackend, Model, ModelGrads, OutputGrads, RenderBackend, RenderSettings,
};

/// A clump of triangles around `centre` (a small object), plus the camera and a random background.
fn clump(
    seed: u64,
    centre: [f64; 3],
    count: usize,
) -> (Model<f32>, objectsplat_core::Camera, Vec<f32>) {
    let mut rng = Rng(seed);
    let camera = orbit_camera(160, 120, 150.0, DVec3::new(0.3, 0.2, -3.0));
    let mut model = Model::<f64>::empty();
    model.sh_degree = 2;
    for _ in 0..count {
        let c = [0, 1, 2].map(|a| centre[a] + rng.uniform(-0.2, 0.2));
        let corners = [0, 1, 2].map(|_| [0, 1, 2].map(|a| c[a] + rng.uniform(-0.12, 0.12)));
        let logits = [0, 1, 2].map(|_| rng.uniform(-2.0, 4.0));
        push_triangle(&mut model, &mut rng, corners, logits);
    }
    let bg = random_background(&mut rng, &camera)
        .into_iter()
        .map(|v| v as f32)
        .collect();
    (model.cast::<f32>(), camera, bg)
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn grad_bits(g: &ModelGrads<f32>) -> Vec<u32> {
    let mut v: Vec<u32> = g.vertices.iter().flatten().map(|x| x.to_bits()).collect();
    v.extend(g.sh.iter().flatten().flatten().map(|x| x.to_bits()));
    v.extend(g.opacity_logits.iter().map(|x| x.to_bits()));
    v
}

#[test]
fn footprint_region_is_exact_inside_and_background_outside() {
    for (seed, centre) in [
        (1, [0.4, -0.3, 0.0]),
        (2, [-0.9, 0.6, 0.2]),
        (3, [0.0, 0.0, 0.0]),
    ] {
        let (model, camera, bg) = clump(seed, centre, 60);
        let backend = CpuBackend::new(2);
        let full = RenderSettings {
            sigma: 0.4,
            sh_degree: 2,
            ..Default::default()
        };
        let include = PixelRect {
            x0: 78,
            y0: 58,
            x1: 84,
            y1: 64,
        };
        let cropped = RenderSettings {
            region: Region::Footprint {
                include,
                margin: 10,
            },
            ..full.clone()
        };
        let (a, saved_a) = backend.forward(&model, &camera, &full, &bg).unwrap();
        let (b, saved_b) = backend.forward(&model, &camera, &cropped, &bg).unwrap();
        let r = b.region;
        let (w, h) = (camera.width, camera.height);
        assert!(
            !r.is_empty() && r.pixels() < (w * h) as usize / 2,
            "seed {seed}: a small region {r:?}"
        );
        assert!(
            r.x0 <= include.x0 && r.y0 <= include.y0 && r.x1 >= include.x1 && r.y1 >= include.y1
        );
        assert_eq!(a.region, PixelRect::full(w, h));
        let crop = |img: &[f32], ch: usize| -> Vec<f32> {
            let mut v = Vec::new();
            for y in r.y0..r.y1 {
                for x in r.x0..r.x1 {
                    let i = (y * w + x) as usize * ch;
                    v.extend_from_slice(&img[i..i + ch]);
                }
            }
            v
        };
        assert_eq!(
            bits(&crop(&a.color, 3)),
            bits(&b.color),
            "seed {seed}: colour"
        );
        assert_eq!(bits(&crop(&a.alpha, 1)), bits(&b.alpha));
        assert_eq!(bits(&crop(&a.depth, 1)), bits(&b.depth));
        assert_eq!(bits(&crop(&a.median_depth, 1)), bits(&b.median_depth));
        assert_eq!(bits(&a.face_max_weight), bits(&b.face_max_weight));
        assert_eq!(a.face_pixel_count, b.face_pixel_count);
        // Outside the region (grown by 10 px) nothing was drawn.
        for y in 0..h {
            for x in 0..w {
                let inside = x + 10 >= r.x0 && x < r.x1 + 10 && y + 10 >= r.y0 && y < r.y1 + 10;
                let i = (y * w + x) as usize;
                if !inside {
                    assert_eq!(
                        a.alpha[i], 0.0,
                        "seed {seed}: pixel ({x}, {y}) outside is covered"
                    );
                    assert_eq!(
                        bits(&a.color[3 * i..3 * i + 3]),
                        bits(&bg[3 * i..3 * i + 3])
                    );
                }
            }
        }
        // The same upstream gradient over the region gives bit-identical parameter gradients.
        let mut rng = Rng(seed + 100);
        let gc: Vec<f32> = (0..(w * h * 3) as usize)
            .map(|_| rng.uniform(-1.0, 1.0) as f32)
            .collect();
        let ga: Vec<f32> = (0..(w * h) as usize)
            .map(|_| rng.uniform(-1.0, 1.0) as f32)
            .collect();
        let full_grads = OutputGrads {
            color: &gc,
            alpha: Some(&ga),
            depth: Some(&ga),
            median_depth: None,
        };
        let (gc_r, ga_r) = (crop(&gc, 3), crop(&ga, 1));
        let region_grads = OutputGrads {
            color: &gc_r,
            alpha: Some(&ga_r),
            depth: Some(&ga_r),
            median_depth: None,
        };
        let ga_full = backend.backward(&model, &saved_a, &full_grads).unwrap();
        let ga_region = backend.backward(&model, &saved_b, &region_grads).unwrap();
        assert_eq!(
            grad_bits(&ga_full),
            grad_bits(&ga_region),
            "seed {seed}: parameter gradients"
        );
        assert_eq!(
            bits(&crop(&ga_full.background, 3)),
            bits(&ga_region.background)
        );
        // Gradients of the wrong size for the region are refused.
        assert!(backend.backward(&model, &saved_b, &full_grads).is_err());
    }
}

#[test]
fn an_empty_footprint_renders_nothing() {
    let (model, camera, bg) = clump(4, [0.0, 0.0, 0.0], 10);
    // Every face behind the camera: nothing is drawn, and an empty include adds nothing.
    let mut behind = model.clone();
    for v in &mut behind.vertices {
        v[2] -= 10.0;
    }
    let settings = RenderSettings {
        region: Region::Footprint {
            include: PixelRect::default(),
            margin: 10,
        },
        ..Default::default()
    };
    let backend = CpuBackend::new(1);
    let (out, saved) = backend.forward(&behind, &camera, &settings, &bg).unwrap();
    assert!(out.region.is_empty() && out.color.is_empty());
    assert!(out.face_max_weight.iter().all(|&w| w == 0.0));
    let grads = backend
        .backward(&behind, &saved, &OutputGrads::color_only(&[]))
        .unwrap();
    assert!(grads.vertices.iter().flatten().all(|&g| g == 0.0));
}
