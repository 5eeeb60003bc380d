//! The Metrics artifact: `metrics.json` and `metrics.csv` in a folder.
//!
//! `metrics.json` (top level = scene averages):
//! - `psnr`, `ssim`, `lpips`: means over the test images; `lpips` is null when no
//!   weights were given, and `lpips_status` then says it was skipped;
//! - `ssim_convention`: which SSIM border convention was used;
//! - `fscore`, `precision`, `recall`, `accuracy`, `completeness`, `tau`, `voxel`:
//!   the whole-scene mesh F-score (null when no mesh was evaluated);
//! - `normal_consistency`: area-weighted |cos| between the predicted faces and the true
//!   surface nearest them (null without a mesh; absent in older reports);
//! - `gt_surface`: which ground-truth surface the F-scores compare against (the
//!   whole mesh, or only what the capture's frames see);
//! - `objects`: one entry per object with `id`, `label` and the same fields —
//!   `psnr`/`ssim` are masked by the object's pixels and averaged over the images
//!   that show it, `lpips` is always null (LPIPS has no masked form) — and, when the
//!   evaluation asked for more thresholds, `thresholds`: one `{tau, fscore, precision,
//!   recall}` per threshold (absent in reports written before it existed, and read as
//!   empty);
//! - `images`: per test image `name`, `psnr`, `ssim`, `lpips`, and `objects`
//!   (per object `id`, `psnr`, `ssim`).
//!
//! A PSNR of identical images is infinite and written as null (JSON has no infinity).
//!
//! `metrics.csv`: one row per scene / object / image with columns
//! `scope,name,id,label,psnr,ssim,lpips,fscore,precision,recall,accuracy,completeness,tau,normal_consistency`,
//! then one `object_tau` row per object and extra threshold (fscore, precision, recall,
//! tau); empty cells mean null.

use anyhow::{Context, Result};
use objectsplat_core::artifact::{METRICS_CSV, METRICS_JSON};
use serde::{Deserialize, Serialize, Serializer};
use std::path::Path;

/// Writes non-finite numbers as null.
fn finite_or_null<S: Serializer>(v: &Option<f64>, s: S) -> std::result::Result<S::Ok, S::Error> {
    match v {
        Some(x) if x.is_finite() => s.serialize_f64(*x),
        _ => s.serialize_none(),
    }
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectImageMetrics {
    pub id: u16,
    #[serde(serialize_with = "finite_or_null")]
    pub psnr: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub ssim: Option<f64>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ImageMetrics {
    pub name: String,
    #[serde(serialize_with = "finite_or_null")]
    pub psnr: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub ssim: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub lpips: Option<f64>,
    pub objects: Vec<ObjectImageMetrics>,
}

/// Mesh and image metrics of one scope (the scene or one object).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ScopeMetrics {
    #[serde(serialize_with = "finite_or_null")]
    pub psnr: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub ssim: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub lpips: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub fscore: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub precision: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub recall: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub accuracy: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub completeness: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub tau: Option<f64>,
    /// Area-weighted |cos| between the predicted faces and the true surface nearest them
    /// ([`crate::normals`]); absent in older reports.
    #[serde(default, serialize_with = "finite_or_null")]
    pub normal_consistency: Option<f64>,
    /// PSNR of the scene rendered as exported (opaque, hard-edged, flat colours:
    /// what a user who opens the `.glb` sees); absent when not scored.
    #[serde(default, serialize_with = "finite_or_null")]
    pub exported_psnr: Option<f64>,
    /// SSIM of the same renders.
    #[serde(default, serialize_with = "finite_or_null")]
    pub exported_ssim: Option<f64>,
    /// The share of the object's true pixels in the test views where the background
    /// hangs in front of it (see `evaluate`); for the scene, over every object.
    #[serde(default, serialize_with = "finite_or_null")]
    pub background_in_front: Option<f64>,
}

/// An object's mesh scores at one more threshold.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ThresholdMetrics {
    pub tau: f64,
    #[serde(serialize_with = "finite_or_null")]
    pub fscore: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub precision: Option<f64>,
    #[serde(serialize_with = "finite_or_null")]
    pub recall: Option<f64>,
}

