//! Training iterations and evaluations on a wgpu device ([`DeviceTrainer`])
//! inside the host's training loop. The host keeps the schedule, the random
//! view and background choices, densification, pruning and connectivity; the
//! device keeps the parameters, Adam's moments and the per-face weight
//! statistics between those events, renders only each view's footprint when
//! cropping is on (as the host steps do), and scores the held-out views.
//! Parameters cross to the host only when an event needs the model, losses
//! only at the loss-log points, face statistics only when asked for.
//!
//! Face statistics: the device keeps the running per-face maxima of the
//! current and previous epoch (`face_stats.rs`' two arrays) while it holds the
//! newest model; the host's copy, remapped through topology edits, goes to the
//! device with the next upload of the model ([`DeviceSteps::set_face_weights`]).
//! The epoch count stays with the host's `FaceWeights`.

use crate::host_steps::HeldOut;
use crate::optim::Optim;
use crate::supervision::{ComponentData, supervision_parts};
use anyhow::{Result, bail};
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::loss::{CROP_MARGIN, DEFAULT_LAMBDA_DSSIM};
use objectsplat_raster::{Model, RenderSettings};
use objectsplat_wgpu::WgpuBackend;
use objectsplat_wgpu::training::{
    AdamSettings, DeviceTrainer, FaceWeightArrays, LearningRates, Moments, OptimizerState, Step,
    TrainingView, ViewScore,
};
use std::collections::VecDeque;

/// Which side holds the newest parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Newest {
    Host,
    Device,
    Both,
}

pub(crate) struct DeviceSteps {
    trainer: DeviceTrainer,
    newest: Newest,
    /// (iteration, view index) of the steps whose losses have not come back yet.
    in_flight: VecDeque<(u64, usize)>,
    /// Losses of the steps that came back and were not yet taken.
    arrived: Vec<f32>,
    /// View index within `data.views` of each device view: the training
    /// views first (device view = training slot), then the held-out views.
    views: Vec<usize>,
    /// Device view of each of `data.views` that was uploaded.
    device_view: Vec<Option<usize>>,
    crop: bool,
    /// Face statistics the host set for its model, uploaded with it.
    host_face_weights: Option<FaceWeightArrays>,
    /// The device's face statistics as the last pull read them (valid while
    /// both sides hold the same model).
    pulled_face_weights: Option<FaceWeightArrays>,
    /// Training steps taken and the share of their frames they rendered, summed.
    steps: u64,
    rendered: f64,
    uploads: u64,
    downloads: u64,
    evaluations: u64,
}

impl Optim {
    fn device_state(&self) -> OptimizerState {
        let g = &self.adam.groups;
        let moments = |i: usize| Moments {
            first: g[i].first_moment().to_vec(),
            second: g[i].second_moment().to_vec(),
            steps: g[i].steps,
        };
        // The SH group's rows are the device's layout already (16×3 per vertex, DC first).
        OptimizerState {
            positions: moments(self.vertices),
            sh: moments(self.sh),
            opacity_logits: moments(self.opacity),
        }
    }

    fn set_device_state(&mut self, state: OptimizerState) -> Result<()> {
        let g = &mut self.adam.groups;
        for (group, m) in [
            (self.vertices, state.positions),
            (self.sh, state.sh),
            (self.opacity, state.opacity_logits),
        ] {
            g[group].set_moments(m.first, m.second, m.steps)?;
        }
        Ok(())
    }

    fn learning_rates(&self) -> LearningRates {
        let g = &self.adam.groups;
        LearningRates {
            positions: g[self.vertices].lr,
            sh_dc: g[self.sh].lr,
            sh_rest: g[self.sh].lr_rest,
            opacity: g[self.opacity].lr,
        }
    }
}

/// Held-out loss and PSNR from per-view scores, as `HostSteps::evaluate`
/// defines them: the mean loss over the views, and the PSNR of one MSE pooled
/// over every supervised pixel and channel of them.
fn held_out(scores: &[ViewScore]) -> HeldOut {
    let loss: f64 = scores.iter().map(|s| s.loss).sum();
    let squared: f64 = scores.iter().map(|s| s.squared_error).sum();
    let weight: f64 = scores.iter().map(|s| 3.0 * s.total_weight).sum();
    let mse = squared / weight.max(1.0);
    HeldOut {
        loss: loss / scores.len().max(1) as f64,
        // A perfect fit is capped at 100 dB rather than reported as infinity.
        psnr: if mse > 1e-10 {
            -10.0 * mse.log10()
        } else {
            100.0
        },
    }
}

