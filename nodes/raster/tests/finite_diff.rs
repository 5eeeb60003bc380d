//! The analytic backward agrees with f64 central finite differences for every
//! parameter group (vertex positions, SH of all degrees, opacity logits, the
//! background) and for the photometric loss end to end.
//!
//! The renderer is only piecewise smooth: a fragment appears/disappears at the
//! α ≥ 1/255 threshold and at the T < 1e-4 early stop, the window has kinks
//! where two edges tie for the max, and the α clamp and the opacity min have
//! kinks. The scenes use irrational-looking coordinates and an off-grid
//! principal point so no pixel centre lies within the FD step (≈ 1e-5 px) of
//! such a set, and every difference asserts that the per-face pixel counts
//! are unchanged between θ + h and θ − h (a crossed threshold would change
//! them), so a failure cannot be a silently invalid configuration.

mod common;

use common::*;
use objectsplat_core::Camera;
use objectsplat_raster::loss::{DEFAULT_LAMBDA_DSSIM, Dims, LossGrad, photometric};
use objectsplat_raster::{
    CpuBackend, Model, ModelGrads, OutputGrads, RenderBackend, RenderOutput, RenderSettings,
    SavedForward,
};

/// The f64 render the objectives score.
type Output = RenderOutput<f64>;

#[derive(Clone, Copy, Debug)]
enum Param {
    Position(usize, usize),
    Sh(usize, usize, usize),
    Logit(usize),
    Background(usize),
}

struct Problem {
    model: Model<f64>,
    camera: Camera,
    settings: RenderSettings,
    background: Vec<f64>,
}

impl Problem {
    fn slot(&mut self, p: Param) -> &mut f64 {
        match p {
            Param::Position(v, a) => &mut self.model.vertices[v][a],
            Param::Sh(v, k, c) => &mut self.model.sh[v][k][c],
            Param::Logit(v) => &mut self.model.opacity_logits[v],
            Param::Background(i) => &mut self.background[i],
        }
    }

    fn render(&self) -> RenderOutput<f64> {
        CpuBackend::new(1)
            .forward(&self.model, &self.camera, &self.settings, &self.background)
            .expect("valid scene")
            .0
    }
}

fn analytic(g: &ModelGrads<f64>, p: Param) -> f64 {
    match p {
        Param::Position(v, a) => g.vertices[v][a],
        Param::Sh(v, k, c) => g.sh[v][k][c],
        Param::Logit(v) => g.opacity_logits[v],
        Param::Background(i) => g.background[i],
    }
}

/// A scalar objective of the render and its gradient with respect to the outputs.
trait Objective {
    fn value(&self, out: &Output) -> f64;
    fn backward(&self, problem: &Problem, out: &Output, saved: &SavedForward) -> ModelGrads<f64>;
}

/// `Σ r·colour + Σ r·alpha + Σ r·depth + Σ r·median` with fixed random `r`:
/// exercises every output's gradient path.
struct LinearProbe {
    color: Vec<f64>,
    alpha: Vec<f64>,
    depth: Vec<f64>,
    median: Vec<f64>,
}

