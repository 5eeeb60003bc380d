//! The device training step's loss and image gradient equal
//! objectsplat_raster::loss::photometric on the CPU backend's render of the same
//! model: weighted pixels, unsupervised pixels and pixels whose target is the
//! step's background colour. Learning rates of 0 leave the parameters as they were.
mod support;

use objectsplat_raster::loss::{DEFAULT_LAMBDA_DSSIM, Dims, photometric};
use objectsplat_raster::{CpuBackend, RenderBackend};
use objectsplat_wgpu::WgpuBackend;
use objectsplat_wgpu::training::{
    AdamSettings, DeviceTrainer, LearningRates, OptimizerState, Step, TrainingView,
};
use support::{Rng, context, flat_view, parity_scenes, relative_difference, step_at};

const FROZEN: LearningRates = LearningRates {
    positions: 0.0,
    sh_dc: 0.0,
    sh_rest: 0.0,
    opacity: 0.0,
};

#[test]
fn device_loss_and_image_gradient_match_the_cpu_loss() {
    let Some(ctx) = context() else { return };
    let gpu = WgpuBackend::new(ctx).unwrap();
    let cpu = CpuBackend::new(2);
    let mut rng = Rng(4242);
    for scene in parity_scenes().into_iter().take(5) {
        let camera = scene.camera;
        let pixels = (camera.width * camera.height) as usize;
        // Some pixels unsupervised, some half weight, some owned by the background colour.
        let weights: Vec<f32> = (0..pixels)
            .map(|p| [0.0, 1.0, 1.0, 0.5][p % 7 % 4])
            .collect();
        let from_background: Vec<bool> = (0..pixels).map(|p| p % 5 == 0).collect();
        let target: Vec<f32> = (0..pixels * 3)
            .map(|_| rng.uniform(0.0, 1.0) as f32)
            .collect();
        let background = [0.25f32, 0.6, 0.9];
        let view = TrainingView {
            camera,
            target: target.clone(),
            weights: weights.clone(),
            from_background: from_background.clone(),
        };
        let mut trainer = DeviceTrainer::new(&gpu, &[view], AdamSettings::default()).unwrap();
        let nv = scene.model.vertex_count();
        trainer
            .load(&scene.model, &OptimizerState::zeros(nv))
            .unwrap();
        trainer
            .step(&Step {
                view: 0,
                background,
                render: scene.settings.clone(),
                learning_rates: FROZEN,
                lambda_dssim: DEFAULT_LAMBDA_DSSIM,
            })
            .unwrap();
        let results = trainer.results().unwrap();
        let got_grad = trainer.last_image_gradient(0).unwrap();

        let bg_image: Vec<f32> = (0..pixels * 3).map(|i| background[i % 3]).collect();
        let (render, _) = cpu
            .forward(&scene.model, &camera, &scene.settings, &bg_image)
            .unwrap();
        let mut goal = target.clone();
        for p in (0..pixels).filter(|&p| from_background[p]) {
            goal[3 * p..3 * p + 3].copy_from_slice(&background);
        }
        let want = photometric(
            Dims::rgb(camera.width, camera.height),
            &render.color,
            &goal,
            Some(&weights),
            DEFAULT_LAMBDA_DSSIM,
        )
        .unwrap();
        assert_eq!(results.len(), 1);
        assert!(results[0].non_finite.is_empty(), "{:?}", results[0]);
        let loss_error = (results[0].loss as f64 - want.value as f64).abs() / want.value as f64;
        let grad_error = relative_difference(&got_grad, &want.grad, 1e-12);
        eprintln!(
            "{}: loss {} vs {} (relative {loss_error:.2e}); gradient relative {grad_error:.2e}",
            scene.name, results[0].loss, want.value
        );
        assert!(loss_error < 1e-5, "{}: loss {loss_error:.3e}", scene.name);
        assert!(
            grad_error < 1e-3,
            "{}: gradient {grad_error:.3e}",
            scene.name
        );

        let mut stored = scene.model.clone();
        trainer.store(&mut stored).unwrap();
        assert_eq!(
            stored, scene.model,
            "{}: a step at learning rate 0 moved the model",
            scene.name
        );
    }
}

#[test]
fn a_view_without_supervised_pixels_gives_zero_loss_and_moves_nothing() {
    let Some(ctx) = context() else { return };
    let gpu = WgpuBackend::new(ctx).unwrap();
    let scene = parity_scenes().swap_remove(0);
    let view = flat_view(&scene, 0.0);
    let mut trainer = DeviceTrainer::new(&gpu, &[view], AdamSettings::default()).unwrap();
    trainer
        .load(
            &scene.model,
            &OptimizerState::zeros(scene.model.vertex_count()),
        )
        .unwrap();
    for _ in 0..2 {
        trainer.step(&step_at(&scene, 0.1)).unwrap();
    }
    let results = trainer.results().unwrap();
    assert_eq!(results.len(), 2);
    for r in &results {
        assert_eq!(r.loss, 0.0);
        assert!(r.non_finite.is_empty());
    }
    assert!(
        trainer
            .last_image_gradient(0)
            .unwrap()
            .iter()
            .all(|&g| g == 0.0)
    );
    let mut stored = scene.model.clone();
    let state = trainer.store(&mut stored).unwrap();
    assert_eq!(stored, scene.model);
    assert_eq!(state.positions.steps, 2);
}

#[test]
fn bad_views_and_steps_are_errors_not_panics() {
    let Some(ctx) = context() else { return };
    let gpu = WgpuBackend::new(ctx).unwrap();
    let scene = parity_scenes().swap_remove(0);
    let good = flat_view(&scene, 1.0);
    let mut short = good.clone();
    short.weights.pop();
    let mut nan = good.clone();
    nan.target[7] = f32::NAN;
    let mut negative = good.clone();
    negative.weights[3] = -1.0;
    for (view, expect) in [
        (short, "weights"),
        (nan, "not finite"),
        (negative, "weight 3"),
    ] {
        let err = DeviceTrainer::new(&gpu, &[view], AdamSettings::default())
            .err()
            .unwrap();
        assert!(format!("{err:#}").contains(expect), "{err:#}");
    }
    assert!(DeviceTrainer::new(&gpu, &[], AdamSettings::default()).is_err());
    let mut trainer = DeviceTrainer::new(&gpu, &[good], AdamSettings::default()).unwrap();
    let step = step_at(&scene, 0.0);
    let err = trainer.step(&step).unwrap_err();
    assert!(
        format!("{err:#}").contains("before a model was loaded"),
        "{err:#}"
    );
    trainer
        .load(
            &scene.model,
            &OptimizerState::zeros(scene.model.vertex_count()),
        )
        .unwrap();
    let err = trainer
        .step(&Step {
            view: 3,
            ..step.clone()
        })
        .unwrap_err();
    assert!(format!("{err:#}").contains("view 3"), "{err:#}");
    let err = trainer
        .step(&Step {
            background: [f32::NAN, 0.0, 0.0],
            ..step.clone()
        })
        .unwrap_err();
    assert!(format!("{err:#}").contains("not finite"), "{err:#}");
    let err = trainer
        .load(
            &scene.model,
            &OptimizerState::zeros(scene.model.vertex_count() + 1),
        )
        .unwrap_err();
    assert!(format!("{err:#}").contains("moments"), "{err:#}");
}