impl DeviceSteps {
    /// Uploads the training views `train` and the held-out views `held_out`
    /// (indices into `data.views`; a view in both is uploaded once). With
    /// `crop`, steps and evaluations render each view's footprint only.
    pub fn new(
        backend: &WgpuBackend,
        data: &ComponentData,
        train: &[usize],
        held_out: &[usize],
        optim: &Optim,
        crop: bool,
    ) -> Result<DeviceSteps> {
        let mut views: Vec<usize> = train.to_vec();
        views.extend(held_out.iter().filter(|v| !train.contains(v)));
        let mut device_view = vec![None; data.views.len()];
        for (slot, &v) in views.iter().enumerate() {
            let Some(entry) = device_view.get_mut(v) else {
                bail!("view {v} of {} views", data.views.len());
            };
            *entry = Some(slot);
        }
        let uploads: Vec<TrainingView> = views
            .iter()
            .map(|&i| {
                let view = &data.views[i];
                let (target, weights, from_background) = supervision_parts(view, data.kind);
                TrainingView {
                    camera: view.camera,
                    target,
                    weights,
                    from_background,
                }
            })
            .collect();
        let adam = AdamSettings {
            beta1: optim.adam.beta1,
            beta2: optim.adam.beta2,
            eps: optim.adam.eps,
        };
        Ok(DeviceSteps {
            trainer: DeviceTrainer::new(backend, &uploads, adam)?,
            newest: Newest::Host,
            in_flight: VecDeque::new(),
            arrived: Vec::new(),
            views,
            device_view,
            crop,
            host_face_weights: None,
            pulled_face_weights: None,
            steps: 0,
            rendered: 0.0,
            uploads: 0,
            downloads: 0,
            evaluations: 0,
        })
    }

    /// The region a pass renders: the view's footprint (the device adds the
    /// view's own supervision) or the whole frame.
    fn region(&self) -> Region {
        if self.crop {
            Region::Footprint {
                include: PixelRect::default(),
                margin: CROP_MARGIN,
            }
        } else {
            Region::Full
        }
    }

    /// Makes the host's model and optimizer state the newest, fetching them
    /// (and the face statistics, in the same readback) if needed; an error if
    /// a step since the last call diverged.
    pub fn pull(
        &mut self,
        model: &mut Model<f32>,
        optim: &mut Optim,
        data: &ComponentData,
    ) -> Result<()> {
        self.fetch(data)?;
        if self.newest == Newest::Device {
            let (state, faces) = self.trainer.store_with_face_weights(model)?;
            self.pulled_face_weights = Some(faces);
            optim.set_device_state(state)?;
            self.downloads += 1;
            self.newest = Newest::Both;
        }
        Ok(())
    }

    /// The host changed the model or the optimizer state (after [`DeviceSteps::pull`]).
    pub fn host_edited(&mut self) {
        self.newest = Newest::Host;
        self.host_face_weights = None;
        self.pulled_face_weights = None;
    }

    /// Puts the host's model on the device when the host holds the newest one.
    fn upload_if_newer(&mut self, model: &Model<f32>, optim: &Optim) -> Result<()> {
        if self.newest == Newest::Host {
            self.trainer.load(model, &optim.device_state())?;
            if let Some((current, previous)) = self.host_face_weights.take() {
                self.trainer.set_face_weights(&current, &previous)?;
            }
            self.uploads += 1;
            self.newest = Newest::Both;
        }
        Ok(())
    }

    /// One line for the training log: where the iterations ran and how often the model moved.
    pub fn summary(&self) -> String {
        format!(
            "iterations ran on the device (render, loss, backward and Adam on the GPU; {}); \
             {} held-out evaluations on the device; the model went to the device {} times \
             and came back {} times (densification, pruning, connectivity, checkpoints); \
             {} host waits for the device in all",
            match self.rendered_fraction() {
                Some(f) => format!("{:.0} % of the frame rendered on average", 100.0 * f),
                None => "no steps".into(),
            },
            self.evaluations,
            self.uploads,
            self.downloads,
            self.host_syncs()
        )
    }

