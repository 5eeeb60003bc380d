//! Scoring a reconstruction: the `evaluate` node. Image metrics of the test renders
//! (PSNR, SSIM, LPIPS; per object masked by the ground-truth id maps) and the F-score of
//! the scene's visible surface against the ground-truth mesh, scene-wide and per object,
//! written as the Metrics artifact. The metric math lives in `objectsplat-metrics`.

pub mod evaluate;

use anyhow::{Context as _, Result};
use evaluate::{EvaluateSettings, GroundTruth, GtSurface, evaluate_scene};
use objectsplat_core::{Frames, read_mesh_artifact};
use objectsplat_metrics::{Lpips, MeshEvalParams, SampleCount, SsimMode};
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Registry, node_ports};
use objectsplat_scene::load_scene;
use std::path::Path;
use std::sync::Arc;

objectsplat_runtime::node_params! {
    /// The parameters of `evaluate`.
    pub struct EvaluateParams {
        /// F-score distance threshold (m)
        tau: f64 = "0.05" as ParamType::float_range(1e-6, 10.0),
        /// more thresholds (m) at which every object's precision, recall and F-score are
        /// reported (metrics.json objects[].thresholds)
        object_taus: Vec<f64> = "[0.05, 0.02]" as ParamType::list(ParamType::float_range(1e-6, 10.0)),
        /// voxel size for down-sampling both point sets (m)
        voxel: f64 = "0.02" as ParamType::float_range(1e-6, 10.0),
        /// surface samples per square metre
        samples: f64 = "10000.0" as ParamType::float_range(1.0, 1e8),
        /// seed of the surface sampling
        seed: i64 = "0" as ParamType::int_range(0, i64::MAX),
        /// cap on the samples drawn on one surface (ground truth, scene, each object); a
        /// surface that needs more (area × samples) fails the node naming its area, as a
        /// diverged model's does, instead of exhausting memory
        max_samples: i64 = "10000000" as ParamType::int_range(1, i64::MAX),
        /// SSIM border convention: 3DGS zero padding, or scikit-image's 5-pixel crop
        ssim: String = "\"gs3d\"" as ParamType::enumeration(&["gs3d", "cropped"]),
        /// AlexNet LPIPS weights (safetensors); LPIPS is skipped without it
        lpips_weights: Option<String> = "None" as ParamType::optional(ParamType::Path),
        /// ground truth of the F-scores: the mesh surface at least one frame sees
        /// (depth-tested), or the whole mesh
        gt_surface: String = "\"observed\"" as ParamType::enumeration(&["observed", "all"]),
    }
}

/// `evaluate`: image metrics of the test renders and mesh F-score, scene and per object.
pub struct Evaluate;

node_ports! {
    struct EvaluatePorts {
        /// renders of the test frames (<frame stem>.png)
        images: input "Images",
        /// the capture; its test split is the ground truth
        frames: input "Frames",
        /// the same test views rendered as exported (render's appearance: exported),
        /// scored beside `images` (exported_psnr, exported_ssim)
        exported: optional "Images",
        /// the scene whose surface is scored
        scene: input "Scene",
        /// ground-truth mesh; per-object F-score needs its object ids
        mesh: optional "Mesh",
        /// ground-truth object-id maps of the test frames, for per-object image metrics
        masks: optional "Masks",
        /// metrics.json + metrics.csv
        metrics: output "Metrics",
    }
}

impl Node for Evaluate {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("evaluate", "7")
            .doc("PSNR and SSIM per test image and averaged (per object: masked by the ground-truth id maps), LPIPS when a weights file is given, and the F-score of the scene's visible surface (faces the renderer can draw) against the ground-truth mesh, for the scene and per object id (per object also at each of object_taus), and the normal consistency of the same surfaces (area-weighted |cos| between each face and the true surface nearest it). With the mesh, also the share of each object's true pixels in the test views where the background member renders an at least half-opaque surface nearer than the object by more than tau (floaters and sheets in front of objects). With `exported` (the test views rendered as the .glb holds the scene), their PSNR and SSIM too: the gap to `images` is what a user loses by opening the export. Writes metrics.json and metrics.csv.")
            .ports::<EvaluatePorts>()
            .params::<EvaluateParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: EvaluatePorts = ctx.ports_as()?;
        let p: EvaluateParams = ctx.params_as()?;
        let tau: f64 = p.tau;
        let voxel: f64 = p.voxel;
        let samples: f64 = p.samples;
        let seed: i64 = p.seed;
        let max_samples: i64 = p.max_samples;
        let ssim: String = p.ssim;
        let lpips_path: Option<String> = p.lpips_weights;
        let ssim = if ssim == "cropped" {
            SsimMode::Cropped
        } else {
            SsimMode::Gs3d
        };
        let lpips = match &lpips_path {
            Some(p) => Some(
                Lpips::load(Path::new(p))
                    .with_context(|| format!("{p}: cannot load LPIPS weights"))?,
            ),
            None => None,
        };
        let frames = Frames::read(&ports.frames)?;
        let scene = load_scene(&ports.scene)?;
        let gt_mesh = match ports.mesh.as_deref() {
            Some(dir) => Some(read_mesh_artifact(dir)?),
            None => None,
        };
        let truth = GroundTruth {
            mesh: gt_mesh.as_ref().map(|(m, l)| (m, l)),
            masks: ports.masks.as_deref(),
        };
        let backend = objectsplat_raster::CpuBackend::new(ctx.threads().max(1));
        let settings = EvaluateSettings {
            backend: &backend,
            mesh: MeshEvalParams {
                tau,
                voxel,
                samples: SampleCount::PerArea(samples),
                // Non-negative: the param range starts at 0.
                seed: seed as u64,
                // The param range is 1..; a cap beyond usize (32-bit) saturates.
                max_samples: usize::try_from(max_samples).unwrap_or(usize::MAX),
            },
            object_taus: p.object_taus,
            ssim,
            lpips: lpips.as_ref(),
            gt_surface: match p.gt_surface.as_str() {
                "all" => GtSurface::All,
                _ => GtSurface::Observed,
            },
        };
        ctx.progress(0, 1, "evaluating");
        let (report, summary) = evaluate_scene(
            &ports.images,
            ports.exported.as_deref(),
            &frames,
            &scene,
            &truth,
            &settings,
        )?;
        report.write(&ports.metrics)?;
        ctx.progress(1, 1, "evaluated");
        ctx.note("test images", summary.test_images);
        ctx.note("images with object masks", summary.images_with_masks);
        ctx.note("objects", summary.objects);
        ctx.note(
            "lpips",
            if lpips.is_some() {
                "computed"
            } else {
                "skipped: no weights"
            },
        );
        if gt_mesh.is_none() {
            ctx.note("mesh F-score", "skipped: no ground-truth mesh wired");
        }
        for o in report.objects.iter().filter(|o| !o.thresholds.is_empty()) {
            let scores: Vec<String> = o
                .thresholds
                .iter()
                .map(|t| {
                    let show = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.3}"));
                    format!(
                        "τ {} cm: P {} R {}",
                        t.tau * 100.0,
                        show(t.precision),
                        show(t.recall)
                    )
                })
                .collect();
            ctx.note(&format!("object {} {}", o.id, o.label), scores.join(", "));
        }
        Ok(Outcome::Done)
    }
}

pub fn register(reg: &mut Registry) {
    // A clash means another crate registered the kind first, which the catalogue's tests catch.
    reg.add_node(Arc::new(Evaluate))
        .expect("node kind `evaluate` is registered once");
}
