//! Evaluation and face statistics on the device: `DeviceTrainer::evaluate`
//! scores views over a black background like objectsplat_raster's loss on the
//! CPU backend's render (loss and weighted squared error), cropped or not,
//! with one readback (two when the tile-entry buffers must grow first); the
//! running per-face maxima of the blending weight are those of the training
//! renders, per epoch.
mod support;

use glam::DVec3;
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::loss::DEFAULT_LAMBDA_DSSIM;
use objectsplat_raster::{CpuBackend, RenderBackend, RenderSettings};
use objectsplat_raster_gpu::training::{Step, Trained, TrainingView};
use support::{
    CpuLoss, FROZEN, Scene, backend, cpu_loss, facing_origin, footprint, loaded_trainer,
    object_view, small_object_scene,
};

/// The object seen from two cameras, each view with its own pixels supervised.
fn scene_and_views() -> (Scene, Vec<TrainingView>) {
    let scene = small_object_scene(80, 41);
    let first = object_view(
        &scene,
        PixelRect {
            x0: 50,
            y0: 34,
            x1: 70,
            y1: 56,
        },
        6,
    );
    let (width, height) = (scene.camera.width, scene.camera.height);
    let other = facing_origin(width, height, scene.camera.fx, DVec3::new(-0.6, 0.3, -2.8));
    let second_scene = Scene {
        camera: other,
        name: "second view".into(),
        model: scene.model.clone(),
        settings: scene.settings.clone(),
        background: scene.background.clone(),
    };
    let second = object_view(
        &second_scene,
        PixelRect {
            x0: 40,
            y0: 30,
            x1: 64,
            y1: 50,
        },
        7,
    );
    (scene, vec![first, second])
}

/// (loss, Σ w·d² over supervised pixels) of the CPU render over black.
fn cpu_score(scene: &Scene, view: &TrainingView) -> (f64, f64) {
    let pixels = (view.camera.width * view.camera.height) as usize;
    let CpuLoss {
        render, goal, loss, ..
    } = cpu_loss(&scene.model, view, &scene.settings, [0.0; 3]);
    let mut squared = 0.0;
    for p in (0..pixels).filter(|&p| view.weights[p] > 0.0) {
        let (rendered, wanted) = (&render.color[3 * p..3 * p + 3], &goal[3 * p..3 * p + 3]);
        for (x, y) in rendered.iter().zip(wanted) {
            squared += view.weights[p] as f64 * ((x - y) as f64).powi(2);
        }
    }
    (loss.value as f64, squared)
}

fn settings(scene: &Scene, region: Region) -> RenderSettings {
    RenderSettings {
        region,
        ..scene.settings.clone()
    }
}

#[test]
fn device_evaluation_matches_the_cpu_with_one_readback() {
    let Some(gpu) = backend() else { return };
    let (scene, views) = scene_and_views();
    let mut trainer = loaded_trainer(&gpu, &views, &scene.model);
    let want: Vec<(f64, f64)> = views.iter().map(|v| cpu_score(&scene, v)).collect();
    let weights: Vec<f64> = views
        .iter()
        .map(|v| v.weights.iter().map(|&w| w as f64).sum())
        .collect();
    let mut previous = None;
    for (round, region) in [footprint(), footprint(), Region::Full]
        .into_iter()
        .enumerate()
    {
        let syncs = trainer.host_syncs();
        let got = trainer
            .evaluate(&[0, 1], &settings(&scene, region), DEFAULT_LAMBDA_DSSIM)
            .unwrap();
        let readbacks = trainer.host_syncs() - syncs;
        eprintln!("evaluation {round} ({region:?}): {readbacks} readbacks");
        // No step came first: the entry buffers were too small once, then never again.
        assert_eq!(readbacks, if round == 0 { 2 } else { 1 });
        for (k, (g, (loss, squared))) in got.iter().zip(&want).enumerate() {
            let dl = (g.loss - loss).abs() / loss;
            let ds = (g.squared_error - squared).abs() / squared;
            eprintln!(
                "  view {k}: loss {} vs {loss} ({dl:.2e}), squared {ds:.2e}",
                g.loss
            );
            assert!(dl < 1e-5, "view {k}: loss differs by {dl:.3e}");
            assert!(ds < 1e-4, "view {k}: squared error differs by {ds:.3e}");
            assert_eq!(g.total_weight, weights[k]);
        }
        if round == 1 {
            // The same evaluation again is the same computation, bit for bit.
            assert_eq!(Some(got.clone()), previous);
        }
        previous = Some(got);
    }
    let err = trainer
        .evaluate(&[2], &scene.settings, DEFAULT_LAMBDA_DSSIM)
        .unwrap_err();
    assert!(format!("{err:#}").contains("view 2"), "{err:#}");
}

