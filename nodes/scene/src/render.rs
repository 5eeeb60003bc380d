//! Rendering a scene: the merged model over a uniform colour or a per-pixel
//! background image, from the frames' cameras or an orbit around the scene.

use crate::scene::Scene;
use anyhow::{Context, Result, bail, ensure};
use glam::DVec3;
use objectsplat_core::{Camera, ComponentKind, Frame, Image};
use objectsplat_raster::{Model, RenderBackend, RenderOutput, RenderSettings, supersample};

/// What shows where no triangle covers a pixel.
pub enum Backdrop<'a> {
    Uniform([f32; 3]),
    /// An RGB image of the camera's size (e.g. an inpainted background view).
    Image(&'a Image),
}

/// Renders `model` (typically [`Scene::merged_model`]) from `camera` with the model's σ and
/// degree, at `supersample²` samples per pixel box-filtered (1: one sample).
pub fn render_view(
    model: &Model<f32>,
    camera: &Camera,
    backdrop: &Backdrop,
    backend: &dyn RenderBackend<f32>,
    supersample: u32,
) -> Result<Image> {
    camera
        .validate()
        .map_err(|e| anyhow::anyhow!("invalid camera: {e}"))?;
    supersample::validate(supersample)?;
    let s = supersample as usize;
    let (width, height) = (camera.width as usize, camera.height as usize);
    let background: Vec<f32> = match backdrop {
        Backdrop::Uniform(rgb) => (0..width * height * s * s * 3)
            .map(|i| rgb[i % 3])
            .collect(),
        Backdrop::Image(image) => {
            ensure!(
                (image.width, image.height) == (camera.width, camera.height),
                "background image is {}×{} but the camera is {}×{}",
                image.width,
                image.height,
                camera.width,
                camera.height
            );
            let rgb = image.to_rgb();
            rgb.check_finite("background image")?;
            // Every sample of a pixel shows the pixel's fill.
            let mut fine = Vec::new();
            supersample::replicate_into(1, &rgb.data, 3, width, height, supersample, &mut fine);
            fine
        }
    };
    let settings = RenderSettings::for_model(model);
    let (fine_camera, settings) = supersample::fine_view(camera, &settings, supersample);
    let (fine, _) = backend.forward(model, &fine_camera, &settings, &background)?;
    ensure!(fine.all_finite(), "the renderer produced non-finite values");
    if supersample == 1 {
        return Ok(fine.color_image());
    }
    let mut out = RenderOutput::default();
    supersample::downsample_into(1, &fine, supersample, &mut out)?;
    Ok(out.color_image())
}

/// Axis-aligned world bounds of the object members' vertices, or of every member when
/// the scene has no object with vertices. `None` for a scene without vertices.
pub fn focus_bounds(scene: &Scene) -> Result<Option<(DVec3, DVec3)>> {
    let world: Vec<_> = scene
        .objects
        .iter()
        .map(|o| Ok((o.entry.kind, o.world_model()?)))
        .collect::<Result<_>>()?;
    let bounds_of = |objects_only: bool| {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        let mut any = false;
        for (kind, model) in &world {
            if objects_only && *kind != ComponentKind::Object {
                continue;
            }
            for v in &model.vertices {
                let p = DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
                lo = lo.min(p);
                hi = hi.max(p);
                any = true;
            }
        }
        any.then_some((lo, hi))
    };
    Ok(bounds_of(true).or_else(|| bounds_of(false)))
}

/// `count` cameras on a circle around the scene's focus (the centre of the objects'
/// bounds), using the intrinsics of the first frame. The circle lies in the plane
/// perpendicular to the frames' mean "up" (−y camera axis), at the frames' mean
/// height above the focus and their mean horizontal distance from it; it starts at
/// the first frame's bearing.
pub fn orbit_cameras(scene: &Scene, frames: &[Frame], count: usize) -> Result<Vec<Camera>> {
    let Some(first) = frames.first() else {
        bail!("an orbit needs at least one frame for its intrinsics and scale");
    };
    let Some((lo, hi)) = focus_bounds(scene)? else {
        bail!("the scene has no vertices to orbit around");
    };
    let focus = (lo + hi) * 0.5;
    let cameras: Vec<Camera> = frames.iter().map(|f| f.camera()).collect();
    let up_sum: DVec3 = cameras
        .iter()
        .map(|c| -(c.rotation().transpose() * DVec3::Y))
        .sum();
    ensure!(
        up_sum.length() > 1e-9,
        "the frames' up directions cancel out; no orbit plane can be chosen"
    );
    let up = up_sum.normalize();
    let offsets: Vec<DVec3> = cameras.iter().map(|c| c.center() - focus).collect();
    let height = offsets.iter().map(|o| o.dot(up)).sum::<f64>() / offsets.len() as f64;
    let radius = offsets
        .iter()
        .map(|o| (*o - up * o.dot(up)).length())
        .sum::<f64>()
        / offsets.len() as f64;
    ensure!(
        radius > 1e-6,
        "the frames sit on the scene's vertical axis; an orbit radius cannot be derived"
    );
    let start = offsets[0] - up * offsets[0].dot(up);
    let e1 = if start.length() > 1e-9 {
        start.normalize()
    } else {
        up.any_orthonormal_vector()
    };
    let e2 = up.cross(e1);
    let cam0 = first.camera();
    (0..count)
        .map(|k| {
            let angle = std::f64::consts::TAU * k as f64 / count as f64;
            let eye = focus + up * height + (e1 * angle.cos() + e2 * angle.sin()) * radius;
            let mut cam =
                Camera::look_at(cam0.width, cam0.height, cam0.fx, cam0.fy, eye, focus, up);
            cam.cx = cam0.cx;
            cam.cy = cam0.cy;
            cam.validate()
                .map_err(|e| anyhow::anyhow!("orbit camera {k}: {e}"))
                .context("the orbit looks straight along the up axis")?;
            Ok(cam)
        })
        .collect()
}
