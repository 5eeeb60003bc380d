//! The procedural demo scene: a textured room with a table and objects, rendered by our
//! own rasterizer from an orbit of cameras, with its annotated ground-truth mesh and
//! SfM-like sparse points. Everything is a deterministic function of the parameters.
//!
//! World frame: metres, Z up, the room spans x, y ∈ [−2, 2], z ∈ [0, 2.6]; the table
//! stands at the centre. Labels: `floor`, `wall` (one object per wall), `ceiling`,
//! `table`, `box`, `cup`, `ball`, `chair`, `bin`.

mod layout;
mod points;
mod render;
pub use render::Render8;
pub mod shapes;
pub mod texture;

use anyhow::{Context, Result, bail};
use glam::DVec3;
use objectsplat_core::{Camera, Frame, Frames, Mesh, ObjectLabels, Points, SplitPolicy};
use std::path::Path;

/// How the cameras move through the room: the layouts real captures come in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CameraPath {
    /// A circle around the table at about 1.5 m, every camera on the table top.
    #[default]
    Orbit,
    /// A loop walked along the walls (0.5 m inside them, straight sides, rounded
    /// corners) at eye height, looking across the room at points that drift beside
    /// the table: corners and two walls in many frames, objects off centre.
    Walk,
    /// Standing near the table and turning: every camera looks outward at a wall
    /// (a room scan from its middle; the objects hardly show).
    Inside,
    /// A close orbit over the table top at 0.8 m, looking down at the small objects:
    /// they fill the frame, the room shows only behind them.
    Tabletop,
}

impl CameraPath {
    pub fn parse(name: &str) -> Result<Self> {
        Ok(match name {
            "orbit" => CameraPath::Orbit,
            "walk" => CameraPath::Walk,
            "inside" => CameraPath::Inside,
            "tabletop" => CameraPath::Tabletop,
            other => bail!(
                "camera path {other:?} is not one of \"orbit\", \"walk\", \"inside\", \"tabletop\""
            ),
        })
    }
}

/// What the room's shell is covered with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Surfaces {
    /// Wooden planks and striped wallpaper.
    #[default]
    Plain,
    /// Detail finer than a few pixels, as real rooms have: a brick wainscot, a
    /// printed notice of text-like glyphs on every wall, a tiled floor and a rug.
    Fine,
}

