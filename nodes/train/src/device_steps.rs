//! Training iterations and evaluations on a wgpu device ([`DeviceTrainer`])
//! behind the loop's [`StepRunner`] interface. The loop keeps the schedule,
//! the random view and background choices, densification, pruning and
//! connectivity; the device keeps the parameters, Adam's moments and the
//! per-face weight statistics between those events, renders the trained
//! model with its frozen occluders (the background behind the objects, or an
//! object among its neighbours, whose layer is rendered into the view's
//! targets once, at upload), adds the depth loss at measured points and the
//! planar prior, renders only each
//! view's footprint when cropping is on (as the host steps do), and scores
//! the held-out views. Parameters cross to the host only at [`StepRunner::sync`],
//! losses when the device's result slots fill up or the loop waits for them.
//!
//! Face statistics: the device keeps the running per-face maxima of the
//! current and previous epoch (`face_stats.rs`' two arrays) while it holds the
//! newest model; the host's copy goes to the device with the next upload of
//! the model. The epoch count stays with the host's `FaceWeights`.

use crate::composite::Composite;
use crate::neighbours::render_layer;
use crate::point_depth::PointDepth;
use crate::steps::{HeldOut, StepInput, StepLoss, StepRunner, Subject, TrainingState};
use crate::supervision::{ComponentData, TargetPlanes, ViewSummary, supervision_parts};
use anyhow::{Result, bail};
use objectsplat_core::ComponentKind;
use objectsplat_core::component::OWN;
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::loss::{CROP_MARGIN, DEFAULT_LAMBDA_DSSIM};
use objectsplat_raster::{Model, RenderSettings};
use objectsplat_raster_gpu::WgpuBackend;
use objectsplat_raster_gpu::training::{
    DepthWeights, DeviceTrainer, Step, StepResult, Trained, TrainingView, ViewScore,
};
use std::collections::VecDeque;

/// Which side holds the newest parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Newest {
    Host,
    Device,
    Both,
}

pub(crate) struct DeviceSteps<'a> {
    data: &'a ComponentData,
    trainer: DeviceTrainer,
    composite: Option<Composite>,
    newest: Newest,
    /// (iteration, view index) of the steps whose results have not come back yet.
    in_flight: VecDeque<(u64, usize)>,
    /// Losses that came back and were not yet taken.
    arrived: Vec<StepLoss>,
    /// Device view of each of `data.views` that was uploaded: the training
    /// views first (device view = training slot), then the held-out views.
    device_view: Vec<Option<usize>>,
    crop: bool,
    /// Training steps whose results came back, and the share of their frames they rendered, summed.
    steps: u64,
    rendered: f64,
    uploads: u64,
    downloads: u64,
    evaluations: u64,
    /// The measured points each view sees (uploaded; kept for the free-space rule).
    points: PointDepth,
}

/// Held-out loss and PSNR from per-view scores, as the host's evaluation
/// defines them.
fn held_out(scores: &[ViewScore]) -> HeldOut {
    HeldOut::pooled(
        scores.iter().map(|s| s.loss).sum(),
        scores.len(),
        scores.iter().map(|s| s.squared_error).sum(),
        scores.iter().map(|s| 3.0 * s.total_weight).sum(),
    )
}

