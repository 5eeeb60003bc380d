//! Cropped device training steps: a step that renders, scores and
//! back-propagates only the footprint (`Region::Footprint`) takes the same
//! loss and moves the parameters as the whole-frame step, up to float-atomic
//! summation noise, and matches objectsplat_raster's CPU loss and gradient on
//! the CPU backend's render. Steps never wait for the device and, once the
//! pools have grown, create no buffer.
mod support;

use objectsplat_optim::{LearningRates, Optim};
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::loss::DEFAULT_LAMBDA_DSSIM;
use objectsplat_raster::{Model, RenderSettings};
use objectsplat_raster_gpu::WgpuBackend;
use objectsplat_raster_gpu::training::{DeviceTrainer, Step, StepResult, TrainingView};
use support::{
    FROZEN, Scene, backend, cpu_loss, footprint, fresh_optim, loaded_trainer, object_view,
    relative_difference, small_object_scene,
};

const RATES: LearningRates = LearningRates {
    positions: 1e-3,
    sh_dc: 1e-2,
    sh_rest: 1e-3,
    opacity: 2e-2,
};
const BACKGROUNDS: [[f32; 3]; 3] = [[0.2, 0.7, 0.4], [0.9, 0.1, 0.3], [0.5, 0.5, 0.05]];

/// The object's own pixels: a box inside its projection.
const OWN: PixelRect = PixelRect {
    x0: 50,
    y0: 34,
    x1: 70,
    y1: 56,
};

fn scene_and_view() -> (Scene, TrainingView) {
    let scene = small_object_scene(80, 21);
    let view = object_view(&scene, OWN, 5);
    (scene, view)
}

fn step(scene: &Scene, region: Region, background: [f32; 3], rates: LearningRates) -> Step {
    Step {
        view: 0,
        background,
        render: RenderSettings {
            region,
            ..scene.settings.clone()
        },
        learning_rates: rates,
        ..support::step_at(scene, 0.0)
    }
}

/// Every parameter of `m`: vertex positions, SH coefficients, opacity logits.
fn flat(m: &Model<f32>) -> Vec<f32> {
    let sh = m.sh.iter().flatten().flatten();
    let positions = m.vertices.iter().flatten();
    positions
        .chain(sh)
        .chain(&m.opacity_logits)
        .copied()
        .collect()
}

/// A trainer on the object's one view, holding its model.
fn object_trainer(gpu: &WgpuBackend, scene: &Scene, view: &TrainingView) -> DeviceTrainer {
    let views = std::slice::from_ref(view);
    loaded_trainer(gpu, views, &scene.model)
}

/// Three Adam steps over the three backgrounds; the losses and the model after.
fn train(
    gpu: &WgpuBackend,
    scene: &Scene,
    view: &TrainingView,
    region: Region,
) -> (Vec<StepResult>, Model<f32>, Optim) {
    let mut trainer = object_trainer(gpu, scene, view);
    for b in BACKGROUNDS {
        trainer.step(&step(scene, region, b, RATES)).unwrap();
    }
    let results = trainer.results().unwrap();
    let mut model = scene.model.clone();
    let mut optim = fresh_optim(&model);
    trainer.store(&mut model, &mut optim).unwrap();
    (results, model, optim)
}

#[test]
fn cropped_steps_equal_whole_frame_steps() {
    let Some(gpu) = backend() else { return };
    let (scene, view) = scene_and_view();
    let (whole_losses, whole, whole_state) = train(&gpu, &scene, &view, Region::Full);
    let (crop_losses, cropped, crop_state) = train(&gpu, &scene, &view, footprint());
    for (a, b) in crop_losses.iter().zip(&whole_losses) {
        assert!(a.non_finite.is_empty() && b.non_finite.is_empty());
        let d = (a.loss as f64 - b.loss as f64).abs() / b.loss as f64;
        eprintln!(
            "loss cropped {} whole {} (relative {d:.2e})",
            a.loss, b.loss
        );
        assert!(d <= 1e-5, "loss differs by {d:.3e}");
    }
    // The gradients behind the moments, and the moved parameters, agree up
    // to the float-atomic order of the backward sums.
    let names = ["positions", "sh", "opacity logits"];
    for ((name, a), b) in names
        .into_iter()
        .zip(crop_state.groups())
        .zip(whole_state.groups())
    {
        let d = relative_difference(a.first_moment(), b.first_moment(), 1e-20);
        eprintln!("{name}: first moments differ by {d:.2e}");
        assert!(d <= 1e-4, "{name}: first moments differ by {d:.3e}");
    }
    let before = flat(&scene.model);
    let moved =
        |m: &Model<f32>| -> Vec<f32> { flat(m).iter().zip(&before).map(|(a, b)| a - b).collect() };
    let d = relative_difference(&moved(&cropped), &moved(&whole), 1e-20);
    eprintln!("parameter updates differ by {d:.2e}");
    assert!(d <= 1e-3, "parameter updates differ by {d:.3e}");
    assert!(moved(&whole).iter().any(|&x| x != 0.0));
}

