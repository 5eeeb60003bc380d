//! One large triangle covering most of the image: every pixel adds into the
//! same face accumulators (and its three vertices), the worst contention for
//! the atomics. Gradient sums equal the CPU backend's with both the native
//! float-atomic and the compare-exchange paths.
mod support;

use objectsplat_raster::{CpuBackend, RenderBackend, RenderSettings};
use objectsplat_raster_gpu::{FloatAtomics, WgpuBackend};
use support::{
    Rng, context, every_output, facing_origin, push_triangle, relative_difference, upstream,
};

fn large_triangle_scene() -> (
    objectsplat_raster::Model<f32>,
    objectsplat_core::Camera,
    Vec<f32>,
) {
    let mut rng = Rng(9);
    let mut model = objectsplat_raster::Model::<f32>::empty();
    model.sh_degree = 3;
    push_triangle(
        &mut model,
        &mut rng,
        [[-3.0, -2.5, 0.0], [3.0, -2.2, 0.3], [0.2, 3.0, -0.2]],
        [1.0, 2.0, 1.5],
    );
    let camera = facing_origin(128, 96, 110.0, glam::DVec3::new(0.1, 0.2, -3.0));
    let bg = (0..128 * 96 * 3)
        .map(|_| rng.uniform(0.0, 1.0) as f32)
        .collect();
    (model, camera, bg)
}

#[test]
fn contended_gradient_sums_match_the_cpu_with_both_atomic_paths() {
    let Some(ctx) = context() else { return };
    let (model, camera, bg) = large_triangle_scene();
    let settings = RenderSettings::for_model(&model);
    let cpu = CpuBackend::new(2);
    let (out, saved) = cpu.forward(&model, &camera, &settings, &bg).unwrap();
    assert!(
        out.face_pixel_count[0] > 128 * 96 / 2,
        "the triangle must cover most pixels, covers {}",
        out.face_pixel_count[0]
    );
    let mut rng = Rng(3);
    let upstream = upstream(&mut rng, 128 * 96);
    let grads = every_output(&upstream);
    let want = cpu.backward(&model, &saved, &grads).unwrap();
    let mut modes = vec![FloatAtomics::CompareExchange];
    if ctx.float_atomics {
        modes.push(FloatAtomics::Native);
    } else {
        eprintln!("SKIPPED native path (adapter lacks SHADER_FLOAT32_ATOMIC)");
    }
    for mode in modes {
        let gpu = WgpuBackend::with_atomics(ctx.clone(), mode).unwrap();
        let (_, saved) = gpu.forward(&model, &camera, &settings, &bg).unwrap();
        let got = gpu.backward(&model, &saved, &grads).unwrap();
        for (name, a, b) in [
            ("vertices", got.vertices.concat(), want.vertices.concat()),
            ("sh", got.sh.concat().concat(), want.sh.concat().concat()),
            (
                "opacity logits",
                got.opacity_logits.clone(),
                want.opacity_logits.clone(),
            ),
        ] {
            let d = relative_difference(&a, &b, 1e-12);
            // Thousands of per-pixel terms summed in another order: f32 rounding only.
            assert!(
                d <= 1e-4,
                "{mode:?}: {name} differs by {d:.3e}: {a:?} vs {b:?}"
            );
        }
    }
}
