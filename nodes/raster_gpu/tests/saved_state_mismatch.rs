//! A backward pass handed another backend's (or another scalar type's) saved
//! forward state is an error naming both, never a panic or a wrong gradient.
mod support;

use objectsplat_raster::{CpuBackend, Model, OutputGrads, RenderBackend};
use support::{backend, parity_scenes};

#[test]
fn foreign_saved_state_is_an_error() {
    let Some(gpu) = backend() else { return };
    let cpu = CpuBackend::new(1);
    let s = parity_scenes().swap_remove(0);
    let pixels = (s.camera.width * s.camera.height) as usize;
    let grad = vec![0.1f32; pixels * 3];
    let grads = OutputGrads::color_only(&grad);

    let crossings: [(&dyn RenderBackend<f32>, &dyn RenderBackend<f32>, &str); 2] = [
        (
            &cpu,
            &gpu,
            "wgpu backend cannot use state saved by the \"cpu\"",
        ),
        (
            &gpu,
            &cpu,
            "cpu backend cannot use state saved by the \"wgpu\"",
        ),
    ];
    for (saver, user, expect) in crossings {
        let (_, saved) = s.render_on(saver, &s.settings);
        let err = user.backward(&s.model, &saved, &grads).unwrap_err();
        assert!(format!("{err:#}").contains(expect), "{err:#}");
    }

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
