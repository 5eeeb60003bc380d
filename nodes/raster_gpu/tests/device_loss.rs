//! The device training step's loss and image gradient equal
//! objectsplat_raster::loss::photometric on the CPU backend's render of the same
//! model: weighted pixels, unsupervised pixels and pixels whose target is the
//! step's background colour. Learning rates of 0 leave the parameters as they were.
mod support;

use objectsplat_optim::Optim;
use objectsplat_raster_gpu::training::{DeviceTrainer, Step, Trained, TrainingView};
use support::{
    FROZEN, Rng, backend, cpu_loss, flat_view, fresh_optim, loaded_trainer, parity_scenes,
    relative_difference, step_at,
};

#[test]
fn device_loss_and_image_gradient_match_the_cpu_loss() {
    let Some(gpu) = backend() else { return };
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
        let view = TrainingView::photometric(camera, target, weights, from_background);
        let views = std::slice::from_ref(&view);
        let mut trainer = loaded_trainer(&gpu, views, &scene.model);
        trainer
            .step(&Step {
                background,
                learning_rates: FROZEN,
                ..step_at(&scene, 0.0)
            })
            .unwrap();
        let results = trainer.results().unwrap();
        let got_grad = trainer.last_image_gradient(0).unwrap();

        let want = cpu_loss(&scene.model, &view, &scene.settings, background).loss;
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
        trainer
            .store(&mut stored, &mut fresh_optim(&scene.model))
            .unwrap();
        assert_eq!(
            stored, scene.model,
            "{}: a step at learning rate 0 moved the model",
            scene.name
        );
    }
}

#[test]
fn a_view_without_supervised_pixels_gives_zero_loss_and_moves_nothing() {
    let Some(gpu) = backend() else { return };
    let scene = parity_scenes().swap_remove(0);
    let view = flat_view(&scene, 0.0);
    let mut trainer = loaded_trainer(&gpu, &[view], &scene.model);
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
    let mut optim = fresh_optim(&scene.model);
    trainer.store(&mut stored, &mut optim).unwrap();
    assert_eq!(stored, scene.model);
    assert_eq!(optim.groups().map(|g| g.steps), [2; 3]);
}

#[test]
fn bad_views_and_steps_are_errors_not_panics() {
    let Some(gpu) = backend() else { return };
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
        let err = DeviceTrainer::new(&gpu, &[view]).err().unwrap();
        assert!(format!("{err:#}").contains(expect), "{err:#}");
    }
    assert!(DeviceTrainer::new(&gpu, &[]).is_err());
    let mut trainer = DeviceTrainer::new(&gpu, &[good]).unwrap();
    let step = step_at(&scene, 0.0);
    let err = trainer.step(&step).unwrap_err();
    assert!(
        format!("{err:#}").contains("before a model was loaded"),
        "{err:#}"
    );
    let trained = Trained::all_of(&scene.model);
    trainer.load(&scene.model, trained, None).unwrap();
    let err = trainer.step(&step).unwrap_err();
    assert!(
        format!("{err:#}").contains("without optimizer state"),
        "{err:#}"
    );
    trainer
        .load(&scene.model, trained, Some(&fresh_optim(&scene.model)))
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
    let wrong = Optim::new(FROZEN, scene.model.vertex_count() + 1).unwrap();
    let err = trainer
        .load(&scene.model, trained, Some(&wrong))
        .unwrap_err();
    assert!(format!("{err:#}").contains("Adam state"), "{err:#}");
    let err = trainer
        .load(
            &scene.model,
            Trained {
                faces: scene.model.face_count() + 1,
                ..trained
            },
            None,
        )
        .unwrap_err();
    assert!(format!("{err:#}").contains("trained"), "{err:#}");
}
