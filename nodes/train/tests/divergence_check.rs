//! A diverging run stops with an error naming the component and the iteration
//! (and the parameter, when one left the finite range); no NaN or infinity is
//! ever handed back.

mod common;

use objectsplat_raster::{CpuBackend, RenderBackend};
use objectsplat_train::Schedule;
use objectsplat_train::trainer::train_component;

fn absurd_run(backend: &dyn RenderBackend<f32>) -> String {
    let (_dir, data, points) = common::plate();
    // Adam moves each coefficient by about the learning rate per step: at
    // 1e38 the SH coefficients overflow f32 within a few steps.
    let schedule = Schedule::new(
        50,
        serde_json::json!({ "lr_sh_dc": 1e38 }).as_object().unwrap(),
    )
    .unwrap();
    let settings = common::settings_with(schedule, 1);
    let err = train_component(backend, &data, &points, &settings, |_, _| true)
        .err()
        .expect("the run must not succeed");
    format!("{err:#}")
}

/// Asserts that the absurd run on `backend` fails naming the component and the
/// iteration, and saying `what` went wrong.
fn assert_diverges(backend: &dyn RenderBackend<f32>, what: &str) {
    let text = absurd_run(backend);
    assert!(
        text.contains("training of \"obj_1_plate\" diverged at iteration") && text.contains(what),
        "{text}"
    );
}

#[test]
fn an_absurd_learning_rate_fails_naming_component_and_iteration() {
    assert_diverges(&CpuBackend::new(1), "is not finite");
}

/// On wgpu the iterations run on the device and report back in batches; the
/// error still names the component, the iteration and what overflowed.
#[test]
fn a_diverging_run_on_the_device_fails_the_same_way() {
    let Some(gpu) = common::wgpu_backend() else {
        return;
    };
    assert_diverges(&gpu, "became non-finite");
}
