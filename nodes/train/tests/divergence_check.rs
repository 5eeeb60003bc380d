//! A diverging run stops with an error naming the component and the iteration
//! (and the parameter, when one left the finite range); no NaN or infinity is
//! ever handed back.

mod common;

use objectsplat_raster::{CpuBackend, RenderBackend};
use objectsplat_train::Schedule;
use objectsplat_train::init::{ComponentMasks, InitSettings};
use objectsplat_train::trainer::{ComponentData, TrainSettings, train_component};

fn absurd_run(backend: &dyn RenderBackend<f32>) -> String {
    let dir = tempfile::tempdir().unwrap();
    common::write_component(dir.path());
    let masks = ComponentMasks::read(dir.path()).unwrap();
    let points = masks.component_points(&common::points()).unwrap();
    let data = ComponentData::read(dir.path()).unwrap();
    let settings = TrainSettings {
        // Adam moves each coefficient by about the learning rate per step: at
        // 1e38 the SH coefficients overflow f32 within a few steps.
        schedule: Schedule::new(
            50,
            serde_json::json!({ "lr_sh_dc": 1e38 }).as_object().unwrap(),
        )
        .unwrap(),
        seed: 1,
        background_randomization: true,
        fixed_background: [0.0; 3],
        init: InitSettings::default(),
        world_scale: 1.0,
        checkpoint: Default::default(),
        crop: true,
        select_on: Default::default(),
        resume_dir: None,
        save_seconds: 60.0,
    };
    let err = train_component(backend, &data, &points, &settings, |_, _| true)
        .err()
        .expect("the run must not succeed");
    format!("{err:#}")
}

#[test]
fn an_absurd_learning_rate_fails_naming_component_and_iteration() {
    let text = absurd_run(&CpuBackend::new(1));
    assert!(
        text.contains("training of \"obj_1_plate\" diverged at iteration")
            && text.contains("is not finite"),
        "{text}"
    );
}

/// On wgpu the iterations run on the device and report back in batches; the
/// error still names the component, the iteration and what overflowed.
#[test]
fn a_diverging_run_on_the_device_fails_the_same_way() {
    let ctx = match objectsplat_wgpu::GpuContext::shared(objectsplat_wgpu::AdapterChoice::Auto) {
        Ok((ctx, _)) => ctx,
        Err(e) => {
            if std::env::var("OBJECTSPLAT_REQUIRE_ADAPTER").is_ok_and(|v| v == "1") {
                panic!("no wgpu adapter but OBJECTSPLAT_REQUIRE_ADAPTER=1: {e:#}");
            }
            eprintln!("SKIPPED (no wgpu adapter): {e:#}");
            return;
        }
    };
    let text = absurd_run(&objectsplat_wgpu::WgpuBackend::new(ctx).unwrap());
    assert!(
        text.contains("training of \"obj_1_plate\" diverged at iteration")
            && text.contains("became non-finite"),
        "{text}"
    );
}