impl<'a> DeviceSteps<'a> {
    /// Uploads the training views `train` and the held-out views `held_out`
    /// (indices into `data.views`; a view in both is uploaded once), with the
    /// measured points each sees when `depth_supervised`. With `crop`, steps
    /// and evaluations render each view's footprint only; every pass takes
    /// `supersample²` samples per pixel. `world_scale` scales the depth
    /// thresholds of the frozen neighbours' renders.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        backend: &WgpuBackend,
        data: &'a ComponentData,
        train: &[usize],
        held_out: &[usize],
        crop: bool,
        depth_supervised: bool,
        supersample: u32,
        world_scale: f64,
    ) -> Result<Self> {
        let mut views: Vec<usize> = train.to_vec();
        views.extend(held_out.iter().filter(|v| !train.contains(v)));
        let mut device_view = vec![None; data.views.len()];
        for (slot, &v) in views.iter().enumerate() {
            let Some(entry) = device_view.get_mut(v) else {
                bail!("view {v} of {}", data.views.len());
            };
            *entry = Some(slot);
        }
        let points = if depth_supervised {
            PointDepth::new(&data.depth_points, data)
        } else {
            PointDepth::default()
        };
        // One view's whole-frame planes at a time on the host.
        let upload = |k: usize| {
            let i = views[k];
            let view = &data.views[i];
            let layer = match (&data.occluders, data.kind) {
                (Some(frozen), ComponentKind::Object) => {
                    let include = ViewSummary::of(view, data.rule()).include;
                    let settings = RenderSettings {
                        region: if crop {
                            Region::Footprint {
                                include,
                                margin: CROP_MARGIN,
                            }
                        } else {
                            Region::Full
                        },
                        ..RenderSettings::for_model(frozen).with_world_scale(world_scale)
                    };
                    Some(render_layer(
                        backend,
                        frozen,
                        &view.camera,
                        &settings,
                        supersample,
                    )?)
                }
                _ => None,
            };
            let TargetPlanes {
                target,
                weights,
                from_background,
                background_share,
            } = supervision_parts(view, data.rule(), layer.as_ref());
            Ok(TrainingView {
                camera: view.camera,
                target,
                weights,
                from_background,
                background_share: if layer.is_some() {
                    background_share
                } else {
                    Vec::new()
                },
                own: view
                    .labels
                    .to_plane()
                    .into_iter()
                    .map(|l| l == OWN)
                    .collect(),
                points: points.of_view(i).to_vec(),
            })
        };
        let trainer =
            DeviceTrainer::streamed(backend, views.len(), upload)?.with_supersample(supersample)?;
        Ok(DeviceSteps {
            data,
            trainer,
            composite: data.occluders.as_ref().map(Composite::new).transpose()?,
            newest: Newest::Host,
            in_flight: VecDeque::new(),
            arrived: Vec::new(),
            device_view,
            crop,
            steps: 0,
            rendered: 0.0,
            uploads: 0,
            downloads: 0,
            evaluations: 0,
            points,
        })
    }

    /// Times the host has waited for the device so far (readbacks).
    pub fn host_syncs(&self) -> u64 {
        self.trainer.host_syncs()
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

    /// The settings of a pass of the trained model at `render` (with the
    /// occluders, at the composite's SH degree) or of it alone.
    fn pass_settings(&self, render: &RenderSettings, with_occluders: bool) -> RenderSettings {
        RenderSettings {
            region: self.region(),
            sh_degree: match (&self.composite, with_occluders) {
                (Some(c), true) => c.sh_degree(render.sh_degree),
                _ => render.sh_degree,
            },
            ..render.clone()
        }
    }

    /// Puts `model` on the device (with the occluders behind it), with
    /// `state`'s Adam state and statistics when it is the training model.
    fn load(&mut self, model: &Model<f32>, state: Option<&TrainingState>) -> Result<()> {
        let trained = Trained::all_of(model);
        let rendered = match self.composite.as_mut() {
            Some(c) => c.assemble(model, model.sigma),
            None => model,
        };
        self.trainer
            .load(rendered, trained, state.map(|s| &s.optim))?;
        if let Some(state) = state {
            let (current, previous) = state.stats.arrays();
            self.trainer.set_face_weights(current, previous)?;
        }
        self.uploads += 1;
        Ok(())
    }

    /// Puts the host's training state on the device when the host holds the newest one.
    fn upload_if_newer(&mut self, state: &TrainingState) -> Result<()> {
        if self.newest == Newest::Host {
            self.load(&state.model, Some(state))?;
            self.newest = Newest::Both;
        }
        Ok(())
    }

    /// Makes `subject` the device's model: the training model (uploaded when
    /// the host's is newer), or another model without optimizer state, after
    /// which the next step uploads the training model again.
    fn load_subject(&mut self, subject: Subject<'_>) -> Result<()> {
        match subject {
            Subject::Training(state) => self.upload_if_newer(state),
            Subject::Other(model) => {
                if self.newest == Newest::Device {
                    bail!("evaluating another model would overwrite steps the host has not synced");
                }
                self.load(model, None)?;
                self.newest = Newest::Host;
                Ok(())
            }
        }
    }

    /// The device views of `views` (indices into `data.views`).
    fn slots(&self, views: &[usize]) -> Result<Vec<usize>> {
        views
            .iter()
            .map(|&v| match self.device_view.get(v).copied().flatten() {
                Some(slot) => Ok(slot),
                None => bail!(
                    "view {v} was not uploaded to the device (neither a training nor a held-out view)"
                ),
            })
            .collect()
    }

    /// Takes in results that came back: losses, the rendered share, and an
    /// error naming the first step in which something turned non-finite.
    fn arrive(&mut self, results: Vec<StepResult>) -> Result<()> {
        for result in results {
            let Some((iteration, view)) = self.in_flight.pop_front() else {
                bail!("the device reported more steps than were queued");
            };
            if !result.non_finite.is_empty() {
                bail!(
                    "training of {:?} diverged at iteration {iteration}: {} became non-finite \
                     (view {:?}, loss {}; parameters overflowed, lower the learning rates)",
                    self.data.name,
                    result.non_finite.join(", "),
                    self.data.views[view].name,
                    result.loss
                );
            }
            let camera = &self.data.views[view].camera;
            self.steps += 1;
            self.rendered +=
                result.rendered_pixels as f64 / (camera.width as f64 * camera.height as f64);
            self.arrived.push(StepLoss {
                iteration,
                loss: result.loss as f64,
            });
        }
        Ok(())
    }
}

