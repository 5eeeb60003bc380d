//! A backward pass handed another backend's (or another scalar type's) saved
//! forward state is an error naming both, never a panic or a wrong gradient.
mod support;

use objectsplat_raster::{CpuBackend, Model, OutputGrads, RenderBackend};
use objectsplat_wgpu::WgpuBackend;
use support::{context, parity_scenes};

#[test]
fn foreign_saved_state_is_an_error() {
    let Some(ctx) = context() else { return };
    let gpu = WgpuBackend::new(ctx).unwrap();
    let cpu = CpuBackend::new(1);
    let s = parity_scenes().swap_remove(0);
    let pixels = (s.camera.width * s.camera.height) as usize;
    let grad = vec![0.1f32; pixels * 3];
    let grads = OutputGrads::color_only(&grad);

    let (_, from_cpu) = cpu
        .forward(&s.model, &s.camera, &s.settings, &s.background)
        .unwrap();
    let err = gpu.backward(&s.model, &from_cpu, &grads).unwrap_err();
    assert!(
        format!("{err:#}").contains("wgpu backend cannot use state saved by the \"cpu\""),
        "{err:#}"
    );

    let (_, from_gpu) = gpu
        .forward(&s.model, &s.camera, &s.settings, &s.background)
        .unwrap();
    let err = cpu.backward(&s.model, &from_gpu, &grads).unwrap_err();
    assert!(
        format!("{err:#}").contains("cpu backend cannot use state saved by the \"wgpu\""),
        "{err:#}"
    );

    // The same backend at f64 saved it: the type check catches it.
    let model64 = Model::<f64> {
        vertices: s.model.vertices.iter().map(|v| v.map(f64::from)).collect(),
        faces: s.model.faces.clone(),
        sh: s
            .model
            .sh
            .iter()
            .map(|r| r.map(|c| c.map(f64::from)))
            .collect(),
        opacity_logits: s.model.opacity_logits.iter().map(|&x| x as f64).collect(),
        ..Model::<f64>::empty()
    };
    let bg64: Vec<f64> = s.background.iter().map(|&x| x as f64).collect();
    let (_, from_f64) = cpu
        .forward(&model64, &s.camera, &s.settings, &bg64)
        .unwrap();
    let err = RenderBackend::<f32>::backward(&cpu, &s.model, &from_f64, &grads).unwrap_err();
    assert!(
        format!("{err:#}").contains("another scalar type"),
        "{err:#}"
    );
}
