//! Backward parity: every gradient group of the wgpu backend (vertices, SH of
//! every degree, opacity logits, background) is within 1e-3 norm-relative of
//! the CPU backend's, with native float atomics and with the compare-exchange
//! path, and in the GPU (256/128 threads per tile) and CPU-adapter (64/32)
//! kernel layouts. (f32 on both sides; the GPU sums in a different order and recovers
//! T by division, so bitwise equality is not expected.)
mod support;

use objectsplat_raster::{CpuBackend, RenderBackend, SH_COEFFS};
use objectsplat_raster_gpu::{FloatAtomics, KernelConfig, WgpuBackend};
use support::{Rng, context, every_output, parity_scenes, relative_difference, upstream};

const TOLERANCE: f64 = 1e-3;

fn sh_band(g: &[[[f32; 3]; SH_COEFFS]], band: std::ops::Range<usize>) -> Vec<f32> {
    g.iter()
        .flat_map(|rows| rows[band.clone()].iter().flatten().copied())
        .collect()
}

fn check_backend(gpu: &WgpuBackend) {
    let cpu = CpuBackend::new(2);
    let mut rng = Rng(77);
    for s in parity_scenes() {
        let pixels = (s.camera.width * s.camera.height) as usize;
        let upstream = upstream(&mut rng, pixels);
        let grads = every_output(&upstream);
        let (_, saved) = s.render_on(&cpu, &s.settings);
        let want = cpu.backward(&s.model, &saved, &grads).unwrap();
        let (_, saved) = s.render_on(gpu, &s.settings);
        let got = gpu.backward(&s.model, &saved, &grads).unwrap();
        let mut groups: Vec<(String, Vec<f32>, Vec<f32>)> = vec![
            (
                "vertices".into(),
                got.vertices.concat(),
                want.vertices.concat(),
            ),
            (
                "opacity logits".into(),
                got.opacity_logits.clone(),
                want.opacity_logits.clone(),
            ),
            (
                "background".into(),
                got.background.clone(),
                want.background.clone(),
            ),
        ];
        for (degree, band) in [(0, 0..1), (1, 1..4), (2, 4..9), (3, 9..16)] {
            groups.push((
                format!("SH degree {degree}"),
                sh_band(&got.sh, band.clone()),
                sh_band(&want.sh, band),
            ));
        }
        for (name, a, b) in groups {
            let norm: f64 = b.iter().map(|x| (*x as f64).powi(2)).sum::<f64>().sqrt();
            // Bands above the active degree are exactly zero on both sides.
            let d = relative_difference(&a, &b, 1e-12);
            eprintln!(
                "{}: {name}: relative difference {d:.2e}, norm {norm:.3e}",
                s.name
            );
            assert!(
                d <= TOLERANCE || (norm == 0.0 && a.iter().all(|&x| x == 0.0)),
                "{} ({:?}): {name} differs by {d:.3e} (norm {norm:.3e})",
                s.name,
                gpu.config()
            );
        }
    }
}

#[test]
fn gradients_match_the_cpu_backend_with_the_compare_exchange_path() {
    let Some(ctx) = context() else { return };
    // The CPU-adapter layout, whatever the adapter.
    let config = KernelConfig {
        atomics: FloatAtomics::CompareExchange,
        forward_threads: 64,
        backward_threads: 32,
    };
    check_backend(&WgpuBackend::with_config(ctx, config).unwrap());
}

#[test]
fn gradients_match_the_cpu_backend_with_native_float_atomics() {
    let Some(ctx) = context() else { return };
    if !ctx.float_atomics {
        eprintln!(
            "SKIPPED (adapter lacks SHADER_FLOAT32_ATOMIC): {}",
            ctx.adapter_info.name
        );
        return;
    }
    // The GPU layout, whatever the adapter.
    let config = KernelConfig {
        atomics: FloatAtomics::Native,
        forward_threads: 256,
        backward_threads: 128,
    };
    check_backend(&WgpuBackend::with_config(ctx, config).unwrap());
}