    /// Times the host has waited for the device so far (readbacks).
    pub fn host_syncs(&self) -> u64 {
        self.trainer.host_syncs()
    }

    /// Mean share of the frame the training steps rendered (None before any step).
    pub fn rendered_fraction(&self) -> Option<f64> {
        (self.steps > 0).then(|| self.rendered / self.steps as f64)
    }

    /// Queues iteration `iteration` (1-based) on training view slot `slot`.
    pub fn step(
        &mut self,
        model: &Model<f32>,
        optim: &Optim,
        iteration: u64,
        slot: usize,
        background: [f32; 3],
        render: RenderSettings,
    ) -> Result<()> {
        self.upload_if_newer(model, optim)?;
        self.trainer.step(&Step {
            view: slot,
            background,
            render: RenderSettings {
                region: self.region(),
                ..render
            },
            learning_rates: optim.learning_rates(),
            lambda_dssim: DEFAULT_LAMBDA_DSSIM,
        })?;
        self.newest = Newest::Device;
        self.pulled_face_weights = None;
        self.in_flight.push_back((iteration, slot));
        if let Some(region) = self.trainer.last_region() {
            self.steps += 1;
            self.rendered += region.pixels() as f64 / self.trainer.view_pixels(slot) as f64;
        }
        Ok(())
    }

    /// The training model's loss and PSNR on `views` (indices into
    /// `data.views`, all uploaded at construction) over a black background,
    /// scored on the device with one readback (`HostSteps::evaluate`'s definitions).
    pub fn evaluate(
        &mut self,
        model: &Model<f32>,
        optim: &Optim,
        data: &ComponentData,
        views: &[usize],
        render: RenderSettings,
    ) -> Result<HeldOut> {
        self.upload_if_newer(model, optim)?;
        self.score(data, views, render)
    }

    /// As [`DeviceSteps::evaluate`] for a model the host holds that is not
    /// the training model (a checkpoint, the finally pruned model): it goes
    /// up without Adam state, and the next step uploads the training model
    /// again. The host must hold the newest training model ([`DeviceSteps::pull`]).
    pub fn evaluate_model(
        &mut self,
        model: &Model<f32>,
        data: &ComponentData,
        views: &[usize],
        render: RenderSettings,
    ) -> Result<HeldOut> {
        if self.newest == Newest::Device {
            bail!("evaluating another model would overwrite steps the host has not pulled");
        }
        self.trainer
            .load(model, &OptimizerState::zeros(model.vertex_count()))?;
        self.uploads += 1;
        self.newest = Newest::Host;
        self.host_face_weights = None;
        self.pulled_face_weights = None;
        self.score(data, views, render)
    }

    /// Scores the device's model on `views` (indices into `data.views`).
    fn score(
        &mut self,
        data: &ComponentData,
        views: &[usize],
        render: RenderSettings,
    ) -> Result<HeldOut> {
        let slots = views
            .iter()
            .map(|&v| match self.device_view.get(v).copied().flatten() {
                Some(slot) => Ok(slot),
                None => bail!(
                    "view {v} was not uploaded to the device (neither a training nor a held-out view)"
                ),
            })
            .collect::<Result<Vec<_>>>()?;
        let settings = RenderSettings {
            region: self.region(),
            ..render
        };
        let scores = match self
            .trainer
            .evaluate(&slots, &settings, DEFAULT_LAMBDA_DSSIM)
        {
            Ok(scores) => scores,
            Err(e) => {
                // A diverged step explains a non-finite evaluation better than the evaluation does.
                self.fetch(data)?;
                return Err(e);
            }
        };
        self.evaluations += 1;
        Ok(held_out(&scores))
    }

    /// The device's running per-face maxima of the blending weight (current
    /// and previous epoch) when the device holds the newest model: those the
    /// last [`DeviceSteps::pull`] brought along, else read back. None when the
    /// host holds the newest model (its own statistics are the newest then).
    pub fn face_weights(&mut self) -> Result<Option<FaceWeightArrays>> {
        match self.newest {
            Newest::Host => Ok(None),
            Newest::Both => match self.pulled_face_weights.take() {
                Some(faces) => Ok(Some(faces)),
                None => self.trainer.face_weights().map(Some),
            },
            Newest::Device => self.trainer.face_weights().map(Some),
        }
    }