impl StepRunner for DeviceSteps<'_> {
    fn step(&mut self, state: &mut TrainingState, iteration: u64, input: &StepInput) -> Result<()> {
        self.upload_if_newer(state)?;
        let [slot] = self.slots(&[input.view])?[..] else {
            unreachable!("one view asked for, one slot returned");
        };
        self.trainer.step(&Step {
            view: slot,
            background: input.background,
            render: self.pass_settings(&input.render, true),
            learning_rates: state.optim.learning_rates(),
            lambda_dssim: DEFAULT_LAMBDA_DSSIM,
            sh_degree: state.model.sh_degree,
            depth: DepthWeights {
                points: input.point_depth_weight,
                planar: input.smoothness_weight,
            },
        })?;
        self.newest = Newest::Device;
        self.in_flight.push_back((iteration, input.view));
        let collected = self.trainer.take_collected();
        self.arrive(collected)
    }

    fn losses(&mut self, wait: bool) -> Result<Vec<StepLoss>> {
        let results = if wait {
            self.trainer.results()?
        } else {
            self.trainer.take_collected()
        };
        self.arrive(results)?;
        Ok(std::mem::take(&mut self.arrived))
    }

    fn evaluate(
        &mut self,
        subject: Subject<'_>,
        views: &[usize],
        render: &RenderSettings,
    ) -> Result<HeldOut> {
        self.load_subject(subject)?;
        let slots = self.slots(views)?;
        let settings = self.pass_settings(render, true);
        let scores = self
            .trainer
            .evaluate(&slots, &settings, DEFAULT_LAMBDA_DSSIM)?;
        let collected = self.trainer.take_collected();
        self.arrive(collected)?;
        self.evaluations += 1;
        Ok(held_out(&scores))
    }

    fn face_max_weight(
        &mut self,
        subject: Subject<'_>,
        views: &[usize],
        render: &RenderSettings,
    ) -> Result<Vec<f32>> {
        self.load_subject(subject)?;
        let slots = self.slots(views)?;
        let settings = self.pass_settings(render, false);
        let weights = self.trainer.face_max_weight(&slots, &settings)?;
        let collected = self.trainer.take_collected();
        self.arrive(collected)?;
        Ok(weights)
    }

    fn sync(&mut self, state: &mut TrainingState) -> Result<()> {
        if self.newest == Newest::Device {
            let (current, previous) = self.trainer.store(&mut state.model, &mut state.optim)?;
            state.stats.set_arrays(current, previous);
            self.downloads += 1;
            self.newest = Newest::Both;
        }
        let collected = self.trainer.take_collected();
        self.arrive(collected)
    }

    fn edited(&mut self) {
        self.newest = Newest::Host;
    }

    fn model_is_current(&self) -> bool {
        self.newest != Newest::Device
    }

    /// The device's statistics roll with the host's while it holds the
    /// newest model; otherwise the host's rolled copy goes up with the next upload.
    fn end_epoch(&mut self) {
        if self.newest != Newest::Host {
            self.trainer.end_epoch();
        }
    }

    fn rendered(&self) -> (u64, f64) {
        (self.steps, self.rendered)
    }

    fn set_rendered(&mut self, (steps, rendered): (u64, f64)) {
        self.steps = steps;
        self.rendered = rendered;
    }

    fn place(&self) -> &'static str {
        "device"
    }

    fn seen_points(&self) -> &PointDepth {
        &self.points
    }

    fn summary(&self) -> Option<String> {
        Some(format!(
            "iterations ran on the device (render, loss, depth terms, backward and Adam on the \
             GPU{}; {}); {} held-out evaluations on the device; the model went to the device {} \
             times and came back {} times (densification, pruning, connectivity, checkpoints); \
             {} host waits for the device in all; {} steps replayed after outgrowing their \
             tile-entry buffers",
            if self.composite.is_some() {
                ", behind the frozen occluders"
            } else {
                ""
            },
            match (self.steps > 0).then(|| self.rendered / self.steps as f64) {
                Some(f) => format!("{:.0} % of the frame rendered on average", 100.0 * f),
                None => "no steps".into(),
            },
            self.evaluations,
            self.uploads,
            self.downloads,
            self.host_syncs(),
            self.trainer.replays()
        ))
    }
}

