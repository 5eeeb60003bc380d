//! Shared by the adapter-needing tests: the shared context, or a loud skip.
#![allow(dead_code)]

use objectsplat_gpu::{AdapterChoice, GpuContext};
use std::sync::Arc;

/// The shared context, or `None` after printing why the test is skipped.
/// With `OBJECTSPLAT_REQUIRE_ADAPTER=1` a missing adapter fails the test instead.
pub fn context() -> Option<Arc<GpuContext>> {
    match GpuContext::shared(AdapterChoice::Auto) {
        Ok((ctx, _)) => Some(ctx),
        Err(e) => {
            if std::env::var("OBJECTSPLAT_REQUIRE_ADAPTER").is_ok_and(|v| v == "1") {
                panic!("no wgpu adapter but OBJECTSPLAT_REQUIRE_ADAPTER=1: {e:#}");
            }
            eprintln!("SKIPPED (no wgpu adapter): {e:#}");
            None
        }
    }
}

/// A small deterministic generator (xorshift64*), so fixtures need no files.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    pub fn next_u32(&mut self) -> u32 {
        (self.next_u64() >> 32) as u32
    }
    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

use glam::DVec3;
use objectsplat_core::Camera;
use objectsplat_raster::{Model, RenderSettings, SH_COEFFS};

/// A named rendering problem shared by the parity tests.
pub struct Scene {
    pub name: String,
    pub model: Model<f32>,
    pub camera: Camera,
    pub settings: RenderSettings,
    pub background: Vec<f32>,
}

/// Adds a triangle with its own three vertices, random SH and the given logits.
pub fn push_triangle(
    model: &mut Model<f32>,
    rng: &mut Rng,
    corners: [[f64; 3]; 3],
    logits: [f64; 3],
) {
    let base = model.vertices.len() as u32;
    for (k, c) in corners.iter().enumerate() {
        model.vertices.push(c.map(|x| x as f32));
        model.sh.push(random_sh(rng));
        model.opacity_logits.push(logits[k] as f32);
    }
    model.faces.push([base, base + 1, base + 2]);
}

pub fn random_sh(rng: &mut Rng) -> [[f32; 3]; SH_COEFFS] {
    let mut rows = [[0f32; 3]; SH_COEFFS];
    for (k, row) in rows.iter_mut().enumerate() {
        let amp = if k == 0 { 1.5 } else { 0.4 };
        *row = [0, 1, 2].map(|_| rng.uniform(-amp, amp) as f32);
    }
    rows
}

/// A camera at `eye` looking at the origin, +y up, with square pixels.
pub fn facing_origin(width: u32, height: u32, focal: f64, eye: DVec3) -> Camera {
    Camera::look_at(width, height, focal, focal, eye, DVec3::ZERO, DVec3::Y)
}

fn camera(width: u32, height: u32) -> Camera {
    facing_origin(
        width,
        height,
        0.9 * width as f64,
        DVec3::new(0.2, -0.3, -3.0),
    )
}

fn background(rng: &mut Rng, camera: &Camera) -> Vec<f32> {
    let n = (camera.width * camera.height * 3) as usize;
    (0..n).map(|_| rng.uniform(0.0, 1.0) as f32).collect()
}

fn scene(name: &str, model: Model<f32>, camera: Camera, rng: &mut Rng) -> Scene {
    let bg = background(rng, &camera);
    Scene {
        name: name.to_string(),
        settings: RenderSettings::for_model(&model),
        model,
        camera,
        background: bg,
    }
}

fn empty_model(sh_degree: u32) -> Model<f32> {
    let mut m = Model::<f32>::empty();
    m.sh_degree = sh_degree;
    m.opacity_floor = 0.0;
    m
}

/// Random triangles in a cube around the origin.
pub fn random_soup(rng: &mut Rng, faces: usize, sh_degree: u32, size: (f64, f64)) -> Model<f32> {
    let mut m = empty_model(sh_degree);
    for _ in 0..faces {
        let c = [0, 1, 2].map(|_| rng.uniform(-1.0, 1.0));
        let r = rng.uniform(size.0, size.1);
        let corners = [0, 1, 2].map(|_| [0, 1, 2].map(|a| c[a] + rng.uniform(-r, r)));
        let logits = [0, 1, 2].map(|_| rng.uniform(-2.0, 4.0));
        push_triangle(&mut m, rng, corners, logits);
    }
    m
}