    /// The host's face statistics for its model (after remapping them through
    /// an edit): they go to the device with the model.
    pub fn set_face_weights(&mut self, current: Vec<f32>, previous: Vec<f32>) -> Result<()> {
        self.pulled_face_weights = None;
        if self.newest == Newest::Host {
            self.host_face_weights = Some((current, previous));
            Ok(())
        } else {
            self.trainer.set_face_weights(&current, &previous)
        }
    }

    /// Every training view has been rendered once more (the host's
    /// `FaceWeights::end_epoch`): the device's statistics follow while it holds
    /// the newest model; the host's own copy is the host's to roll.
    pub fn end_epoch(&mut self) {
        self.pulled_face_weights = None;
        if self.newest != Newest::Host {
            self.trainer.end_epoch();
        }
    }

    /// The losses of the steps queued since the last call, in order; an error
    /// naming the first step in which something turned non-finite.
    pub fn losses(&mut self, data: &ComponentData) -> Result<Vec<f32>> {
        self.fetch(data)?;
        Ok(std::mem::take(&mut self.arrived))
    }

    fn fetch(&mut self, data: &ComponentData) -> Result<()> {
        for result in self.trainer.results()? {
            let Some((iteration, slot)) = self.in_flight.pop_front() else {
                bail!("the device reported more steps than were queued");
            };
            if !result.non_finite.is_empty() {
                bail!(
                    "training of {:?} diverged at iteration {iteration}: {} became non-finite \
                     (view {:?}, loss {}; parameters overflowed, lower the learning rates)",
                    data.name,
                    result.non_finite.join(", "),
                    data.views[self.views[slot]].name,
                    result.loss
                );
            }
            self.arrived.push(result.loss);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    //! DeviceSteps against HostSteps on the CPU backend: the same step (loss,
    //! moved parameters, face statistics) and the same held-out evaluation,
    //! within the device tolerances of objectsplat-wgpu's tests.
    use super::*;
    use crate::face_stats::FaceWeights;
    use crate::host_steps::HostSteps;
    use crate::schedule::Schedule;
    use crate::supervision::View;
    use glam::DVec3;
    use objectsplat_core::component::{IGNORE, OTHER, OWN};
    use objectsplat_core::{Camera, ComponentKind, Split};
    use objectsplat_gpu::{AdapterChoice, GpuContext};
    use objectsplat_raster::{CpuBackend, SH_COEFFS};

    fn gpu() -> Option<WgpuBackend> {
        match GpuContext::shared(AdapterChoice::Auto) {
            Ok((ctx, _)) => Some(WgpuBackend::new(ctx).unwrap()),
            Err(e) => {
                if std::env::var("OBJECTSPLAT_REQUIRE_ADAPTER").is_ok_and(|v| v == "1") {
                    panic!("no wgpu adapter but OBJECTSPLAT_REQUIRE_ADAPTER=1: {e:#}");
                }
                eprintln!("SKIPPED (no wgpu adapter): {e:#}");
                None
            }
        }
    }

    /// xorshift64*: fixtures without files.
    struct Rng(u64);
    impl Rng {
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            let u = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11;
            lo + (hi - lo) * u as f64 / (1u64 << 53) as f64
        }
    }

    /// A small object (60 random triangles near the origin) and an object
    /// component of four 96×72 views: OWN pixels in a box around the object's
    /// image, OTHER pixels elsewhere and a band of IGNORE pixels; the last view is held out.
    fn object() -> (Model<f32>, ComponentData) {
        let mut rng = Rng(0x5eed_0042);
        let mut model = Model::<f32>::empty();
        model.sh_degree = 2;
        model.opacity_floor = 0.0;
        for f in 0..60u32 {
            let c = [0, 1, 2].map(|_| rng.uniform(-0.3, 0.3));
            let r = rng.uniform(0.1, 0.25);
            for _ in 0..3 {
                model
                    .vertices
                    .push([0, 1, 2].map(|a| (c[a] + rng.uniform(-r, r)) as f32));
                let mut sh = [[0f32; 3]; SH_COEFFS];
                for (k, row) in sh.iter_mut().enumerate() {
                    let amp = if k == 0 { 1.5 } else { 0.4 };
                    *row = [0, 1, 2].map(|_| rng.uniform(-amp, amp) as f32);
                }
                model.sh.push(sh);
                model.opacity_logits.push(rng.uniform(-1.0, 4.0) as f32);
            }
            model.faces.push([3 * f, 3 * f + 1, 3 * f + 2]);
        }
        let eyes = [
            DVec3::new(0.2, -0.3, -3.0),
            DVec3::new(-0.5, 0.2, -2.8),
            DVec3::new(0.6, 0.4, -3.1),
            DVec3::new(-0.1, -0.6, -2.9),
        ];
        let (w, h) = (96u32, 72u32);
        let views = eyes
            .iter()
            .enumerate()
            .map(|(k, &eye)| {
                let camera = Camera::look_at(w, h, 86.0, 86.0, eye, DVec3::ZERO, DVec3::Y);
                let labels = (0..w * h)
                    .map(|p| {
                        let (x, y) = (p % w, p / w);
                        if x.abs_diff(w / 2) < 12 && y.abs_diff(h / 2) < 10 {
                            OWN
                        } else if y % 9 == 4 {
                            IGNORE
                        } else {
                            OTHER
                        }
                    })
                    .collect();
                View {
                    name: format!("v{k}"),
                    camera,
                    target: (0..w * h * 3)
                        .map(|_| rng.uniform(0.0, 1.0) as f32)
                        .collect(),
                    labels,
                    split: if k == 3 { Split::Test } else { Split::Train },
                }
            })
            .collect();
        let data = ComponentData {
            name: "object".into(),
            kind: ComponentKind::Object,
            views,
            occluders: None,
            depth_points: Vec::new(),
        };
        (model, data)
    }

    fn optim(model: &Model<f32>) -> Optim {
        let schedule = Schedule::new(100, &serde_json::Map::new()).unwrap();
        Optim::new(&schedule, model.vertex_count()).unwrap()
    }

    fn flat(m: &Model<f32>) -> Vec<f64> {
        m.vertices
            .iter()
            .flatten()
            .chain(m.sh.iter().flatten().flatten())
            .chain(&m.opacity_logits)
            .map(|&x| x as f64)
            .collect()
    }

    /// ‖a − b‖ / ‖b‖.
    fn relative(a: &[f64], b: &[f64]) -> f64 {
        let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
        let n: f64 = b.iter().map(|y| y * y).sum();
        (d / n.max(1e-300)).sqrt()
    }

    #[test]
    fn device_evaluation_equals_the_host_evaluation() {
        let Some(gpu) = gpu() else { return };
        let (model, data) = object();
        let optim = optim(&model);
        let cpu = CpuBackend::new(2);
        let render = RenderSettings::for_model(&model);
        for crop in [true, false] {
            let mut device = DeviceSteps::new(&gpu, &data, &[0, 1, 2], &[3], &optim, crop).unwrap();
            let mut host = HostSteps::new(&cpu, &data, crop, false).unwrap();
            for views in [&[3usize][..], &[0, 1, 2, 3][..]] {
                let got = device
                    .evaluate(&model, &optim, &data, views, render.clone())
                    .unwrap();
                let want = host.evaluate(&model, &data, views, &render).unwrap();
                eprintln!("crop {crop}, views {views:?}: device {got:?}, host {want:?}");
                assert!(
                    (got.loss - want.loss).abs() <= 1e-5 * want.loss,
                    "{got:?} vs {want:?}"
                );
                assert!((got.psnr - want.psnr).abs() <= 1e-3, "{got:?} vs {want:?}");
            }
            let err = DeviceSteps::new(&gpu, &data, &[0], &[], &optim, crop)
                .unwrap()
                .evaluate(&model, &optim, &data, &[3], render.clone())
                .unwrap_err();
            assert!(format!("{err:#}").contains("not uploaded"), "{err:#}");
        }
    }

    #[test]
    fn a_device_step_matches_the_host_step() {
        let Some(gpu) = gpu() else { return };
        let (model, data) = object();
        let cpu = CpuBackend::new(2);
        let render = RenderSettings::for_model(&model);
        let backgrounds = [[0.3f32, 0.8, 0.1], [0.7, 0.2, 0.5]];
        let slots = [1usize, 0];

        let (mut host_model, mut host_optim) = (model.clone(), optim(&model));
        let mut host = HostSteps::new(&cpu, &data, true, false).unwrap();
        let mut host_stats = FaceWeights::new(model.face_count());
        let mut host_losses = Vec::new();
        for (&slot, &b) in slots.iter().zip(&backgrounds) {
            host_losses.push(
                host.step(
                    &mut host_model,
                    &mut host_optim,
                    &data,
                    slot,
                    b,
                    &render,
                    0.0,
                    0.0,
                    &mut host_stats,
                )
                .unwrap(),
            );
        }

        let (mut device_model, mut device_optim) = (model.clone(), optim(&model));
        let mut device =
            DeviceSteps::new(&gpu, &data, &[0, 1, 2], &[3], &device_optim, true).unwrap();
        for (k, (&slot, &b)) in slots.iter().zip(&backgrounds).enumerate() {
            device
                .step(
                    &device_model,
                    &device_optim,
                    k as u64 + 1,
                    slot,
                    b,
                    render.clone(),
                )
                .unwrap();
        }
        let losses = device.losses(&data).unwrap();
        device
            .pull(&mut device_model, &mut device_optim, &data)
            .unwrap();
        let fraction = device.rendered_fraction().unwrap();
        eprintln!("losses device {losses:?}, host {host_losses:?}; rendered {fraction:.2}");
        assert!(
            fraction < 0.8,
            "the object's footprint is part of the frame: {fraction}"
        );
        for (d, h) in losses.iter().zip(&host_losses) {
            assert!((*d as f64 - h).abs() <= 1e-5 * h, "loss {d} vs {h}");
        }
        let before = flat(&model);
        let moved = |m: &Model<f32>| -> Vec<f64> {
            flat(m).iter().zip(&before).map(|(a, b)| a - b).collect()
        };
        let d = relative(&moved(&device_model), &moved(&host_model));
        eprintln!("parameter updates differ by {d:.2e}");
        assert!(d <= 2e-3, "parameter updates differ by {d:.3e}");
        let g = &device_optim.adam.groups[device_optim.sh];
        let h = &host_optim.adam.groups[host_optim.sh];
        assert_eq!(g.steps, h.steps);

        // Face statistics: the same running maxima as the host step's records,
        // brought back by the pull (no further readback).
        let syncs = device.host_syncs();
        let (current, previous) = device.face_weights().unwrap().unwrap();
        assert_eq!(device.host_syncs(), syncs);
        let want = host_stats.max_weight();
        for (f, (a, b)) in current.iter().zip(&want).enumerate() {
            assert!((a - b).abs() <= 1e-4, "face {f}: {a} vs {b}");
        }
        assert!(previous.iter().all(|&w| w == 0.0));
        assert!(current.iter().any(|&w| w > 0.0));
    }

    #[test]
    fn host_face_statistics_go_to_the_device_with_the_model() {
        let Some(gpu) = gpu() else { return };
        let (model, data) = object();
        let optim = optim(&model);
        let render = RenderSettings::for_model(&model);
        let nf = model.face_count();
        let mut device = DeviceSteps::new(&gpu, &data, &[0, 1, 2], &[3], &optim, true).unwrap();
        // The host holds the newest model: its statistics wait for the upload.
        assert_eq!(device.face_weights().unwrap(), None);
        let current: Vec<f32> = (0..nf)
            .map(|f| if f % 2 == 0 { 2.0 } else { 0.0 })
            .collect();
        let previous: Vec<f32> = (0..nf).map(|f| f as f32 / nf as f32).collect();
        device
            .set_face_weights(current.clone(), previous.clone())
            .unwrap();
        device.end_epoch(); // the host rolled its own copy already
        device
            .step(&model, &optim, 1, 0, [0.5; 3], render.clone())
            .unwrap();
        let (now, before) = device.face_weights().unwrap().unwrap();
        assert_eq!(before, previous);
        // Weights of a step are at most 1: the even faces keep the host's 2.0.
        for f in 0..nf {
            if f % 2 == 0 {
                assert_eq!(now[f], 2.0);
            }
        }
        assert!(now.iter().enumerate().any(|(f, &w)| f % 2 == 1 && w > 0.0));
        device.end_epoch();
        let (now2, before2) = device.face_weights().unwrap().unwrap();
        assert_eq!(before2, now);
        assert!(now2.iter().all(|&w| w == 0.0));
        // Statistics of another face count are refused once the device holds the model.
        let err = device
            .set_face_weights(vec![0.0; nf + 1], vec![0.0; nf + 1])
            .unwrap_err();
        assert!(format!("{err:#}").contains("faces"), "{err:#}");
    }
}