impl Surfaces {
    pub fn parse(name: &str) -> Result<Self> {
        Ok(match name {
            "plain" => Surfaces::Plain,
            "fine" => Surfaces::Fine,
            other => bail!("surfaces {other:?} is not one of \"plain\", \"fine\""),
        })
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticParams {
    pub seed: u64,
    pub views: usize,
    pub width: u32,
    pub height: u32,
    pub split: SplitPolicy,
    /// Integer downscale factor applied to `width`×`height` (1 = as given).
    pub resolution: u32,
    /// Cap on the image width after `resolution`, keeping the aspect ratio.
    pub max_width: Option<u32>,
    /// Whether the room has a table (without one the small objects stand on the floor).
    pub table: bool,
    /// Number of sparse points.
    pub points: usize,
    /// Standard deviation of the Gaussian noise added to each point (metres).
    pub points_noise: f64,
    /// Samples per pixel along each axis when rendering (anti-aliasing).
    pub supersample: u32,
    /// Horizontal field of view in degrees.
    pub fov_degrees: f64,
    /// How the cameras move through the room.
    pub path: CameraPath,
    /// What the room's shell is covered with.
    pub surfaces: Surfaces,
    pub threads: usize,
}

impl Default for SyntheticParams {
    fn default() -> Self {
        SyntheticParams {
            seed: 7,
            views: 24,
            width: 160,
            height: 120,
            split: SplitPolicy::Sparse,
            resolution: 1,
            max_width: None,
            table: true,
            points: 4000,
            points_noise: 0.01,
            supersample: 2,
            fov_degrees: 60.0,
            path: CameraPath::Orbit,
            surfaces: Surfaces::Plain,
            threads: objectsplat_masks::raster::default_threads(),
        }
    }
}

impl SyntheticParams {
    pub fn validate(&self) -> Result<()> {
        if self.views == 0 || self.views > 10_000 {
            bail!("views = {} must be in 1..=10000", self.views);
        }
        if self.resolution == 0 {
            bail!("resolution = 0 must be a downscale factor ≥ 1");
        }
        let (w, h) = self.image_size();
        if w < 8 || h < 8 || w > 8192 || h > 8192 {
            bail!(
                "image size {w}×{h} (width {}, height {}, resolution {}) must be within 8..=8192",
                self.width,
                self.height,
                self.resolution
            );
        }
        if self.supersample == 0 || self.supersample > 8 {
            bail!("supersample = {} must be in 1..=8", self.supersample);
        }
        if !(self.points_noise.is_finite() && self.points_noise >= 0.0 && self.points_noise < 1.0) {
            bail!(
                "points_noise = {} must be a finite standard deviation in [0, 1) metres",
                self.points_noise
            );
        }
        if self.points > 10_000_000 {
            bail!("points = {} is more than 10 million", self.points);
        }
        if !(self.fov_degrees.is_finite() && self.fov_degrees > 10.0 && self.fov_degrees < 150.0) {
            bail!("fov_degrees = {} must be in (10, 150)", self.fov_degrees);
        }
        Ok(())
    }

    pub fn image_size(&self) -> (u32, u32) {
        let (w, h) = (
            self.width / self.resolution.max(1),
            self.height / self.resolution.max(1),
        );
        match self.max_width {
            Some(max) if w > max => (
                max,
                ((h as u64 * max as u64 + w as u64 / 2) / w as u64) as u32,
            ),
            _ => (w, h),
        }
    }
}

/// The generated scene in memory.
#[derive(Debug, Clone)]
pub struct SyntheticScene {
    pub frames: Vec<Frame>,
    pub images: Vec<Render8>,
    pub mesh: Mesh,
    pub labels: ObjectLabels,
    pub points: Points,
}

pub fn generate(params: &SyntheticParams) -> Result<SyntheticScene> {
    params.validate()?;
    let room = layout::build_room(params.seed, params.table, params.surfaces);
    let cameras = cameras(params);
    let texture_seed = params.seed.wrapping_mul(0x2545_F491_4F6C_DD1D);
    let views = render::render_views(&room, &cameras, params, texture_seed)?;
    let points = points::sample_points(&room, &cameras, &views.depth, params, texture_seed)?;
    let splits = params.split.assign(cameras.len());
    let frames = cameras
        .iter()
        .zip(splits)
        .enumerate()
        .map(|(i, (camera, split))| {
            Frame::new(
                frame_name(i),
                format!("images/{}.png", frame_name(i)),
                camera,
                split,
            )
        })
        .collect();
    let colors = room.vertex_colors(texture_seed);
    let (mesh, labels, _, _) = room.builder.into_mesh(colors);
    Ok(SyntheticScene {
        frames,
        images: views.images,
        mesh,
        labels,
        points,
    })
}

pub fn frame_name(i: usize) -> String {
    format!("frame_{i:03}")
}

/// The room's inner bounds (metres): x, y ∈ [−2, 2], z ∈ [0, 2.6].
pub fn layout_bounds() -> (DVec3, DVec3) {
    let (h, z) = (layout::ROOM_HALF, layout::ROOM_HEIGHT);
    (DVec3::new(-h, -h, 0.0), DVec3::new(h, h, z))
}

/// The cameras of `params.path`.
pub fn cameras(params: &SyntheticParams) -> Vec<Camera> {
    match params.path {
        CameraPath::Orbit => orbit_cameras(params),
        CameraPath::Walk => walk_cameras(params),
        CameraPath::Inside => inside_cameras(params),
        CameraPath::Tabletop => tabletop_cameras(params),
    }
}

/// The pinhole focal length (px) of `params`' image width and field of view.
fn focal(params: &SyntheticParams) -> f64 {
    let (w, _) = params.image_size();
    (w as f64 / 2.0) / (params.fov_degrees.to_radians() / 2.0).tan()
}

/// A loop 0.5 m inside the walls (a square with rounded corners), eye height with a
/// walker's bob, each camera looking across the room at a point beside the table
/// that drifts with the walk.
fn walk_cameras(params: &SyntheticParams) -> Vec<Camera> {
    let (w, h) = params.image_size();
    let f = focal(params);
    let reach = layout::ROOM_HALF - 0.5;
    (0..params.views)
        .map(|i| {
            let t = i as f64 / params.views as f64;
            let angle = std::f64::consts::TAU * t + 0.2;
            // A superellipse: straight along the walls, rounded in the corners.
            let (c, s) = (angle.cos(), angle.sin());
            let squash = |v: f64| v.signum() * v.abs().powf(0.5);
            let eye = DVec3::new(
                reach * squash(c),
                reach * squash(s),
                1.55 + 0.05 * (9.0 * angle).sin(),
            );
            let side = DVec3::new(-s, c, 0.0) * (0.7 * (2.0 * angle).sin());
            let target = DVec3::new(0.0, 0.0, 0.55) + side;
            Camera::look_at(w, h, f, f, eye, target, DVec3::Z)
        })
        .collect()
}

/// Cameras 0.9 m from the room's centre at 1.4 m, each turned outward and a little
/// down, one turn around: the walls, the floor near them and what stands there.
fn inside_cameras(params: &SyntheticParams) -> Vec<Camera> {
    let (w, h) = params.image_size();
    let f = focal(params);
    (0..params.views)
        .map(|i| {
            let angle = std::f64::consts::TAU * i as f64 / params.views as f64 + 0.4;
            let out = DVec3::new(angle.cos(), angle.sin(), 0.0);
            let eye = out * 0.9 + DVec3::Z * 1.4;
            let target = out * layout::ROOM_HALF + DVec3::Z * 0.7;
            Camera::look_at(w, h, f, f, eye, target, DVec3::Z)
        })
        .collect()
}

/// A circle 0.8 m from the table's centre, 0.55 m above its top, looking at the
/// objects on it (a little off centre, alternating sides, as a hand-held sweep does).
fn tabletop_cameras(params: &SyntheticParams) -> Vec<Camera> {
    let (w, h) = params.image_size();
    let f = focal(params);
    (0..params.views)
        .map(|i| {
            let angle = std::f64::consts::TAU * i as f64 / params.views as f64 + 0.1;
            let (c, s) = (angle.cos(), angle.sin());
            let eye = DVec3::new(0.8 * c, 0.8 * s, layout::TABLE_HEIGHT + 0.55);
            let sweep = if i % 2 == 0 { 0.08 } else { -0.08 };
            let target = DVec3::new(-s * sweep, c * sweep, layout::TABLE_HEIGHT + 0.05);
            Camera::look_at(w, h, f, f, eye, target, DVec3::Z)
        })
        .collect()
}

/// Cameras on a circle around the table at about 1.5 m height, looking at its top.
pub fn orbit_cameras(params: &SyntheticParams) -> Vec<Camera> {
    let (w, h) = params.image_size();
    let f = (w as f64 / 2.0) / (params.fov_degrees.to_radians() / 2.0).tan();
    let target = DVec3::new(0.0, 0.0, 0.6);
    (0..params.views)
        .map(|i| {
            let t = i as f64 / params.views as f64;
            let angle = std::f64::consts::TAU * t + 0.3;
            let radius = 1.65 + 0.1 * (3.0 * angle).sin();
            let height = 1.5 + 0.12 * (2.0 * angle).cos();
            let eye = DVec3::new(radius * angle.cos(), radius * angle.sin(), height);
            Camera::look_at(w, h, f, f, eye, target, DVec3::Z)
        })
        .collect()
}

impl SyntheticScene {
    /// Writes the three artifacts: Frames (frames.json + images/), Mesh, Points.
    pub fn write(&self, frames_dir: &Path, mesh_dir: &Path, points_dir: &Path) -> Result<()> {
        let images_dir = frames_dir.join("images");
        for d in [
            &images_dir,
            &mesh_dir.to_path_buf(),
            &points_dir.to_path_buf(),
        ] {
            std::fs::create_dir_all(d)
                .with_context(|| format!("{}: cannot create folder", d.display()))?;
        }
        for (frame, image) in self.frames.iter().zip(&self.images) {
            objectsplat_core::image::write_rgb8(
                &frames_dir.join(&frame.image),
                &image.rgb,
                image.width,
                image.height,
            )?;
        }
        Frames::write_json(frames_dir, &self.frames)?;
        objectsplat_core::write_mesh_artifact(mesh_dir, &self.mesh, &self.labels)?;
        self.points
            .write_ply(&points_dir.join(objectsplat_core::artifact::POINTS_PLY))?;
        Ok(())
    }

    pub fn cameras(&self) -> Vec<Camera> {
        self.frames.iter().map(Frame::camera).collect()
    }
}
