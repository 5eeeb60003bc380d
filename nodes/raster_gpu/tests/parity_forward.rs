//! Forward parity: the wgpu backend renders every output like the CPU backend
//! (f32 both): images within 1e-4 absolute, per-face statistics equal, in
//! every kernel layout (threads per tile).
mod support;

use objectsplat_raster::CpuBackend;
use objectsplat_raster_gpu::{KernelConfig, WgpuBackend};
use support::{context, paired_outputs, parity_scenes};

fn max_abs_diff(a: &[f32], b: &[f32]) -> (f32, usize) {
    assert_eq!(a.len(), b.len());
    let mut worst = (0.0f32, 0usize);
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        let d = (x - y).abs();
        if d > worst.0 {
            worst = (d, i);
        }
    }
    worst
}

#[test]
fn forward_outputs_match_the_cpu_backend() {
    let Some(ctx) = context() else { return };
    let cpu = CpuBackend::new(2);
    for forward_threads in [32, 64, 256] {
        let config = KernelConfig {
            forward_threads,
            ..KernelConfig::for_context(&ctx)
        };
        let gpu = WgpuBackend::with_config(ctx.clone(), config).unwrap();
        check_scenes(&gpu, &cpu);
    }
}

fn check_scenes(gpu: &WgpuBackend, cpu: &CpuBackend) {
    for s in parity_scenes() {
        let (want, _) = s.render_on(cpu, &s.settings);
        let (got, _) = s.render_on(gpu, &s.settings);
        let covered = want.face_pixel_count.iter().filter(|&&c| c > 0).count();
        assert!(covered > 0, "{}: the scene must draw something", s.name);
        for (what, a, b) in paired_outputs(&got, &want) {
            let (d, i) = max_abs_diff(a, b);
            assert!(
                d <= 1e-4,
                "{}: {what}[{i}] differs by {d} ({} vs {})",
                s.name,
                a[i],
                b[i]
            );
        }
        assert_eq!(
            got.face_pixel_count, want.face_pixel_count,
            "{}: face pixel counts",
            s.name
        );
    }
}