#[test]
fn face_weights_are_running_maxima_of_the_training_renders() {
    let Some(gpu) = backend() else { return };
    let (scene, views) = scene_and_views();
    let nf = scene.model.face_count();
    let mut trainer = loaded_trainer(&gpu, &views, &scene.model);
    // Per view, the render's per-face maxima through the RenderBackend interface.
    let rendered: Vec<Vec<f32>> = views
        .iter()
        .map(|v| {
            let black = vec![0.0f32; (v.camera.width * v.camera.height * 3) as usize];
            let (out, _) = gpu
                .forward(&scene.model, &v.camera, &scene.settings, &black)
                .unwrap();
            let (cpu, _) = CpuBackend::new(2)
                .forward(&scene.model, &v.camera, &scene.settings, &black)
                .unwrap();
            for (a, b) in out.face_max_weight.iter().zip(&cpu.face_max_weight) {
                assert!((a - b).abs() <= 1e-4);
            }
            out.face_max_weight
        })
        .collect();
    let max =
        |a: &[f32], b: &[f32]| -> Vec<f32> { a.iter().zip(b).map(|(x, y)| x.max(*y)).collect() };
    let step = |view| Step {
        view,
        background: [0.4, 0.2, 0.9],
        render: settings(&scene, footprint()),
        learning_rates: FROZEN,
        ..support::step_at(&scene, 0.0)
    };
    let bits = |v: &[f32]| -> Vec<u32> { v.iter().map(|x| x.to_bits()).collect() };
    let zeros = vec![0.0f32; nf];
    assert_eq!(
        trainer.face_weights().unwrap(),
        (zeros.clone(), zeros.clone())
    );
    trainer.step(&step(0)).unwrap();
    trainer.step(&step(1)).unwrap();
    let (current, previous) = trainer.face_weights().unwrap();
    assert_eq!(bits(&current), bits(&max(&rendered[0], &rendered[1])));
    assert_eq!(previous, zeros);
    assert!(current.iter().any(|&w| w > 0.0));
    trainer.end_epoch();
    trainer.step(&step(1)).unwrap();
    let (current, previous) = trainer.face_weights().unwrap();
    assert_eq!(bits(&current), bits(&rendered[1]));
    assert_eq!(bits(&previous), bits(&max(&rendered[0], &rendered[1])));

    // Set from the host (after a remap there), then folded into by the next step.
    let host_current: Vec<f32> = (0..nf).map(|f| (f % 7) as f32 * 0.1).collect();
    let host_previous: Vec<f32> = (0..nf).map(|f| (f % 3) as f32 * 0.2).collect();
    trainer
        .set_face_weights(&host_current, &host_previous)
        .unwrap();
    trainer.step(&step(0)).unwrap();
    let (current, previous) = trainer.face_weights().unwrap();
    assert_eq!(bits(&current), bits(&max(&host_current, &rendered[0])));
    assert_eq!(previous, host_previous);
    let err = trainer
        .set_face_weights(&host_current[1..], &host_previous)
        .unwrap_err();
    assert!(format!("{err:#}").contains("faces"), "{err:#}");
    // Loading a model starts its statistics over.
    trainer
        .load(
            &scene.model,
            Trained::all_of(&scene.model),
            Some(&support::fresh_optim(&scene.model)),
        )
        .unwrap();
    assert_eq!(trainer.face_weights().unwrap(), (zeros.clone(), zeros));
}