impl LinearProbe {
    fn new(pixels: usize, seed: u64) -> Self {
        let mut rng = Rng(seed);
        let mut v = |n: usize| (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect::<Vec<_>>();
        LinearProbe {
            color: v(pixels * 3),
            alpha: v(pixels),
            depth: v(pixels),
            median: v(pixels),
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl Objective for LinearProbe {
    fn value(&self, out: &Output) -> f64 {
        dot(&self.color, &out.color)
            + dot(&self.alpha, &out.alpha)
            + dot(&self.depth, &out.depth)
            + dot(&self.median, &out.median_depth)
    }
    fn backward(&self, problem: &Problem, _: &Output, saved: &SavedForward) -> ModelGrads<f64> {
        let grads = OutputGrads {
            color: &self.color,
            alpha: Some(&self.alpha),
            depth: Some(&self.depth),
            median_depth: Some(&self.median),
        };
        CpuBackend::new(2)
            .backward(&problem.model, saved, &grads)
            .expect("valid gradients")
    }
}

/// `0.8·L1 + 0.2·(1 − SSIM)` against a target, with per-pixel weights including zeros.
struct Photometric {
    target: Vec<f64>,
    weights: Vec<f64>,
    dims: Dims,
}

impl Photometric {
    fn loss(&self, color: &[f64]) -> LossGrad<f64> {
        photometric(
            self.dims,
            color,
            &self.target,
            Some(&self.weights),
            DEFAULT_LAMBDA_DSSIM,
        )
        .expect("valid")
    }
}

impl Objective for Photometric {
    fn value(&self, out: &Output) -> f64 {
        self.loss(&out.color).value
    }
    fn backward(&self, problem: &Problem, out: &Output, saved: &SavedForward) -> ModelGrads<f64> {
        let l = self.loss(&out.color);
        CpuBackend::new(2)
            .backward(&problem.model, saved, &OutputGrads::color_only(&l.grad))
            .expect("valid gradients")
    }
}

/// Checks one parameter group: relative error ‖fd − analytic‖ / ‖analytic‖ < 1e-4.
fn check_group(
    problem: &mut Problem,
    objective: &dyn Objective,
    name: &str,
    params: &[Param],
    h: f64,
) {
    let (out, saved) = CpuBackend::new(2)
        .forward(
            &problem.model,
            &problem.camera,
            &problem.settings,
            &problem.background,
        )
        .unwrap();
    let grads = objective.backward(problem, &out, &saved);
    let mut err2 = 0.0;
    let mut norm2 = 0.0;
    let mut worst = (0.0, None);
    for &p in params {
        let orig = *problem.slot(p);
        *problem.slot(p) = orig + h;
        let plus = problem.render();
        *problem.slot(p) = orig - h;
        let minus = problem.render();
        *problem.slot(p) = orig;
        assert_eq!(
            plus.face_pixel_count, minus.face_pixel_count,
            "{name}: {p:?} moves a fragment across a threshold; the scene is not a valid FD configuration"
        );
        let fd = (objective.value(&plus) - objective.value(&minus)) / (2.0 * h);
        let an = analytic(&grads, p);
        err2 += (fd - an).powi(2);
        norm2 += an * an;
        if (fd - an).abs() > worst.0 {
            worst = ((fd - an).abs(), Some((p, fd, an)));
        }
    }
    assert!(
        norm2 > 0.0,
        "{name}: the analytic gradient is identically zero; the check would be vacuous"
    );
    let rel = (err2 / norm2).sqrt();
    assert!(
        rel < 1e-4,
        "{name}: relative error {rel:.3e} (worst {worst:?})"
    );
}

fn all_positions(m: &Model<f64>) -> Vec<Param> {
    (0..m.vertices.len())
        .flat_map(|v| (0..3).map(move |a| Param::Position(v, a)))
        .collect()
}

fn sh_band(m: &Model<f64>, band: std::ops::Range<usize>) -> Vec<Param> {
    (0..m.vertices.len())
        .flat_map(|v| {
            band.clone()
                .flat_map(move |k| (0..3).map(move |c| Param::Sh(v, k, c)))
        })
        .collect()
}

fn all_logits(m: &Model<f64>) -> Vec<Param> {
    (0..m.vertices.len()).map(Param::Logit).collect()
}

fn problem(seed: u64, sigma: f64) -> Problem {
    let (model, camera) = gradient_scene(seed);
    let mut rng = Rng(seed ^ 0xABCD);
    let background = random_background(&mut rng, &camera);
    Problem {
        model,
        camera,
        settings: settings(sigma, 3),
        background,
    }
}

/// The scene really contains the cases it claims, and they are all drawn.
#[test]
fn gradient_scene_contains_the_intended_cases() {
    let p = problem(7, 0.6);
    let out = p.render();
    assert!(
        out.face_pixel_count.iter().all(|&c| c > 0),
        "every face is drawn: {:?}",
        out.face_pixel_count
    );
    let (cos4, _) = face_diagnostics(&p.model, &p.camera, 4);
    assert!(
        cos4 < 0.1 && cos4 > 1e-3,
        "face 4 is nearly edge-on: |cos| = {cos4}"
    );
    let (_, r3) = face_diagnostics(&p.model, &p.camera, 3);
    assert!(r3 > 1.0 && r3 < 2.0, "face 3 is tiny: inradius {r3} px");
    assert!(
        p.model.face_opacity(5) > 0.999,
        "face 5 saturates the α clamp"
    );
}

fn check_all_groups(sigma: f64, seed: u64) {
    let mut p = problem(seed, sigma);
    let pixels = (p.camera.width * p.camera.height) as usize;
    let probe = LinearProbe::new(pixels, seed + 1);
    let m = p.model.clone();
    check_group(&mut p, &probe, "positions", &all_positions(&m), 1e-6);
    check_group(&mut p, &probe, "SH degree 0", &sh_band(&m, 0..1), 1e-5);
    check_group(&mut p, &probe, "SH degree 1", &sh_band(&m, 1..4), 1e-5);
    check_group(&mut p, &probe, "SH degree 2", &sh_band(&m, 4..9), 1e-5);
    check_group(&mut p, &probe, "SH degree 3", &sh_band(&m, 9..16), 1e-5);
    check_group(&mut p, &probe, "opacity logits", &all_logits(&m), 1e-5);
    let bg: Vec<Param> = (0..pixels * 3).step_by(7).map(Param::Background).collect();
    check_group(&mut p, &probe, "background", &bg, 1e-4);
}

#[test]
fn every_parameter_group_matches_finite_differences_soft_window() {
    check_all_groups(0.6, 7);
}

#[test]
fn every_parameter_group_matches_finite_differences_sharp_window() {
    // σ small: near-opaque triangles, the α clamp covers much of face 5.
    check_all_groups(0.07, 11);
}

#[test]
fn photometric_loss_end_to_end_matches_finite_differences() {
    let mut p = problem(23, 0.5);
    let pixels = (p.camera.width * p.camera.height) as usize;
    let mut rng = Rng(99);
    let target: Vec<f64> = (0..pixels * 3).map(|_| rng.uniform(0.0, 1.0)).collect();
    // A block of unsupervised pixels (weight 0) and varied weights elsewhere.
    let weights: Vec<f64> = (0..pixels)
        .map(|i| {
            if i % 40 < 8 {
                0.0
            } else {
                rng.uniform(0.2, 1.0)
            }
        })
        .collect();
    let objective = Photometric {
        target,
        weights,
        dims: Dims::rgb(p.camera.width, p.camera.height),
    };
    let m = p.model.clone();
    check_group(
        &mut p,
        &objective,
        "loss/positions",
        &all_positions(&m),
        1e-6,
    );
    check_group(&mut p, &objective, "loss/SH", &sh_band(&m, 0..16), 1e-5);
    check_group(
        &mut p,
        &objective,
        "loss/opacity logits",
        &all_logits(&m),
        1e-5,
    );
    let bg: Vec<Param> = (0..pixels * 3).step_by(11).map(Param::Background).collect();
    check_group(&mut p, &objective, "loss/background", &bg, 1e-5);
}

/// A general camera pose (rotation and translation), so the world→camera
/// transform and the SH view direction are exercised off the identity.
#[test]
fn gradients_match_finite_differences_with_a_rotated_camera() {
    let mut p = problem(31, 0.4);
    p.camera = orbit_camera(
        40,
        36,
        36.0,
        objectsplat_core::glam::DVec3::new(0.4, -0.3, -2.3),
    );
    let out = p.render();
    assert!(
        out.face_pixel_count.iter().filter(|&&c| c > 0).count() >= 4,
        "most faces visible: {:?}",
        out.face_pixel_count
    );
    let pixels = (p.camera.width * p.camera.height) as usize;
    let probe = LinearProbe::new(pixels, 5);
    let m = p.model.clone();
    check_group(
        &mut p,
        &probe,
        "rotated/positions",
        &all_positions(&m),
        1e-6,
    );
    check_group(&mut p, &probe, "rotated/SH", &sh_band(&m, 0..16), 1e-5);
    check_group(
        &mut p,
        &probe,
        "rotated/opacity logits",
        &all_logits(&m),
        1e-5,
    );
}
