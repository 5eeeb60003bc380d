//! `backend_for` picks the named backend and says why; the wgpu backend
//! rejects invalid input with errors instead of panicking.
mod support;

use objectsplat_raster::{CpuBackend, OutputGrads, RenderBackend, RenderSettings};
use objectsplat_raster_gpu::backend_for;
use support::{Rng, backend, context, facing_origin, random_soup};

#[test]
fn wgpu_picks_the_adapter_and_auto_skips_lavapipe() {
    let Some(ctx) = context() else { return };
    let (backend, why) = backend_for("wgpu", 2).unwrap();
    assert_eq!(backend.name(), "wgpu");
    assert!(why.starts_with("wgpu on "), "{why}");
    let (backend, why) = backend_for("auto", 2).unwrap();
    if ctx.adapter_info.device_type == wgpu::DeviceType::Cpu {
        // Only lavapipe here: auto takes the faster CPU backend and says why.
        assert_eq!(backend.name(), "cpu", "{why}");
        assert!(why.contains("no hardware GPU adapter"), "{why}");
    } else {
        assert_eq!(backend.name(), "wgpu", "{why}");
    }
    let (backend, why) = backend_for("cpu", 3).unwrap();
    assert_eq!(backend.name(), "cpu");
    assert!(why.contains("3 threads"), "{why}");
    let err = backend_for("cuda", 1)
        .err()
        .expect("unknown names are refused");
    assert!(format!("{err:#}").contains("\"cuda\""), "{err:#}");
}

#[test]
fn invalid_inputs_are_errors_not_panics() {
    let Some(gpu) = backend() else { return };
    let mut rng = Rng(1);
    let model = random_soup(&mut rng, 10, 1, (0.1, 0.5));
    let camera = facing_origin(32, 24, 30.0, glam::DVec3::new(0.0, 0.0, -3.0));
    let settings = RenderSettings::for_model(&model);
    let bg = vec![0.5f32; 32 * 24 * 3];

    let mut bad = model.clone();
    bad.vertices[0][1] = f32::NAN;
    let err = gpu
        .forward(&bad, &camera, &settings, &bg)
        .err()
        .expect("a NaN vertex is an error");
    assert!(format!("{err:#}").contains("vertex 0"), "{err:#}");

    let mut bad = model.clone();
    bad.faces[0][2] = 999;
    assert!(gpu.forward(&bad, &camera, &settings, &bg).is_err());

    let bad_settings = RenderSettings {
        alpha_max: 1.5,
        ..settings.clone()
    };
    assert!(gpu.forward(&model, &camera, &bad_settings, &bg).is_err());
    assert!(gpu.forward(&model, &camera, &settings, &bg[1..]).is_err());

    let (_, saved) = gpu.forward(&model, &camera, &settings, &bg).unwrap();
    let short = vec![0f32; 5];
    assert!(
        gpu.backward(&model, &saved, &OutputGrads::color_only(&short))
            .is_err()
    );
    let mut other = model.clone();
    other.vertices.pop();
    let g = vec![0f32; 32 * 24 * 3];
    assert!(
        gpu.backward(&other, &saved, &OutputGrads::color_only(&g))
            .is_err()
    );
    let (_, cpu_saved) = CpuBackend::new(1)
        .forward(&model, &camera, &settings, &bg)
        .unwrap();
    let err = gpu
        .backward(&model, &cpu_saved, &OutputGrads::color_only(&g))
        .unwrap_err();
    assert!(format!("{err:#}").contains("cpu"), "{err:#}");
}

#[test]
fn empty_models_render_the_background() {
    let Some(gpu) = backend() else { return };
    let model = objectsplat_raster::Model::<f32>::empty();
    let camera = facing_origin(20, 17, 20.0, glam::DVec3::new(0.0, 0.0, -3.0));
    let bg: Vec<f32> = (0..20 * 17 * 3).map(|i| (i % 7) as f32 / 7.0).collect();
    let (out, saved) = gpu
        .forward(&model, &camera, &RenderSettings::default(), &bg)
        .unwrap();
    assert_eq!(out.color, bg);
    assert!(out.alpha.iter().all(|&a| a == 0.0));
    let g: Vec<f32> = (0..20 * 17 * 3).map(|i| i as f32).collect();
    let grads = gpu
        .backward(&model, &saved, &OutputGrads::color_only(&g))
        .unwrap();
    assert_eq!(grads.background, g);
}