/// A grid mesh whose vertices are shared by up to six faces.
pub fn shared_grid(rng: &mut Rng, n: usize, sh_degree: u32) -> Model<f32> {
    let mut m = empty_model(sh_degree);
    for j in 0..=n {
        for i in 0..=n {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            let z = 0.3 * (3.0 * u).sin() * (2.0 * v).cos();
            m.vertices
                .push([(2.0 * u - 1.0) as f32, (2.0 * v - 1.0) as f32, z as f32]);
            m.sh.push(random_sh(rng));
            m.opacity_logits.push(rng.uniform(-1.0, 3.0) as f32);
        }
    }
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    for j in 0..n {
        for i in 0..n {
            m.faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            m.faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    m
}

/// The parity scenes: every case the brief names, at most 128×96 pixels.
pub fn parity_scenes() -> Vec<Scene> {
    let mut rng = Rng(0x5eed_0001);
    let mut scenes = Vec::new();
    for degree in 0..=3 {
        let m = random_soup(&mut rng, 250, degree, (0.05, 0.5));
        scenes.push(scene(
            &format!("random soup, SH degree {degree}"),
            m,
            camera(96, 72),
            &mut rng,
        ));
    }
    let m = shared_grid(&mut rng, 12, 2);
    scenes.push(scene("shared-vertex grid", m, camera(128, 96), &mut rng));

    // Nearly edge-on: the view ray grazes the plane (|cos| ≈ 0.02, above min_abs_cos).
    let mut m = empty_model(1);
    push_triangle(
        &mut m,
        &mut rng,
        [[-0.8, -0.5, 0.0], [0.8, -0.4, 0.06], [0.0, 0.7, -0.05]],
        [3.0, 2.0, 4.0],
    );
    let eye = DVec3::new(0.0, 0.1, -3.0);
    let mut edge_on = scene("nearly edge-on face", m, camera(96, 72), &mut rng);
    // Tilt the face until it is almost parallel to the view direction.
    for v in &mut edge_on.model.vertices {
        let (y, z) = (v[1] as f64, v[2] as f64);
        let a = 1.55f64;
        v[1] = (y * a.cos() - z * a.sin()) as f32;
        v[2] = (y * a.sin() + z * a.cos()) as f32;
    }
    edge_on.camera = facing_origin(96, 72, 86.0, eye);
    scenes.push(edge_on);

    let m = random_soup(&mut rng, 400, 3, (0.08, 0.2));
    scenes.push(scene("tiny faces", m, camera(96, 72), &mut rng));

    // Overlapping parallel faces with depths 1e-3 apart (plus exact repeats).
    let mut m = empty_model(2);
    for layer in 0..12 {
        let dz = 1e-3 * (layer / 2) as f64;
        let s = rng.uniform(0.6, 1.0);
        push_triangle(
            &mut m,
            &mut rng,
            [[-s, -s, dz], [s, -0.8 * s, dz], [0.1, s, dz]],
            [0.5, 1.0, 0.0],
        );
    }
    scenes.push(scene(
        "overlapping faces at close depths",
        m,
        camera(96, 72),
        &mut rng,
    ));

    // Big faces spanning many tiles, corners near tile borders.
    let m = random_soup(&mut rng, 20, 1, (0.8, 1.6));
    scenes.push(scene(
        "faces across tile borders",
        m,
        camera(128, 96),
        &mut rng,
    ));

    // Saturated opacities: α clamps at alpha_max, compositing stops early.
    let mut m = random_soup(&mut rng, 150, 3, (0.2, 0.7));
    for x in &mut m.opacity_logits {
        *x = 12.0;
    }
    scenes.push(scene("saturated opacities", m, camera(96, 72), &mut rng));

    // A soft window (σ < 1) and an opacity floor.
    let mut m = random_soup(&mut rng, 200, 3, (0.1, 0.6));
    m.opacity_floor = 0.05;
    let mut soft = scene(
        "soft window with opacity floor",
        m,
        camera(100, 75),
        &mut rng,
    );
    soft.settings.sigma = 0.4;
    scenes.push(soft);

    // A σ per face (a composed scene's members, frozen occluders): from the
    // sharp end of the schedule to a soft window, none equal to the render's σ.
    let mut m = random_soup(&mut rng, 180, 2, (0.1, 0.6));
    m.face_sigma = (0..m.face_count())
        .map(|f| [1e-4, 0.05, 0.3, 0.7, 1.0][f % 5])
        .collect();
    scenes.push(scene(
        "per-face window sharpness",
        m,
        camera(96, 72),
        &mut rng,
    ));
    scenes
}

/// Random upstream gradients for every output.
pub fn upstream(rng: &mut Rng, pixels: usize) -> [Vec<f32>; 4] {
    let mut g = |n: usize| {
        (0..n)
            .map(|_| rng.uniform(-1.0, 1.0) as f32)
            .collect::<Vec<f32>>()
    };
    [g(pixels * 3), g(pixels), g(pixels), g(pixels)]
}

/// ‖a − b‖ / max(‖b‖, floor): the norm-relative difference of one gradient group.
pub fn relative_difference(a: &[f32], b: &[f32], floor: f64) -> f64 {
    assert_eq!(a.len(), b.len());
    let mut diff = 0.0f64;
    let mut norm = 0.0f64;
    for (x, y) in a.iter().zip(b) {
        diff += (*x as f64 - *y as f64).powi(2);
        norm += (*y as f64).powi(2);
    }
    diff.sqrt() / norm.sqrt().max(floor)
}

use objectsplat_optim::LearningRates;
use objectsplat_raster::loss::DEFAULT_LAMBDA_DSSIM;
use objectsplat_raster_gpu::training::{DepthWeights, Step, TrainingView};

/// One training view of `scene`: a flat grey target, every pixel at `weight`.
pub fn flat_view(scene: &Scene, weight: f32) -> TrainingView {
    let pixels = (scene.camera.width * scene.camera.height) as usize;
    TrainingView::photometric(
        scene.camera,
        vec![0.5; pixels * 3],
        vec![weight; pixels],
        vec![false; pixels],
    )
}

/// A step on view 0 over a black background, every tensor at learning rate `lr`.
pub fn step_at(scene: &Scene, lr: f64) -> Step {
    Step {
        view: 0,
        background: [0.0; 3],
        render: scene.settings.clone(),
        learning_rates: LearningRates {
            positions: lr,
            sh_dc: lr,
            sh_rest: lr,
            opacity: lr,
        },
        lambda_dssim: DEFAULT_LAMBDA_DSSIM,
        sh_degree: scene.settings.sh_degree,
        depth: DepthWeights::default(),
    }
}

use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::loss::CROP_MARGIN;

/// A small object in a wider frame: `faces` random triangles around
/// (0.1, −0.12, 0), seen at 128×96 (about a tenth of the frame).
pub fn small_object_scene(faces: usize, seed: u64) -> Scene {
    let mut rng = Rng(seed);
    let mut m = empty_model(2);
    for _ in 0..faces {
        let c = [0.1, -0.12, 0.0].map(|o| o + rng.uniform(-0.3, 0.3));
        let r = rng.uniform(0.1, 0.25);
        let corners = [0, 1, 2].map(|_| [0, 1, 2].map(|a| c[a] + rng.uniform(-r, r)));
        let logits = [0, 1, 2].map(|_| rng.uniform(-1.0, 4.0));
        push_triangle(&mut m, &mut rng, corners, logits);
    }
    let camera = camera(128, 96);
    scene("small object", m, camera, &mut rng)
}

/// The object's view: the pixels of `own` keep a random target, every other
/// pixel is supervised toward the step's background colour, except a band
/// of unsupervised (weight 0) pixels, as an object component's views are.
pub fn object_view(scene: &Scene, own: PixelRect, seed: u64) -> TrainingView {
    let mut rng = Rng(seed);
    let (w, h) = (scene.camera.width, scene.camera.height);
    let pixels = (w * h) as usize;
    let mut view = TrainingView::photometric(
        scene.camera,
        (0..pixels * 3)
            .map(|_| rng.uniform(0.0, 1.0) as f32)
            .collect(),
        vec![1.0; pixels],
        vec![true; pixels],
    );
    for p in 0..pixels {
        let (x, y) = (p as u32 % w, p as u32 / w);
        if x >= own.x0 && x < own.x1 && y >= own.y0 && y < own.y1 {
            view.from_background[p] = false;
        } else if y % 11 == 3 {
            view.weights[p] = 0.0;
        }
    }
    view
}

/// The footprint region a trainer crops to: the view's own supervision, the loss's margin.
pub fn footprint() -> Region {
    Region::Footprint {
        include: PixelRect::default(),
        margin: CROP_MARGIN,
    }
}

use objectsplat_optim::Optim;
use objectsplat_raster::loss::{LossGrad, photometric};
use objectsplat_raster::{CpuBackend, OutputGrads, RenderBackend, RenderOutput, SavedForward};
use objectsplat_raster_gpu::WgpuBackend;
use objectsplat_raster_gpu::training::{DeviceTrainer, Trained};

/// The wgpu backend on the shared context, or `None` after printing why the test is skipped.
pub fn backend() -> Option<WgpuBackend> {
    context().map(|ctx| WgpuBackend::new(ctx).unwrap())
}

/// Adam at the reference settings with zero moments for `model`.
pub fn fresh_optim(model: &Model<f32>) -> Optim {
    Optim::new(FROZEN, model.vertex_count()).unwrap()
}

/// A trainer on `views` holding `model` (all of it trained), its optimizer state all zeros.
pub fn loaded_trainer(
    gpu: &WgpuBackend,
    views: &[TrainingView],
    model: &Model<f32>,
) -> DeviceTrainer {
    let mut trainer = DeviceTrainer::new(gpu, views).unwrap();
    trainer
        .load(model, Trained::all_of(model), Some(&fresh_optim(model)))
        .unwrap();
    trainer
}

/// What a device step's loss is checked against: the CPU backend's render of
/// `model` over `background`, the view's target with its background pixels in
/// that colour, and the photometric loss between the two.
pub struct CpuLoss {
    pub render: RenderOutput<f32>,
    pub saved: SavedForward,
    pub goal: Vec<f32>,
    pub loss: LossGrad<f32>,
}

pub fn cpu_loss(
    model: &Model<f32>,
    view: &TrainingView,
    settings: &RenderSettings,
    background: [f32; 3],
) -> CpuLoss {
    let camera = view.camera;
    let pixels = (camera.width * camera.height) as usize;
    let image: Vec<f32> = (0..pixels * 3).map(|i| background[i % 3]).collect();
    let (render, saved) = CpuBackend::new(2)
        .forward(model, &camera, settings, &image)
        .unwrap();
    let mut goal = view.target.clone();
    for p in (0..pixels).filter(|&p| view.from_background[p]) {
        goal[3 * p..3 * p + 3].copy_from_slice(&background);
    }
    let loss = photometric(
        objectsplat_raster::loss::Dims::rgb(camera.width, camera.height),
        &render.color,
        &goal,
        Some(&view.weights),
        DEFAULT_LAMBDA_DSSIM,
    )
    .unwrap();
    CpuLoss {
        render,
        saved,
        goal,
        loss,
    }
}

/// Learning rates of 0: a step scores and back-propagates but moves nothing.
pub const FROZEN: LearningRates = LearningRates {
    positions: 0.0,
    sh_dc: 0.0,
    sh_rest: 0.0,
    opacity: 0.0,
};

impl Scene {
    /// `backend`'s render of the scene with `settings` over its background, and
    /// what its backward pass needs.
    pub fn render_on(
        &self,
        backend: &dyn RenderBackend<f32>,
        settings: &RenderSettings,
    ) -> (RenderOutput<f32>, SavedForward) {
        backend
            .forward(&self.model, &self.camera, settings, &self.background)
            .unwrap()
    }
}

/// The per-pixel outputs and the per-face maximum weights of two renders, by name.
pub fn paired_outputs<'a>(
    got: &'a RenderOutput<f32>,
    want: &'a RenderOutput<f32>,
) -> [(&'static str, &'a [f32], &'a [f32]); 5] {
    [
        ("color", &got.color, &want.color),
        ("alpha", &got.alpha, &want.alpha),
        ("depth", &got.depth, &want.depth),
        ("median depth", &got.median_depth, &want.median_depth),
        (
            "face max weight",
            &got.face_max_weight,
            &want.face_max_weight,
        ),
    ]
}

/// Gradients for every output, borrowed from [`upstream`]'s four vectors.
pub fn every_output(upstream: &[Vec<f32>; 4]) -> OutputGrads<'_> {
    let [color, alpha, depth, median] = upstream;
    OutputGrads {
        color,
        alpha: Some(alpha),
        depth: Some(depth),
        median_depth: Some(median),
    }
}
