//! The model's on-disk encoding: a folder holding `model.ply` and `model.json`
//! (see the crate README, section "Model encoding").

use crate::model::{MAX_SH_DEGREE, Model, SH_COEFFS};
use crate::sh::SH_DC;
use anyhow::{Context, Result, bail};
use objectsplat_core::Ply;
use objectsplat_core::artifact::{MODEL_JSON, MODEL_PLY};
use objectsplat_core::ply::{Column, Element, Format, Property, ScalarType};
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use std::path::Path;

/// Number of `f_rest_*` properties (15 coefficients × 3 channels).
const REST: usize = (SH_COEFFS - 1) * 3;

#[derive(Debug, Serialize, Deserialize)]
struct ModelJson {
    sh_degree: u32,
    opacity_floor: f64,
    sigma: f64,
    #[serde(default)]
    metadata: Map<String, Value>,
}

/// The 8-bit display colour of an SH DC coefficient: `clamp(0.5 + C0·dc, 0, 1)·255`, rounded.
pub fn dc_to_u8(dc: f32) -> u8 {
    ((0.5 + SH_DC * dc as f64).clamp(0.0, 1.0) * 255.0).round() as u8
}

/// The model's mesh as a PLY: positions, display colours (the flat colours,
/// [`Model::flat_dc`]), all SH coefficients, opacity logits, the baked flat
/// colours' DC coefficients where the model has them (`flat_dc_0..2`) and faces.
pub fn model_to_ply(model: &Model<f32>) -> Ply {
    let nv = model.vertex_count();
    let col = |f: &dyn Fn(usize) -> f32| Column::F32((0..nv).map(f).collect());
    let mut vertex = Element::new("vertex", nv);
    for (a, name) in ["x", "y", "z"].iter().enumerate() {
        vertex = vertex.with(Property::scalar(*name, col(&|v| model.vertices[v][a])));
    }
    for (ch, name) in ["red", "green", "blue"].iter().enumerate() {
        vertex = vertex.with(Property::scalar(
            *name,
            Column::U8((0..nv).map(|v| dc_to_u8(model.flat_dc(v)[ch])).collect()),
        ));
    }
    for ch in 0..3 {
        vertex = vertex.with(Property::scalar(
            format!("f_dc_{ch}"),
            col(&|v| model.sh[v][0][ch]),
        ));
    }
    // Channel-major like 3DGS: f_rest_{ch·15 + (k − 1)} = sh[v][k][ch].
    for i in 0..REST {
        let (ch, k) = (i / (SH_COEFFS - 1), i % (SH_COEFFS - 1) + 1);
        vertex = vertex.with(Property::scalar(
            format!("f_rest_{i}"),
            col(&|v| model.sh[v][k][ch]),
        ));
    }
    vertex = vertex.with(Property::scalar(
        "opacity",
        col(&|v| model.opacity_logits[v]),
    ));
    if !model.flat_dc.is_empty() {
        for ch in 0..3 {
            vertex = vertex.with(Property::scalar(
                format!("flat_dc_{ch}"),
                col(&|v| model.flat_dc[v][ch]),
            ));
        }
    }
    let nf = model.face_count();
    let offsets: Vec<usize> = (0..=nf).map(|i| i * 3).collect();
    let indices = Column::I32(model.faces.iter().flatten().map(|&i| i as i32).collect());
    let face = Element::new("face", nf).with(Property::list(
        "vertex_indices",
        ScalarType::U8,
        offsets,
        indices,
    ));
    Ply::new(vec![vertex, face])
}

/// Writes `model.ply` and `model.json` into `dir` (created if missing).
pub fn save_model(model: &Model<f32>, dir: &Path) -> Result<()> {
    model
        .validate()
        .context("refusing to save an invalid model")?;
    if !model.face_sigma.is_empty() {
        bail!(
            "the model carries a σ per face (a union of models rendered together); \
             save its parts instead"
        );
    }
    if model.vertex_count() > i32::MAX as usize {
        bail!(
            "model has {} vertices; PLY int indices cannot address them",
            model.vertex_count()
        );
    }
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create model folder {}", dir.display()))?;
    model_to_ply(model).write(&dir.join(MODEL_PLY), Format::BinaryLittleEndian)?;
    let json = ModelJson {
        sh_degree: model.sh_degree,
        opacity_floor: model.opacity_floor,
        sigma: model.sigma,
        metadata: model.metadata.clone(),
    };
    let path = dir.join(MODEL_JSON);
    std::fs::write(&path, serde_json::to_string_pretty(&json)?)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Reads a model folder written by [`save_model`] and validates it.
pub fn load_model(dir: &Path) -> Result<Model<f32>> {
    let json_path = dir.join(MODEL_JSON);
    let text = std::fs::read_to_string(&json_path)
        .with_context(|| format!("cannot read {}", json_path.display()))?;
    let meta: ModelJson = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a valid model.json", json_path.display()))?;
    if meta.sh_degree > MAX_SH_DEGREE {
        bail!(
            "{}: sh_degree {} exceeds {MAX_SH_DEGREE}",
            json_path.display(),
            meta.sh_degree
        );
    }
    let ply_path = dir.join(MODEL_PLY);
    let ply = Ply::read(&ply_path)?;
    let in_ply = |m: String| anyhow::anyhow!("{}: {m}", ply_path.display());
    let vertex = ply.element("vertex").map_err(in_ply)?;
    let nv = vertex.count;
    let get = |name: &str| vertex.scalar_f32(name).map_err(in_ply);
    let (x, y, z) = (get("x")?, get("y")?, get("z")?);
    let dc: Vec<Vec<f32>> = (0..3)
        .map(|c| get(&format!("f_dc_{c}")))
        .collect::<Result<_>>()?;
    let rest: Vec<Vec<f32>> = (0..REST)
        .map(|i| get(&format!("f_rest_{i}")))
        .collect::<Result<_>>()?;
    let opacity = get("opacity")?;
    let mut model = Model::<f32>::empty();
    model.vertices = (0..nv).map(|v| [x[v], y[v], z[v]]).collect();
    model.sh = (0..nv)
        .map(|v| {
            let mut rows = [[0.0f32; 3]; SH_COEFFS];
            for ch in 0..3 {
                rows[0][ch] = dc[ch][v];
                for k in 1..SH_COEFFS {
                    rows[k][ch] = rest[ch * (SH_COEFFS - 1) + k - 1][v];
                }
            }
            rows
        })
        .collect();
    model.opacity_logits = opacity;
    if vertex.has("flat_dc_0") {
        let flat: Vec<Vec<f32>> = (0..3)
            .map(|c| get(&format!("flat_dc_{c}")))
            .collect::<Result<_>>()?;
        model.flat_dc = (0..nv)
            .map(|v| [flat[0][v], flat[1][v], flat[2][v]])
            .collect();
    }
    let faces = ply.element("face").map_err(in_ply)?;
    let list = faces.list_u32("vertex_indices").map_err(in_ply)?;
    model.faces = Vec::with_capacity(list.len());
    for (f, row) in list.rows().enumerate() {
        let [a, b, c] = row else {
            bail!(
                "{}: face {f} has {} vertices; only triangles are supported",
                ply_path.display(),
                row.len()
            );
        };
        model.faces.push([*a, *b, *c]);
    }
    model.sh_degree = meta.sh_degree;
    model.opacity_floor = meta.opacity_floor;
    model.sigma = meta.sigma;
    model.metadata = meta.metadata;
    model
        .validate()
        .with_context(|| format!("model in {} is invalid", dir.display()))?;
    Ok(model)
}