/// Reading is lenient (missing fields take their defaults, `object_id` is read as `id`), so
/// metrics a plugin or an older version wrote still load.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ObjectMetrics {
    #[serde(alias = "object_id")]
    pub id: u16,
    pub label: String,
    #[serde(flatten)]
    pub metrics: ScopeMetrics,
    /// How many test images show the object (its image metrics average over these).
    pub images: usize,
    /// Mesh scores at the extra thresholds the evaluation asked for.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub thresholds: Vec<ThresholdMetrics>,
}

/// The Metrics artifact's `metrics.json`. Reading is lenient like [`ObjectMetrics`]'s.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MetricsReport {
    #[serde(flatten)]
    pub scene: ScopeMetrics,
    #[serde(serialize_with = "finite_or_null")]
    pub voxel: Option<f64>,
    pub ssim_convention: String,
    pub lpips_status: String,
    /// Which ground-truth surface the F-scores use (null without a mesh).
    pub gt_surface: Option<String>,
    pub objects: Vec<ObjectMetrics>,
    pub images: Vec<ImageMetrics>,
}

#[derive(Serialize)]
struct CsvRow<'a> {
    scope: &'static str,
    name: &'a str,
    id: Option<u16>,
    label: &'a str,
    psnr: Option<f64>,
    ssim: Option<f64>,
    lpips: Option<f64>,
    fscore: Option<f64>,
    precision: Option<f64>,
    recall: Option<f64>,
    accuracy: Option<f64>,
    completeness: Option<f64>,
    tau: Option<f64>,
    normal_consistency: Option<f64>,
    exported_psnr: Option<f64>,
    exported_ssim: Option<f64>,
    background_in_front: Option<f64>,
}

impl<'a> CsvRow<'a> {
    fn scope(
        scope: &'static str,
        name: &'a str,
        id: Option<u16>,
        label: &'a str,
        m: &ScopeMetrics,
    ) -> Self {
        let f = |v: Option<f64>| v.filter(|x| x.is_finite());
        CsvRow {
            scope,
            name,
            id,
            label,
            psnr: f(m.psnr),
            ssim: f(m.ssim),
            lpips: f(m.lpips),
            fscore: f(m.fscore),
            precision: f(m.precision),
            recall: f(m.recall),
            accuracy: f(m.accuracy),
            completeness: f(m.completeness),
            tau: f(m.tau),
            normal_consistency: f(m.normal_consistency),
            exported_psnr: f(m.exported_psnr),
            exported_ssim: f(m.exported_ssim),
            background_in_front: f(m.background_in_front),
        }
    }
}

impl MetricsReport {
    /// Writes `metrics.json` and `metrics.csv` into `dir` (created if missing).
    pub fn write(&self, dir: &Path) -> Result<()> {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create folder", dir.display()))?;
        let json_path = dir.join(METRICS_JSON);
        let json = serde_json::to_string_pretty(self)?;
        std::fs::write(&json_path, json + "\n")
            .with_context(|| format!("{}: cannot write", json_path.display()))?;
        let csv_path = dir.join(METRICS_CSV);
        std::fs::write(&csv_path, self.to_csv()?)
            .with_context(|| format!("{}: cannot write", csv_path.display()))
    }

    pub fn read(dir: &Path) -> Result<MetricsReport> {
        objectsplat_core::files::read_json(&dir.join(METRICS_JSON), "metrics file")
    }

    pub fn to_csv(&self) -> Result<String> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(CsvRow::scope("scene", "scene", None, "", &self.scene))?;
        for o in &self.objects {
            w.serialize(CsvRow::scope(
                "object",
                &o.label,
                Some(o.id),
                &o.label,
                &o.metrics,
            ))?;
        }
        for o in &self.objects {
            for t in &o.thresholds {
                let m = ScopeMetrics {
                    fscore: t.fscore,
                    precision: t.precision,
                    recall: t.recall,
                    tau: Some(t.tau),
                    ..Default::default()
                };
                w.serialize(CsvRow::scope(
                    "object_tau",
                    &o.label,
                    Some(o.id),
                    &o.label,
                    &m,
                ))?;
            }
        }
        for img in &self.images {
            let m = ScopeMetrics {
                psnr: img.psnr,
                ssim: img.ssim,
                lpips: img.lpips,
                ..Default::default()
            };
            w.serialize(CsvRow::scope("image", &img.name, None, "", &m))?;
        }
        // Invariant: writing into a Vec cannot fail, and the rows are UTF-8 strings.
        let bytes = w
            .into_inner()
            .map_err(|e| anyhow::anyhow!("CSV buffer: {e}"))?;
        Ok(String::from_utf8(bytes)?)
    }
}
