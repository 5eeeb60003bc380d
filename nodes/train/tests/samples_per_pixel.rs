//! How many samples per pixel a run takes, and which loop takes them: the
//! host's loop supersamples 2×2 unless told otherwise; a wgpu device's loop
//! renders one sample, and a factor given for it explicitly runs the steps on
//! the host instead of being dropped.

mod common;

use objectsplat_core::ComponentKind;
use objectsplat_raster::{CpuBackend, RenderBackend};
use objectsplat_train::Schedule;
use objectsplat_train::trainer::{TrainReport, train_component};

fn run(backend: &dyn RenderBackend<f32>, object_supersample: u32) -> TrainReport {
    let (_dir, data, points) = common::plate();
    let settings = common::short_run_settings(
        60,
        2,
        serde_json::json!({ "object_supersample": object_supersample }),
    );
    train_component(backend, &data, &points, &settings, |_, _| true).expect("a short run")
}

fn said(report: &TrainReport, what: &str) -> bool {
    report.notes.iter().any(|n| n.contains(what))
}

#[test]
fn the_loops_own_factor_is_two_on_the_host_and_one_on_a_device() {
    let s = Schedule::scaled(3000);
    for kind in [ComponentKind::Object, ComponentKind::Background] {
        assert_eq!(s.supersample_for(kind, false), 2);
        assert_eq!(s.supersample_for(kind, true), 1);
    }
    let given = Schedule::new(
        3000,
        serde_json::json!({ "supersample": 4, "object_supersample": 1 })
            .as_object()
            .unwrap(),
    )
    .unwrap();
    assert_eq!(given.supersample_for(ComponentKind::Background, true), 4);
    assert_eq!(given.supersample_for(ComponentKind::Object, false), 1);
    let err = Schedule::new(
        3000,
        serde_json::json!({ "object_supersample": 3 })
            .as_object()
            .unwrap(),
    )
    .unwrap_err();
    assert!(
        format!("{err:#}").contains("object_supersample")
            && format!("{err:#}").contains("1, 2 or 4"),
        "{err:#}"
    );
}

#[test]
fn a_host_run_says_how_many_samples_it_took() {
    let cpu = CpuBackend::new(2);
    let two = run(&cpu, 2);
    assert!(said(&two, "2×2 samples per pixel"), "{:?}", two.notes);
    assert_eq!(two.steps_ran_on, "host");
    let one = run(&cpu, 1);
    assert!(said(&one, "one sample per pixel"), "{:?}", one.notes);
    // The same seed at another sampling is another run.
    assert_ne!(
        common::parameter_bits(&one.model),
        common::parameter_bits(&two.model)
    );
}

#[test]
fn a_factor_given_for_a_device_runs_its_steps_on_the_host() {
    let Some(gpu) = common::wgpu_backend() else {
        return;
    };
    let own = run(&gpu, 0);
    assert_eq!(own.steps_ran_on, "device", "{:?}", own.notes);
    assert!(said(&own, "one sample per pixel"), "{:?}", own.notes);
    let given = run(&gpu, 2);
    assert_eq!(given.steps_ran_on, "host", "{:?}", given.notes);
    assert!(said(&given, "2×2 samples per pixel"), "{:?}", given.notes);
    assert!(said(&given, "steps on the host"), "{:?}", given.notes);
}
