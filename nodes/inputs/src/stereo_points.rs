//! The `stereo_points` node: structure from motion's sparse points made dense by
//! plane-sweep stereo over the training views (`crate::stereo`).

use crate::scene;
use crate::stereo::{StereoSettings, StereoView, dense_points};
use anyhow::{Context as _, Result, bail};
use objectsplat_core::artifact::POINTS_PLY;
use objectsplat_core::{Frames, Points, Split};
use objectsplat_runtime::{
    Context, Node, NodeParams, NodeSpec, Outcome, ParamError, ParamType, Params, node_params,
    node_ports,
};

node_params! {
    /// The parameters of `stereo_points`.
    pub struct StereoPointsParams {
        /// neighbour views each training view is matched against
        neighbours: i64 = "4" as ParamType::int_range(1, 32),
        /// depth planes swept per view (uniform in inverse depth over the sparse points' range)
        depth_planes: i64 = "128" as ParamType::int_range(3, 4096),
        /// side of the correlation window in pixels (odd)
        window: i64 = "7" as ParamType::int_range(3, 63),
        /// lowest normalised cross-correlation a depth is accepted with
        min_ncc: f64 = "0.6" as ParamType::float_range(-1.0, 1.0),
        /// lowest standard deviation of a window's grey levels (0–1); flatter windows match anything
        min_texture: f64 = "0.01" as ParamType::float_range(0.0, 1.0),
        /// neighbours whose own depths must agree for a depth to be kept
        min_consistent: i64 = "2" as ParamType::int_range(1, 32),
        /// reprojection error allowed in that agreement, in pixels
        max_reprojection_px: f64 = "1.0" as ParamType::float_range(1e-3, 100.0),
        /// relative depth difference allowed in that agreement
        max_relative_depth: f64 = "0.01" as ParamType::float_range(1e-5, 1.0),
        /// at most this many dense points (averaged on a voxel grid coarsened until they fit)
        max_points: i64 = "20000" as ParamType::int_range(1, 100_000_000),
        /// longest image side matched at; larger frames are downscaled (area average)
        max_image_size: i64 = "640" as ParamType::int_range(16, 100_000),
    }
}

node_ports! {
    struct StereoPointsPorts {
        /// posed photos; only the training views are matched (test views stay unseen)
        frames: input "Frames",
        /// sparse points (e.g. colmap_sfm's): each view's depth range and neighbour choice
        points: input "Points",
        /// the sparse points followed by the dense ones
        dense: output "Points",
    }
}

/// `stereo_points`: dense points for the trainer where SfM's are sparse.
pub struct StereoPoints;

impl StereoPointsParams {
    fn settings(&self) -> Result<StereoSettings> {
        let count = |name: &str, v: i64| {
            usize::try_from(v).with_context(|| format!("{name} = {v} is out of range"))
        };
        Ok(StereoSettings {
            neighbours: count("neighbours", self.neighbours)?,
            depth_planes: count("depth_planes", self.depth_planes)?,
            window: count("window", self.window)?,
            min_ncc: self.min_ncc as f32,
            min_texture: self.min_texture as f32,
            min_consistent: count("min_consistent", self.min_consistent)?,
            max_reprojection_px: self.max_reprojection_px,
            max_relative_depth: self.max_relative_depth,
            max_points: count("max_points", self.max_points)?,
        })
    }
}

impl Node for StereoPoints {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("stereo_points", "1")
            .doc("Dense points from posed photos by plane-sweep stereo on the CPU, for captures whose only points are structure from motion's (features match where texture is, so plain walls and floors get few). Each training view is matched against its best neighbours by triangulation angle over fronto-parallel planes in the depth range of the sparse points it sees (normalised cross-correlation, the best half of the neighbours averaged); a depth is kept where enough neighbours' depth maps agree, and the points are averaged on a voxel grid. Test views are never read. Output: the sparse points, then the dense ones.")
            .ports::<StereoPointsPorts>()
            .params::<StereoPointsParams>()
    }

    fn check_params(&self, params: &Params) -> Vec<ParamError> {
        let Ok(p) = StereoPointsParams::try_read(params) else {
            // Ill-typed params are reported by the engine's type check.
            return Vec::new();
        };
        let mut problems = Vec::new();
        if p.window % 2 == 0 {
            problems.push(ParamError::new(
                "window",
                format!(
                    "{} is even; the window is centred on a pixel, so its side must be odd",
                    p.window
                ),
            ));
        }
        if p.min_consistent > p.neighbours {
            problems.push(ParamError::new(
                "min_consistent",
                format!(
                    "{} exceeds `neighbours` ({}): a depth is checked against that many views at most",
                    p.min_consistent, p.neighbours
                ),
            ));
        }
        problems
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: StereoPointsPorts = ctx.ports_as()?;
        let p: StereoPointsParams = ctx.params_as()?;
        let settings = p.settings()?;
        let frames = Frames::read(&ports.frames)?;
        let sparse = Points::read_ply(&ports.points.join(POINTS_PLY))?;
        let train: Vec<_> = frames.by_split(Split::Train).collect();
        if train.len() < 2 {
            bail!(
                "{}: stereo needs at least two training views, the frames have {}",
                ports.frames.display(),
                train.len()
            );
        }
        if sparse.positions.is_empty() {
            bail!(
                "{}: no sparse points: each view's depth range comes from them",
                ports.points.display()
            );
        }
        let longest = p.max_image_size as u32;
        let mut views = Vec::with_capacity(train.len());
        for (i, frame) in train.iter().enumerate() {
            ctx.progress(i as u64, train.len() as u64, "reading the training views");
            let mut rgb = frames.load_rgb(frame)?;
            let mut camera = frame.camera();
            let side = rgb.width.max(rgb.height);
            if side > longest {
                let scale = longest as f64 / side as f64;
                let (w, h) = (
                    ((rgb.width as f64 * scale).round() as u32).max(1),
                    ((rgb.height as f64 * scale).round() as u32).max(1),
                );
                rgb = rgb.resize_area(w, h);
                camera = camera.scaled(w, h);
            }
            views.push(StereoView { camera, rgb });
        }
        let result = dense_points(
            &views,
            &sparse,
            &settings,
            ctx.threads(),
            &mut |done, total| ctx.progress(done as u64, total as u64, "sweeping depth planes"),
        )?;
        let unmatched: Vec<&str> = train
            .iter()
            .zip(&result.neighbours)
            .filter(|(_, n)| n.is_empty())
            .map(|(f, _)| f.name.as_str())
            .collect();
        if !unmatched.is_empty() {
            ctx.note(
                "views_without_depth",
                format!(
                    "{} (too few sparse points in view, or no neighbour within 60°)",
                    unmatched.join(", ")
                ),
            );
        }
        let filled: usize = result.depth_maps.iter().map(|m| m.filled()).sum();
        let pixels: usize = views.iter().map(|v| v.rgb.pixel_count()).sum();
        ctx.note(
            "depth_filled",
            format!(
                "{:.1} % of training pixels",
                100.0 * filled as f64 / pixels.max(1) as f64
            ),
        );
        ctx.note("consistent_depths", result.kept.iter().sum::<usize>());
        ctx.note("dense_points", result.points.positions.len());
        ctx.note("voxel", format!("{:.4}", result.voxel));
        let mut out = sparse;
        out.positions.extend(result.points.positions);
        out.colors.extend(result.points.colors);
        scene::write_points(&ports.dense, &out)?;
        Ok(Outcome::Done)
    }
}
