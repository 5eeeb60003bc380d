//! The weights-only pass (`CpuBackend::face_max_weight_into`) gives every
//! face the largest blending weight a full forward pass gives it, bit for
//! bit, on random scenes, over the whole frame and over a footprint, with
//! either kernel; and a backward pass refuses the workspace it leaves.

mod common;

use common::*;
use objectsplat_core::Camera;
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::cpu::{Background, CpuWorkspace};
use objectsplat_raster::{CpuBackend, Kernel, Model, OutputGrads, RenderSettings};

/// A full forward pass over a black background into `ws`.
fn full_forward(
    backend: &CpuBackend,
    ws: &mut CpuWorkspace<f32>,
    model: &Model<f32>,
    camera: &Camera,
    settings: &RenderSettings,
) {
    let black = Background::Uniform([0.0; 3]);
    backend
        .forward_into(ws, model, camera, settings, black)
        .expect("valid scene");
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn weights_only_pass_matches_the_forward_pass_bit_for_bit() {
    for kernel in [Kernel::Simd, Kernel::Scalar] {
        let backend = CpuBackend::new(2).with_kernel(kernel);
        // One workspace for every pass, as a trainer keeps it: a weights-only
        // pass after a full one (and the reverse) must not see the other's leftovers.
        let mut ws = CpuWorkspace::<f32>::default();
        for (seed, count, (w, h), sigma, region) in [
            (11u64, 600usize, (96u32, 72u32), 1.0f64, Region::Full),
            (12, 2500, (120, 88), 0.05, Region::Full),
            (13, 1200, (80, 64), 1e-4, Region::Full),
            (
                14,
                900,
                (112, 80),
                0.4,
                Region::Footprint {
                    include: PixelRect {
                        x0: 40,
                        y0: 30,
                        x1: 60,
                        y1: 50,
                    },
                    margin: 2,
                },
            ),
        ] {
            let (model, camera, _) = random_soup_f32(seed, count, w, h);
            let settings = RenderSettings {
                sigma,
                sh_degree: 3,
                region,
                ..Default::default()
            };
            let weights = backend
                .face_max_weight_into(&mut ws, &model, &camera, &settings)
                .expect("valid scene")
                .to_vec();
            full_forward(&backend, &mut ws, &model, &camera, &settings);
            let full = &ws.output.face_max_weight;
            let shown = full.iter().filter(|&&m| m > 0.0).count();
            assert!(
                shown > count / 8,
                "seed {seed}: a busy scene ({shown} faces shown)"
            );
            assert_eq!(bits(&weights), bits(full), "{kernel:?}, seed {seed}");
        }
    }
}

#[test]
fn a_backward_pass_refuses_a_weights_only_workspace() {
    let backend = CpuBackend::new(2);
    let (model, camera, _) = random_soup_f32(21, 300, 64, 48);
    let settings = RenderSettings::default();
    let mut ws = CpuWorkspace::<f32>::default();
    full_forward(&backend, &mut ws, &model, &camera, &settings);
    backend
        .face_max_weight_into(&mut ws, &model, &camera, &settings)
        .expect("valid scene");
    let pixels = (camera.width * camera.height) as usize;
    let color = vec![1.0f32; 3 * pixels];
    let grads = OutputGrads::color_only(&color);
    let simd =
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma");
    let outcome = backend.backward_into(&mut ws, &model, &grads);
    if simd {
        let message = format!(
            "{:#}",
            outcome.expect_err("no forward pass to differentiate")
        );
        assert!(message.contains("before any forward pass"), "{message}");
    } else {
        // Without the eight-lane kernels the weights come from a full forward pass.
        outcome.expect("a full forward pass ran");
    }
}