#[cfg(test)]
mod tests {
    //! DeviceSteps against HostSteps on the CPU backend, through the one
    //! StepRunner interface: the same steps (loss, moved parameters, face
    //! statistics) and the same evaluations, for an object and for the
    //! background behind frozen occluders with both depth terms, within the
    //! device tolerances of objectsplat-raster-gpu's tests; and the depth terms'
    //! device gradient against the host's analytic gradient and against
    //! finite differences of the host's loss, on the device's own render.
    use super::*;
    use crate::depth_smoothness::{self, DepthImage};
    use crate::face_stats::FaceWeights;
    use crate::host_steps::HostSteps;
    use crate::schedule::Schedule;
    use crate::supervision::View;
    use glam::DVec3;
    use objectsplat_core::component::{IGNORE, OTHER};
    use objectsplat_core::{Camera, ComponentKind, Split};
    use objectsplat_gpu::{AdapterChoice, GpuContext};
    use objectsplat_optim::Optim;
    use objectsplat_raster::{CpuBackend, RenderOutput, SH_COEFFS};

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

    /// `faces` random triangles around `centre`, SH up to `degree`.
    fn soup(rng: &mut Rng, faces: u32, centre: [f64; 3], spread: f64, degree: u32) -> Model<f32> {
        let mut model = Model::<f32>::empty();
        model.sh_degree = degree;
        model.opacity_floor = 0.0;
        for f in 0..faces {
            let c = [0, 1, 2].map(|a| centre[a] + rng.uniform(-spread, spread));
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
        model
    }

    /// The trained model (60 random triangles near the origin) and a
    /// component of four 96×72 views of it: OWN pixels in a box around its
    /// image, OTHER pixels elsewhere and a band of IGNORE pixels; the last view
    /// is held out; measured points on the trained model's faces.
    /// `behind` gives it frozen occluders (a second soup, nearer the cameras,
    /// with its own σ per face and SH degree 3): the background behind them,
    /// an object among them.
    fn component(kind: ComponentKind, behind: bool) -> (Model<f32>, ComponentData) {
        let mut rng = Rng(0x5eed_0042);
        let model = soup(&mut rng, 60, [0.0; 3], 0.3, 2);
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
                        if x.abs_diff(w / 2) < 22 && y.abs_diff(h / 2) < 16 {
                            OWN
                        } else if y % 9 == 4 {
                            IGNORE
                        } else {
                            OTHER
                        }
                    })
                    .collect::<Vec<u8>>();
                let target: Vec<f32> = (0..w * h * 3)
                    .map(|_| rng.uniform(0.0, 1.0) as f32)
                    .collect();
                let split = if k == 3 { Split::Test } else { Split::Train };
                View::from_planes(&format!("v{k}"), camera, &target, &labels, split).unwrap()
            })
            .collect();
        let occluders = behind.then(|| {
            let mut frozen = soup(&mut rng, 25, [0.35, 0.1, -0.6], 0.35, 3);
            frozen.sigma = 0.4;
            frozen.face_sigma = (0..frozen.face_count())
                .map(|f| 0.2 + 0.05 * (f % 7) as f64)
                .collect();
            frozen
        });
        // Each face's centroid and the points halfway from it to the corners.
        let depth_points = model
            .faces
            .iter()
            .flat_map(|f| {
                let v = f.map(|i| model.vertices[i as usize]);
                let c = [0, 1, 2].map(|a| (v[0][a] + v[1][a] + v[2][a]) / 3.0);
                let halfway = v.map(|corner| [0, 1, 2].map(|a| 0.5 * (c[a] + corner[a])));
                std::iter::once(c).chain(halfway)
            })
            .collect();
        let data = ComponentData {
            name: "component".into(),
            kind,
            views,
            occluders,
            depth_points,
            other_points: Vec::new(),
        };
        (model, data)
    }

    fn state(model: &Model<f32>) -> TrainingState {
        // The short budget's world-unit rates, as the trainer resolves them at 24 mm per pixel.
        let schedule = Schedule::scaled(100).for_footprint(0.024).unwrap();
        TrainingState {
            model: model.clone(),
            optim: Optim::new(schedule.learning_rates(0), model.vertex_count()).unwrap(),
            stats: FaceWeights::new(model.face_count()),
        }
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

    /// Two steps (views 1 and 0, two backgrounds) with the given depth weights.
    fn inputs(model: &Model<f32>, points: f64, planar: f64) -> Vec<StepInput> {
        [(1usize, [0.3f32, 0.8, 0.1]), (0, [0.7, 0.2, 0.5])]
            .into_iter()
            .map(|(view, background)| StepInput {
                view,
                background,
                render: RenderSettings::for_model(model),
                point_depth_weight: points,
                smoothness_weight: planar,
                normal_agreement_weight: 0.0,
            })
            .collect()
    }

    /// Runs `inputs` on `runner`; returns the losses and the synced state.
    fn run(
        runner: &mut dyn StepRunner,
        model: &Model<f32>,
        inputs: &[StepInput],
    ) -> (Vec<f64>, TrainingState) {
        let mut state = state(model);
        for (k, input) in inputs.iter().enumerate() {
            runner.step(&mut state, k as u64 + 1, input).unwrap();
        }
        let losses = runner.losses(true).unwrap();
        runner.sync(&mut state).unwrap();
        assert_eq!(
            losses.iter().map(|l| l.iteration).collect::<Vec<_>>(),
            (1..=inputs.len() as u64).collect::<Vec<_>>()
        );
        (losses.into_iter().map(|l| l.loss).collect(), state)
    }

    /// The device's steps against the host's: losses, parameter updates,
    /// Adam's step counts and the face statistics.
    fn steps_agree(kind: ComponentKind, behind: bool, points: f64, planar: f64) {
        steps_agree_at(kind, behind, points, planar, 1);
    }

    fn steps_agree_at(kind: ComponentKind, behind: bool, points: f64, planar: f64, samples: u32) {
        let Some(gpu) = gpu() else { return };
        let (model, data) = component(kind, behind);
        let cpu = CpuBackend::new(2);
        let inputs = inputs(&model, points, planar);
        let depth = points > 0.0;
        let mut host = HostSteps::new(&cpu, &data, true, depth, samples).unwrap();
        let (host_losses, host_state) = run(&mut host, &model, &inputs);
        let mut device =
            DeviceSteps::new(&gpu, &data, &[0, 1, 2], &[3], true, depth, samples, 1.0).unwrap();
        let (device_losses, device_state) = run(&mut device, &model, &inputs);
        let fraction = (&device as &dyn StepRunner).rendered_fraction().unwrap();
        let want_fraction = (&host as &dyn StepRunner).rendered_fraction().unwrap();
        eprintln!(
            "{kind:?} behind {behind}, depth {points}/{planar}, {samples}² samples: losses device \
             {device_losses:?}, host {host_losses:?}; rendered {fraction:.3} vs {want_fraction:.3}"
        );
        assert!((fraction - want_fraction).abs() < 1e-9, "rendered share");
        for (d, h) in device_losses.iter().zip(&host_losses) {
            assert!((d - h).abs() <= 1e-5 * h, "loss {d} vs {h}");
        }
        let before = flat(&model);
        let moved = |m: &Model<f32>| -> Vec<f64> {
            flat(m).iter().zip(&before).map(|(a, b)| a - b).collect()
        };
        let d = relative(&moved(&device_state.model), &moved(&host_state.model));
        eprintln!("parameter updates differ by {d:.2e}");
        assert!(d <= 2e-3, "parameter updates differ by {d:.3e}");
        assert_eq!(
            device_state.optim.groups().map(|g| g.steps),
            host_state.optim.groups().map(|g| g.steps)
        );
        // Adam's updates hardly see a gradient's scale; its first moments do.
        for (d, h) in device_state
            .optim
            .groups()
            .iter()
            .zip(host_state.optim.groups())
        {
            let wide = |x: &[f32]| x.iter().map(|&v| v as f64).collect::<Vec<_>>();
            let r = relative(&wide(d.first_moment()), &wide(h.first_moment()));
            assert!(r <= 2e-3, "{}: first moments differ by {r:.3e}", d.name);
        }
        let (now, previous) = device_state.stats.arrays();
        let want = host_state.stats.max_weight();
        for (f, (a, b)) in now.iter().zip(&want).enumerate() {
            assert!((a - b).abs() <= 1e-4, "face {f}: {a} vs {b}");
        }
        assert!(previous.iter().all(|&w| w == 0.0));
        assert!(now.iter().any(|&w| w > 0.0));
    }

    #[test]
    fn an_object_step_matches_the_host_step() {
        steps_agree(ComponentKind::Object, false, 0.0, 0.0);
    }

    #[test]
    fn a_background_step_behind_occluders_matches_the_host_step() {
        steps_agree(ComponentKind::Background, true, 0.0, 0.0);
    }

    #[test]
    fn an_object_step_among_frozen_neighbours_matches_the_host_step() {
        steps_agree(ComponentKind::Object, true, 0.0, 0.0);
        steps_agree_at(ComponentKind::Object, true, 0.0, 0.0, 2);
    }

    #[test]
    fn a_background_step_with_both_depth_terms_matches_the_host_step() {
        steps_agree(ComponentKind::Background, true, 1.0, 3.0);
        steps_agree(ComponentKind::Background, false, 1.0, 3.0);
    }

    #[test]
    fn supersampled_steps_match_the_host_steps() {
        steps_agree_at(ComponentKind::Object, false, 0.0, 0.0, 2);
        steps_agree_at(ComponentKind::Background, true, 1.0, 3.0, 2);
    }

    #[test]
    fn device_evaluation_and_face_weights_equal_the_host_ones() {
        let Some(gpu) = gpu() else { return };
        let cpu = CpuBackend::new(2);
        for behind in [false, true] {
            let (model, data) = component(ComponentKind::Background, behind);
            let state = state(&model);
            let render = RenderSettings::for_model(&model);
            for (crop, samples) in [(true, 1), (false, 1), (true, 2), (false, 2)] {
                let mut device =
                    DeviceSteps::new(&gpu, &data, &[0, 1, 2], &[3], crop, false, samples, 1.0)
                        .unwrap();
                let mut host = HostSteps::new(&cpu, &data, crop, false, samples).unwrap();
                for views in [&[3usize][..], &[0, 1, 2, 3][..]] {
                    for subject in [Subject::Training(&state), Subject::Other(&model)] {
                        let got =
                            StepRunner::evaluate(&mut device, subject, views, &render).unwrap();
                        let want =
                            StepRunner::evaluate(&mut host, subject, views, &render).unwrap();
                        eprintln!(
                            "behind {behind}, crop {crop}, {samples}² samples, views {views:?}: \
                             device {got:?}, host {want:?}"
                        );
                        assert!(
                            (got.loss - want.loss).abs() <= 1e-5 * want.loss,
                            "{got:?} vs {want:?}"
                        );
                        assert!((got.psnr - want.psnr).abs() <= 1e-3, "{got:?} vs {want:?}");
                    }
                    let got = StepRunner::face_max_weight(
                        &mut device,
                        Subject::Training(&state),
                        views,
                        &render,
                    )
                    .unwrap();
                    let want = StepRunner::face_max_weight(
                        &mut host,
                        Subject::Training(&state),
                        views,
                        &render,
                    )
                    .unwrap();
                    assert_eq!(got.len(), want.len());
                    for (f, (a, b)) in got.iter().zip(&want).enumerate() {
                        assert!((a - b).abs() <= 1e-4, "face {f}: {a} vs {b}");
                    }
                }
                let err = DeviceSteps::new(&gpu, &data, &[0], &[], crop, false, 1, 1.0)
                    .unwrap()
                    .evaluate(Subject::Training(&state), &[3], &render)
                    .unwrap_err();
                assert!(format!("{err:#}").contains("not uploaded"), "{err:#}");
            }
        }
    }

    #[test]
    fn host_face_statistics_go_to_the_device_with_the_model() {
        let Some(gpu) = gpu() else { return };
        let (model, data) = component(ComponentKind::Object, false);
        let mut state = state(&model);
        let nf = model.face_count();
        let mut device =
            DeviceSteps::new(&gpu, &data, &[0, 1, 2], &[3], true, false, 1, 1.0).unwrap();
        let current: Vec<f32> = (0..nf)
            .map(|f| if f % 2 == 0 { 2.0 } else { 0.0 })
            .collect();
        let previous: Vec<f32> = (0..nf).map(|f| f as f32 / nf as f32).collect();
        state.stats = FaceWeights::from_parts(current.clone(), previous.clone(), 1).unwrap();
        let input = &inputs(&model, 0.0, 0.0)[0];
        device.step(&mut state, 1, input).unwrap();
        device.sync(&mut state).unwrap();
        let (now, before) = state.stats.arrays();
        assert_eq!(before, &previous[..]);
        // Weights of a step are at most 1: the even faces keep the host's 2.0.
        for f in (0..nf).step_by(2) {
            assert_eq!(now[f], 2.0);
        }
        assert!(now.iter().enumerate().any(|(f, &w)| f % 2 == 1 && w > 0.0));
        // The device rolls its statistics with the host's while it holds the newest model.
        let rolled = now.to_vec();
        state.stats.end_epoch();
        device.end_epoch();
        device.step(&mut state, 2, input).unwrap();
        device.sync(&mut state).unwrap();
        let (now, before) = state.stats.arrays();
        assert_eq!(before, &rolled[..]);
        assert!(now.iter().all(|&w| w < 2.0) && now.iter().any(|&w| w > 0.0));
    }

    /// The depth terms' gradient the device starts its backward pass from,
    /// on its own render: against the host's analytic gradient, and against
    /// central differences of the host's loss on that render.
    #[test]
    fn device_depth_gradients_match_the_host_terms_and_finite_differences() {
        let Some(gpu) = gpu() else { return };
        let (model, data) = component(ComponentKind::Background, false);
        let points = PointDepth::new(&data.depth_points, &data);
        assert!(points.count(0) > 3, "the view must see measured points");
        for (point_weight, planar_weight) in [(1.0, 0.0), (0.0, 3.0), (0.7, 2.0)] {
            let mut device =
                DeviceSteps::new(&gpu, &data, &[0, 1, 2], &[3], true, true, 1, 1.0).unwrap();
            let mut state = state(&model);
            let mut input = inputs(&model, point_weight, planar_weight).swap_remove(1);
            input.render.sh_degree = model.sh_degree;
            device.step(&mut state, 1, &input).unwrap();
            let pass = device.trainer.last_pass().unwrap();
            let region = pass.region;
            let (rw, rh) = (region.width() as usize, region.height() as usize);
            let channel = |values: &[f32], k: usize| -> Vec<f32> {
                values.chunks_exact(6).map(|v| v[k]).collect()
            };
            let (alpha, depth) = (channel(&pass.image, 3), channel(&pass.image, 4));
            let out = RenderOutput {
                width: data.views[0].camera.width,
                height: data.views[0].camera.height,
                region,
                alpha: alpha.clone(),
                depth: depth.clone(),
                ..RenderOutput::default()
            };
            let labels = &data.views[0].labels;
            let own = |i: usize| {
                let (x, y) = (region.x0 as usize + i % rw, region.y0 as usize + i / rw);
                labels.get(x as u32, y as u32) == OWN
            };
            // The host's terms on the device's render.
            let loss_and_gradient = |alpha: &[f32], depth: &[f32]| {
                let (mut dd, mut da) = (vec![0.0f32; rw * rh], vec![0.0f32; rw * rh]);
                let out = RenderOutput {
                    alpha: alpha.to_vec(),
                    depth: depth.to_vec(),
                    ..out.clone()
                };
                let mut loss = points.add_gradient(0, &out, point_weight, &mut dd, &mut da);
                if planar_weight > 0.0 {
                    let image = DepthImage {
                        width: rw,
                        height: rh,
                        depth,
                        alpha,
                    };
                    loss += depth_smoothness::add_gradient(
                        &image,
                        own,
                        planar_weight,
                        &mut dd,
                        &mut da,
                    );
                }
                (loss, dd, da)
            };
            let (_, want_depth, want_alpha) = loss_and_gradient(&alpha, &depth);
            let (got_alpha, got_depth) = (channel(&pass.upstream, 3), channel(&pass.upstream, 4));
            let to64 = |v: &[f32]| v.iter().map(|&x| x as f64).collect::<Vec<_>>();
            for (name, got, want) in [
                ("depth", &got_depth, &want_depth),
                ("alpha", &got_alpha, &want_alpha),
            ] {
                let d = relative(&to64(got), &to64(want));
                eprintln!(
                    "weights {point_weight}/{planar_weight}: d/d{name} device vs host {d:.2e}"
                );
                assert!(
                    want.iter().any(|&g| g != 0.0),
                    "{name}: no gradient to compare"
                );
                assert!(
                    d <= 1e-4,
                    "{name}: the device's gradient differs by {d:.3e}"
                );
            }
            // Central differences of the loss at pixels where the device has a
            // gradient, where the loss is smooth at the step's scale: both terms
            // are L1, with kinks where a point's depth error or a run's second
            // difference crosses 0 (there the one-sided differences disagree).
            let eps = 1e-3f32;
            let mut checked = 0;
            for i in (0..rw * rh).filter(|&i| got_depth[i] != 0.0).take(60) {
                for (plane, analytic) in [(4usize, got_depth[i]), (3, got_alpha[i])] {
                    let shifted = |delta: f32| {
                        let (mut a, mut d) = (alpha.clone(), depth.clone());
                        if plane == 4 {
                            d[i] += delta;
                        } else {
                            a[i] += delta;
                        }
                        loss_and_gradient(&a, &d).0
                    };
                    let (up, here, down) = (shifted(eps), shifted(0.0), shifted(-eps));
                    let (right, left) = ((up - here) / eps as f64, (here - down) / eps as f64);
                    if (right - left).abs() > 1e-2 * (1.0 + right.abs()) {
                        continue;
                    }
                    let numeric = (up - down) / (2.0 * eps as f64);
                    assert!(
                        (numeric - analytic as f64).abs() <= 5e-3 * (1.0 + numeric.abs()),
                        "pixel {i} channel {plane}: numeric {numeric} device {analytic}"
                    );
                    checked += 1;
                }
            }
            eprintln!("weights {point_weight}/{planar_weight}: {checked} finite differences");
            assert!(checked >= 10, "only {checked} finite differences");
        }
    }
}