#[test]
fn a_cropped_step_matches_the_cpu_loss_on_the_cpu_render() {
    let Some(gpu) = backend() else { return };
    let (scene, view) = scene_and_view();
    let mut trainer = object_trainer(&gpu, &scene, &view);
    let pixels = (scene.camera.width * scene.camera.height) as usize;
    for b in BACKGROUNDS {
        trainer.step(&step(&scene, footprint(), b, FROZEN)).unwrap();
        let got = trainer.results().unwrap();
        let got_grad = trainer.last_image_gradient(0).unwrap();
        let want = cpu_loss(&scene.model, &view, &scene.settings, b).loss;
        let loss_error = (got[0].loss as f64 - want.value as f64).abs() / want.value as f64;
        let grad_error = relative_difference(&got_grad, &want.grad, 1e-12);
        eprintln!("background {b:?}: loss {loss_error:.2e}, gradient {grad_error:.2e}");
        assert!(loss_error < 1e-5, "loss differs by {loss_error:.3e}");
        assert!(grad_error < 1e-3, "gradient differs by {grad_error:.3e}");
        // The crop rendered a part of the frame: the gradient outside is exactly 0.
        let zero = got_grad
            .chunks_exact(3)
            .filter(|g| g.iter().all(|&x| x == 0.0));
        assert!(zero.count() > pixels / 3);
    }
}

#[test]
fn steps_do_not_wait_for_the_device_and_create_no_buffers_once_grown() {
    let Some(gpu) = backend() else { return };
    let (scene, view) = scene_and_view();
    let mut trainer = object_trainer(&gpu, &scene, &view);
    // Warm-up: the pools grow to the model, the entries, the image and a
    // readback of nine results.
    for region in [Region::Full, footprint(), footprint()] {
        for b in BACKGROUNDS {
            trainer.step(&step(&scene, region, b, RATES)).unwrap();
        }
    }
    trainer.results().unwrap();
    let (created, syncs) = (trainer.buffers_created(), trainer.host_syncs());
    for region in [footprint(), Region::Full, footprint()] {
        for b in BACKGROUNDS {
            trainer.step(&step(&scene, region, b, RATES)).unwrap();
        }
    }
    assert_eq!(
        trainer.host_syncs() - syncs,
        0,
        "a step waited for the device"
    );
    let results = trainer.results().unwrap();
    assert_eq!(results.len(), 9);
    assert_eq!(
        trainer.host_syncs() - syncs,
        1,
        "one readback for nine results"
    );
    assert_eq!(trainer.replays(), 0, "a step outgrew its buffers");
    assert_eq!(trainer.buffers_created(), created, "steps created buffers");
    let before = trainer.host_syncs();
    trainer
        .evaluate(&[0], &scene.settings, DEFAULT_LAMBDA_DSSIM)
        .unwrap();
    assert_eq!(
        trainer.host_syncs() - before,
        1,
        "one readback per evaluation"
    );
    assert_eq!(
        trainer.buffers_created(),
        created,
        "the evaluation created buffers"
    );
}

#[test]
fn a_margin_below_the_loss_window_is_an_error() {
    let Some(gpu) = backend() else { return };
    let (scene, view) = scene_and_view();
    let mut trainer = object_trainer(&gpu, &scene, &view);
    let narrow = Region::Footprint {
        include: PixelRect::default(),
        margin: 4,
    };
    let err = trainer
        .step(&step(&scene, narrow, BACKGROUNDS[0], RATES))
        .unwrap_err();
    assert!(format!("{err:#}").contains("margin"), "{err:#}");
}
