//! Topology edits between optimizer steps: densification by midpoint
//! subdivision and pruning by a face keep mask.
//!
//! Both keep vertex indices stable where they can (densification appends
//! vertices; pruning compacts them) and report what the optimizer state must do.

use anyhow::{Result, bail};
use objectsplat_core::geometry::triangle_area;
use objectsplat_raster::Model;
use objectsplat_raster::model::inverse_sigmoid;
use rand::Rng;
use std::collections::HashMap;

/// Samples up to `count` distinct indices with probability ∝ `weights`, without
/// replacement (Efraimidis–Spirakis keys `ln(u)/w`). Zero-weight entries are
/// never drawn, so fewer than `count` come back when fewer candidates exist.
pub fn sample_without_replacement(
    weights: &[f32],
    count: usize,
    rng: &mut impl Rng,
) -> Result<Vec<usize>> {
    if let Some(i) = weights.iter().position(|w| !w.is_finite() || *w < 0.0) {
        bail!(
            "sampling weight {i} is {} (must be finite and ≥ 0)",
            weights[i]
        );
    }
    let mut keys: Vec<(f64, usize)> = weights
        .iter()
        .enumerate()
        .filter(|(_, w)| **w > 0.0)
        .map(|(i, &w)| {
            // u in (0, 1]: ln(u) is finite and ≤ 0; larger key = drawn earlier.
            let u: f64 = 1.0 - rng.random::<f64>();
            (u.ln() / w as f64, i)
        })
        .collect();
    let take = count.min(keys.len());
    keys.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut picked: Vec<usize> = keys[..take].iter().map(|k| k.1).collect();
    picked.sort_unstable();
    Ok(picked)
}

fn face_area(model: &Model<f32>, f: usize) -> f64 {
    triangle_area(&model.faces[f].map(|i| model.vertices[i as usize].map(|x| x as f64)))
}

/// How densification chooses faces (see `Schedule` for the reference values).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DensifyPolicy {
    /// Faces to split, before the candidate guard.
    pub count: usize,
    /// Faces with a smaller 3D area get zero probability.
    pub min_area: f64,
    /// This many largest-area faces are always split (within `count`).
    pub always_largest: usize,
}

/// Per-face limits on splitting: faces with `splittable[f] == false` are never
/// chosen (too small on screen to split).
pub type Splittable<'a> = Option<&'a [bool]>;

/// Chooses the faces to split: the `always_largest` largest faces, then the
/// rest sampled without replacement ∝ `face_max_weight` among faces at least
/// `min_area` large. Never returns more faces than have non-zero probability.
pub fn select_faces_to_split(
    model: &Model<f32>,
    face_max_weight: &[f32],
    splittable: Splittable<'_>,
    policy: DensifyPolicy,
    rng: &mut impl Rng,
) -> Result<Vec<usize>> {
    let t = model.faces.len();
    if face_max_weight.len() != t || splittable.is_some_and(|s| s.len() != t) {
        bail!(
            "densification got {} face weights and {:?} split flags for {t} faces",
            face_max_weight.len(),
            splittable.map(|s| s.len())
        );
    }
    let can_split = |f: usize| splittable.is_none_or(|s| s[f]);
    let areas: Vec<f64> = (0..t).map(|f| face_area(model, f)).collect();
    let mut forced: Vec<usize> = (0..t).filter(|&f| can_split(f)).collect();
    forced.sort_by(|&a, &b| areas[b].total_cmp(&areas[a]).then(a.cmp(&b)));
    forced.truncate(policy.always_largest.min(policy.count));
    let mut weights: Vec<f32> = face_max_weight
        .iter()
        .zip(&areas)
        .enumerate()
        .map(|(f, (&w, &a))| {
            if a < policy.min_area || !can_split(f) {
                0.0
            } else {
                w
            }
        })
        .collect();
    for &f in &forced {
        weights[f] = 0.0;
    }
    let mut chosen = sample_without_replacement(&weights, policy.count - forced.len(), rng)?;
    chosen.extend(forced);
    chosen.sort_unstable();
    Ok(chosen)
}

/// What a topology edit did to the vertex table.
#[derive(Debug, Clone, PartialEq)]
pub struct VertexEdit {
    /// Per old vertex: kept or removed (all true for densification).
    pub keep: Vec<bool>,
    /// Vertices appended after the kept ones.
    pub appended: usize,
    /// Per face after the edit: the face before the edit it is (kept) or comes from (split).
    pub face_origin: Vec<u32>,
}

