//! The device training step applies Adam exactly as documented (moments,
//! bias correction, the SH DC/rest learning-rate split) to a gradient that
//! matches the CPU backend's gradient of the CPU loss, and flags what turns
//! non-finite instead of carrying on silently.
mod support;

use objectsplat_optim::{AdamGroup, LearningRates};
use objectsplat_raster::{CpuBackend, Model, OutputGrads, RenderBackend};
use objectsplat_raster_gpu::training::{Step, TrainingView};
use support::{
    Rng, backend, cpu_loss, flat_view, fresh_optim, loaded_trainer, parity_scenes,
    relative_difference, step_at,
};

/// Adam's reference settings written out, not read from objectsplat-optim:
/// the checks below use these numbers (and check the optimizer holds them).
struct AdamSettings {
    beta1: f64,
    beta2: f64,
    eps: f64,
}
const ADAM: AdamSettings = AdamSettings {
    beta1: 0.9,
    beta2: 0.999,
    eps: 1e-15,
};
const RATES: LearningRates = LearningRates {
    positions: 1e-3,
    sh_dc: 2e-2,
    sh_rest: 1e-3,
    opacity: 5e-2,
};

fn flat(model: &Model<f32>) -> [Vec<f32>; 3] {
    [
        model.vertices.concat(),
        model.sh.iter().flatten().flatten().copied().collect(),
        model.opacity_logits.clone(),
    ]
}

/// p_t = p_{t−1} − lr·(m_t/bc1)/(√(v_t/bc2) + ε), in f64 from the device's own moments.
fn check_update(
    name: &str,
    before: &[f32],
    after: &[f32],
    state: &AdamGroup,
    lr: impl Fn(usize) -> f64,
) {
    let t = state.steps as i32;
    let (first, second) = (state.first_moment(), state.second_moment());
    let (bc1, bc2) = (1.0 - ADAM.beta1.powi(t), 1.0 - ADAM.beta2.powi(t));
    let mut worst = 0.0f64;
    for i in 0..before.len() {
        let (m, v) = (first[i] as f64, second[i] as f64);
        let want = before[i] as f64 - lr(i) * (m / bc1) / ((v / bc2).sqrt() + ADAM.eps);
        let err = (after[i] as f64 - want).abs() / (lr(i) * 1e-4 + 1e-6 * want.abs());
        worst = worst.max(err);
    }
    assert!(worst <= 1.0, "{name}: update off by {worst:.2} × tolerance");
}

#[test]
fn device_adam_follows_the_formula_on_the_cpu_gradient() {
    let Some(gpu) = backend() else { return };
    let cpu = CpuBackend::new(2);
    let mut rng = Rng(99);
    let scene = parity_scenes().swap_remove(3); // random soup, SH degree 3
    let camera = scene.camera;
    let pixels = (camera.width * camera.height) as usize;
    let target: Vec<f32> = (0..pixels * 3)
        .map(|_| rng.uniform(0.0, 1.0) as f32)
        .collect();
    let weights = vec![1.0f32; pixels];
    let view = TrainingView::photometric(camera, target, weights, vec![false; pixels]);
    let background = [0.3f32, 0.1, 0.7];
    let step = Step {
        background,
        learning_rates: RATES,
        ..step_at(&scene, 0.0)
    };
    let mut trainer = loaded_trainer(&gpu, std::slice::from_ref(&view), &scene.model);

    let mut model = scene.model.clone();
    let mut optim = fresh_optim(&model);
    assert_eq!(
        (optim.adam.beta1, optim.adam.beta2, optim.adam.eps),
        (ADAM.beta1, ADAM.beta2, ADAM.eps)
    );
    let mut previous = optim.clone();
    for t in 1..=3u64 {
        // The CPU's gradient of the CPU loss at the current parameters.
        // No pixel is the background's: the loss compares with the target itself.
        let at_model = cpu_loss(&model, &view, &scene.settings, background);
        let (saved, loss) = (at_model.saved, at_model.loss);
        let g = cpu
            .backward(&model, &saved, &OutputGrads::color_only(&loss.grad))
            .unwrap();
        let cpu_grads = [
            g.vertices.concat(),
            g.sh.iter()
                .flatten()
                .flatten()
                .copied()
                .collect::<Vec<f32>>(),
            g.opacity_logits.clone(),
        ];

        trainer.step(&step).unwrap();
        let before = flat(&model);
        trainer.store(&mut model, &mut optim).unwrap();
        let after = flat(&model);
        let names = ["positions", "sh", "opacity logits"];
        let tensors = names.into_iter().zip(optim.groups()).zip(previous.groups());
        for (k, ((name, now), before_state)) in tensors.enumerate() {
            assert_eq!(now.steps, t, "{name}");
            let (first, first_before) = (now.first_moment(), before_state.first_moment());
            // The device's gradient, recovered from m_t = β1·m_{t−1} + (1 − β1)·g.
            let device_grad: Vec<f32> = (0..first.len())
                .map(|i| {
                    ((first[i] as f64 - ADAM.beta1 * first_before[i] as f64) / (1.0 - ADAM.beta1))
                        as f32
                })
                .collect();
            let d = relative_difference(&device_grad, &cpu_grads[k], 1e-12);
            eprintln!("step {t}: {name}: device vs cpu gradient {d:.2e}");
            assert!(d < 2e-3, "step {t}: {name} gradient differs by {d:.3e}");
            // v_t = β2·v_{t−1} + (1 − β2)·g² with the same g.
            for (i, &g) in device_grad.iter().enumerate() {
                let g = g as f64;
                let want = ADAM.beta2 * before_state.second_moment()[i] as f64
                    + (1.0 - ADAM.beta2) * g * g;
                let got = now.second_moment()[i] as f64;
                assert!(
                    (got - want).abs() <= 1e-4 * want.abs() + 1e-30,
                    "step {t}: {name} second moment {i}: {got} vs {want}"
                );
            }
            let lr = |i: usize| match k {
                0 => RATES.positions,
                1 if i % 48 < 3 => RATES.sh_dc,
                1 => RATES.sh_rest,
                _ => RATES.opacity,
            };
            check_update(name, &before[k], &after[k], now, lr);
        }
        previous = optim.clone();
    }
    let results = trainer.results().unwrap();
    assert_eq!(results.len(), 3);
    assert!(results.iter().all(|r| r.non_finite.is_empty()));
    // Three steps of descent lower the loss on this one view.
    assert!(results[2].loss < results[0].loss, "{results:?}");
}

#[test]
fn overflowing_parameters_are_flagged_not_hidden() {
    let Some(gpu) = backend() else { return };
    let scene = parity_scenes().swap_remove(0);
    let view = flat_view(&scene, 1.0);
    let mut trainer = loaded_trainer(&gpu, &[view], &scene.model);
    // The first update moves every value by about the learning rate; the second
    // (|m̂/√v̂| ≈ 0.67 even where the gradient has vanished) passes f32's 3.4e38.
    for _ in 0..3 {
        trainer.step(&step_at(&scene, 3e38)).unwrap();
    }
    let results = trainer.results().unwrap();
    eprintln!("{results:?}");
    let first = results.iter().find(|r| !r.non_finite.is_empty());
    let first = first.expect("a learning rate of 3e38 must overflow something");
    assert!(
        first.non_finite.iter().any(|w| [
            "the vertex positions",
            "the SH coefficients",
            "the opacity logits",
            "the render"
        ]
        .contains(w)),
        "{first:?}"
    );
}
