//! Training iterations on a wgpu device ([`DeviceTrainer`]) inside the
//! host's training loop. The host keeps the schedule, the random view and
//! background choices, densification, pruning, connectivity and evaluation;
//! the device keeps the parameters and Adam's moments between those events.
//! Parameters cross to the host only when an event needs the model, losses
//! only at the loss-log points.

use crate::optim::Optim;
use crate::supervision::{ComponentData, supervision_parts};
use anyhow::{Result, bail};
use objectsplat_raster::loss::DEFAULT_LAMBDA_DSSIM;
use objectsplat_raster::{Model, RenderSettings};
use objectsplat_wgpu::WgpuBackend;
use objectsplat_wgpu::training::{
    AdamSettings, DeviceTrainer, LearningRates, Moments, OptimizerState, Step, TrainingView,
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
    /// View index within `data.views` of each training view slot.
    views: Vec<usize>,
    uploads: u64,
    downloads: u64,
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

impl DeviceSteps {
    /// Uploads the training views `train` (indices into `data.views`).
    pub fn new(
        backend: &WgpuBackend,
        data: &ComponentData,
        train: &[usize],
        optim: &Optim,
    ) -> Result<DeviceSteps> {
        let views: Vec<TrainingView> = train
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
            trainer: DeviceTrainer::new(backend, &views, adam)?,
            newest: Newest::Host,
            in_flight: VecDeque::new(),
            arrived: Vec::new(),
            views: train.to_vec(),
            uploads: 0,
            downloads: 0,
        })
    }

    /// Makes the host's model and optimizer state the newest, fetching them if
    /// needed; an error if a step since the last call diverged.
    pub fn pull(
        &mut self,
        model: &mut Model<f32>,
        optim: &mut Optim,
        data: &ComponentData,
    ) -> Result<()> {
        self.fetch(data)?;
        if self.newest == Newest::Device {
            let state = self.trainer.store(model)?;
            optim.set_device_state(state)?;
            self.downloads += 1;
            self.newest = Newest::Both;
        }
        Ok(())
    }

    /// The host changed the model or the optimizer state (after [`DeviceSteps::pull`]).
    pub fn host_edited(&mut self) {
        self.newest = Newest::Host;
    }

    /// One line for the training log: where the iterations ran and how often the model moved.
    pub fn summary(&self) -> String {
        format!(
            "iterations ran on the device (render, loss, backward and Adam on the GPU); \
             the model went to the device {} times and came back {} times \
             (evaluation, densification, pruning, connectivity)",
            self.uploads, self.downloads
        )
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
        if self.newest == Newest::Host {
            self.trainer.load(model, &optim.device_state())?;
            self.uploads += 1;
        }
        self.trainer.step(&Step {
            view: slot,
            background,
            render,
            learning_rates: optim.learning_rates(),
            lambda_dssim: DEFAULT_LAMBDA_DSSIM,
        })?;
        self.newest = Newest::Device;
        self.in_flight.push_back((iteration, slot));
        Ok(())
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