/// Splits each selected face into 4 at its edge midpoints. A midpoint is one
/// new vertex shared by every selected face on that edge (unselected
/// neighbours keep their edge, leaving T-junctions as in the reference). A
/// midpoint's SH is the mean of its endpoints'; its opacity is the mean of
/// their activated opacities, written as a logit under the current floor.
/// Parents are removed; children are appended after the unselected faces.
pub fn subdivide_faces(model: &mut Model<f32>, selected: &[usize]) -> Result<VertexEdit> {
    let t = model.faces.len();
    let old_vertices = model.vertices.len();
    let mut is_selected = vec![false; t];
    for &f in selected {
        if f >= t {
            bail!("face {f} selected for splitting, but the model has {t} faces");
        }
        is_selected[f] = true;
    }
    let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
    let mut children = Vec::with_capacity(4 * selected.len());
    for f in (0..t).filter(|&f| is_selected[f]) {
        let [a, b, c] = model.faces[f];
        let mut mid = |p: u32, q: u32| -> Result<u32> {
            let key = (p.min(q), p.max(q));
            if let Some(&m) = midpoint.get(&key) {
                return Ok(m);
            }
            let index = u32::try_from(model.vertices.len())
                .map_err(|_| anyhow::anyhow!("densification exceeds u32 vertex indices"))?;
            let (p, q) = (p as usize, q as usize);
            let pos = std::array::from_fn(|k| 0.5 * (model.vertices[p][k] + model.vertices[q][k]));
            let sh = std::array::from_fn(|k| {
                std::array::from_fn(|c| 0.5 * (model.sh[p][k][c] + model.sh[q][k][c]))
            });
            let opacity = 0.5 * (model.vertex_opacity(p) as f64 + model.vertex_opacity(q) as f64);
            let m = model.opacity_floor;
            let logit = inverse_sigmoid((opacity - m) / (1.0 - m)) as f32;
            if !model.flat_dc.is_empty() {
                let (fp, fq) = (model.flat_dc(p), model.flat_dc(q));
                model
                    .flat_dc
                    .push(std::array::from_fn(|ch| 0.5 * (fp[ch] + fq[ch])));
            }
            model.vertices.push(pos);
            model.sh.push(sh);
            model.opacity_logits.push(logit);
            midpoint.insert(key, index);
            Ok(index)
        };
        let ab = mid(a, b)?;
        let bc = mid(b, c)?;
        let ca = mid(c, a)?;
        children.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    let kept = (0..t).filter(|&f| !is_selected[f]);
    let mut faces: Vec<[u32; 3]> = kept.clone().map(|f| model.faces[f]).collect();
    faces.extend(children);
    model.faces = faces;
    let mut face_origin: Vec<u32> = kept.map(|f| f as u32).collect();
    for f in (0..t).filter(|&f| is_selected[f]) {
        face_origin.extend([f as u32; 4]);
    }
    if !model.face_sigma.is_empty() {
        model.face_sigma = face_origin
            .iter()
            .map(|&f| model.face_sigma[f as usize])
            .collect();
    }
    Ok(VertexEdit {
        keep: vec![true; old_vertices],
        appended: model.vertices.len() - old_vertices,
        face_origin,
    })
}

/// Removes the faces whose `keep_face` entry is false, then every vertex no
/// face references, and renumbers the faces.
pub fn prune_faces(model: &mut Model<f32>, keep_face: &[bool]) -> Result<VertexEdit> {
    if keep_face.len() != model.faces.len() {
        bail!(
            "pruning got a keep mask of {} for {} faces",
            keep_face.len(),
            model.faces.len()
        );
    }
    let face_origin: Vec<u32> = (0..keep_face.len() as u32)
        .filter(|&f| keep_face[f as usize])
        .collect();
    let faces: Vec<[u32; 3]> = face_origin
        .iter()
        .map(|&f| model.faces[f as usize])
        .collect();
    model.faces = faces;
    if !model.face_sigma.is_empty() {
        model.face_sigma = face_origin
            .iter()
            .map(|&f| model.face_sigma[f as usize])
            .collect();
    }
    let mut edit = remove_unreferenced_vertices(model)?;
    edit.face_origin = face_origin;
    Ok(edit)
}

/// Drops vertices no face references and renumbers the faces.
pub fn remove_unreferenced_vertices(model: &mut Model<f32>) -> Result<VertexEdit> {
    let n = model.vertices.len();
    let mut keep = vec![false; n];
    for f in &model.faces {
        for &v in f {
            let v = v as usize;
            if v >= n {
                bail!("a face references vertex {v}, but the model has {n} vertices");
            }
            keep[v] = true;
        }
    }
    let mut new_index = vec![u32::MAX; n];
    let mut next = 0u32;
    for v in 0..n {
        if keep[v] {
            new_index[v] = next;
            next += 1;
        }
    }
    for f in &mut model.faces {
        // Every face corner was marked kept above, so its new index is assigned.
        *f = f.map(|v| new_index[v as usize]);
    }
    retain_by_mask(&mut model.vertices, &keep);
    retain_by_mask(&mut model.sh, &keep);
    retain_by_mask(&mut model.opacity_logits, &keep);
    if !model.flat_dc.is_empty() {
        retain_by_mask(&mut model.flat_dc, &keep);
    }
    Ok(VertexEdit {
        keep,
        appended: 0,
        face_origin: (0..model.faces.len() as u32).collect(),
    })
}

fn retain_by_mask<T>(rows: &mut Vec<T>, keep: &[bool]) {
    let mut flags = keep.iter();
    // `keep` has one entry per row (checked by the callers), so `next` never runs out.
    rows.retain(|_| *flags.next().unwrap_or(&false));
}
