//! How many samples per pixel a run takes: 2×2 unless told otherwise, on the
//! host's loop and on a wgpu device's alike, and the run says so.

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
fn components_take_two_by_two_samples_unless_told_otherwise() {
    let s = Schedule::scaled(3000);
    for kind in [ComponentKind::Object, ComponentKind::Background] {
        assert_eq!(s.supersample_for(kind), 2);
    }
    let given = Schedule::new(
        3000,
        serde_json::json!({ "supersample": 4, "object_supersample": 1 })
            .as_object()
            .unwrap(),
    )
    .unwrap();
    assert_eq!(given.supersample_for(ComponentKind::Background), 4);
    assert_eq!(given.supersample_for(ComponentKind::Object), 1);
    for bad in [0, 3, 8] {
        let err = Schedule::new(
            3000,
            serde_json::json!({ "object_supersample": bad })
                .as_object()
                .unwrap(),
        )
        .unwrap_err();
        let text = format!("{err:#}");
        assert!(
            text.contains("object_supersample") && text.contains("1, 2 or 4"),
            "{text}"
        );
    }
}

#[test]
fn a_run_says_how_many_samples_it_took() {
    let cpu = CpuBackend::new(2);
    let two = run(&cpu, 2);
    assert!(said(&two, "2×2 samples per pixel"), "{:?}", two.notes);
    let one = run(&cpu, 1);
    assert!(said(&one, "one sample per pixel"), "{:?}", one.notes);
    // The same seed at another sampling is another run.
    assert_ne!(
        common::parameter_bits(&one.model),
        common::parameter_bits(&two.model)
    );
}

#[test]
fn a_device_supersamples_in_its_own_loop() {
    let Some(gpu) = common::wgpu_backend() else {
        return;
    };
    let two = run(&gpu, 2);
    assert_eq!(two.steps_ran_on, "device", "{:?}", two.notes);
    assert!(said(&two, "2×2 samples per pixel"), "{:?}", two.notes);
}
