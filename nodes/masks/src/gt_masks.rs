//! Ground-truth object masks: the annotated mesh rasterized into every frame.
//!
//! The nearest surface owns each pixel (z-buffer), so occlusion is resolved by depth
//! and the masks are mutually exclusive by construction. A face belongs to the object
//! of its first vertex (the ScanNet++ toolkit rule, [`Mesh::face_object`]). Pixel
//! values follow the Masks encoding: the object id; `0` for a surface that is no kept
//! object (unannotated, a background label such as wall/floor, a label outside
//! `keep_labels`, or an object too small in that frame); [`UNOWNED`] where no surface
//! is hit at all.

use crate::raster::{NO_FACE, RasterOptions, rasterize};
use anyhow::{Result, bail};
use objectsplat_core::masks::{NO_OBJECT, UNOWNED};
use objectsplat_core::{Camera, IdMap, Mesh, ObjectLabels};
use std::collections::BTreeSet;

#[derive(Debug, Clone, PartialEq)]
pub struct GtMaskParams {
    /// Labels of the objects to keep (e.g. chair, table, sofa); empty keeps every object.
    pub keep_labels: Vec<String>,
    /// Labels whose surfaces belong to the background (id 0), e.g. wall, floor, ceiling.
    pub background_labels: Vec<String>,
    /// Per-frame pixel count below which an object is dropped from that frame (to 0).
    /// `None` uses `min_fraction` of the frame area.
    pub min_pixels: Option<u64>,
    /// Fraction of the frame area used when `min_pixels` is not given.
    pub min_fraction: f64,
    pub raster: RasterOptions,
}

impl Default for GtMaskParams {
    fn default() -> Self {
        GtMaskParams {
            keep_labels: Vec::new(),
            background_labels: vec!["wall".into(), "floor".into(), "ceiling".into()],
            min_pixels: None,
            min_fraction: 0.0005,
            raster: RasterOptions::default(),
        }
    }
}

impl GtMaskParams {
    /// Per-frame minimum pixel count for a frame of `area` pixels.
    pub fn threshold(&self, area: u64) -> u64 {
        self.min_pixels
            .unwrap_or_else(|| (self.min_fraction * area as f64).ceil() as u64)
    }
}

/// Masks for a list of cameras, in the same order, and the labels of the objects that
/// appear in at least one of them.
#[derive(Debug, Clone, PartialEq)]
pub struct GtMasks {
    pub masks: Vec<IdMap>,
    pub labels: ObjectLabels,
}

/// Maps each face to the mask value it paints (object id, or 0 for background),
/// after checking the annotation and the label lists.
pub fn face_mask_values(
    mesh: &Mesh,
    labels: &ObjectLabels,
    params: &GtMaskParams,
) -> Result<Vec<u16>> {
    if let Err(e) = mesh.validate() {
        bail!("mesh: {e}");
    }
    if !(params.min_fraction.is_finite() && (0.0..=1.0).contains(&params.min_fraction)) {
        bail!(
            "min_fraction = {} must be a number in [0, 1]",
            params.min_fraction
        );
    }
    let known: BTreeSet<&str> = labels.values().map(String::as_str).collect();
    for wanted in &params.keep_labels {
        if !known.contains(wanted.as_str()) {
            bail!(
                "keep_labels names {wanted:?}, but no object has that label (labels present: {})",
                known
                    .iter()
                    .map(|l| format!("{l:?}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    let keep = |label: &str| {
        !params.background_labels.iter().any(|b| b == label)
            && (params.keep_labels.is_empty() || params.keep_labels.iter().any(|k| k == label))
    };
    let Some(ids) = &mesh.object_ids else {
        bail!("mesh has no per-vertex object_id annotation, so it cannot give object masks");
    };
    // Resolve each distinct object id once.
    let mut value_of_id = std::collections::BTreeMap::<i32, u16>::new();
    for &id in ids {
        if value_of_id.contains_key(&id) {
            continue;
        }
        // Ids ≤ 0 are "no object" (−1 in our encoding, ≤ 0 in the ScanNet++ toolkit).
        let value = if id <= 0 {
            NO_OBJECT
        } else if id >= UNOWNED as i32 {
            bail!("mesh object_id {id} does not fit a mask (ids must be in 1..=65534)");
        } else {
            let Some(label) = labels.get(&(id as u16)) else {
                bail!("mesh object_id {id} has no label in the objects list");
            };
            if keep(label) { id as u16 } else { NO_OBJECT }
        };
        value_of_id.insert(id, value);
    }
    Ok((0..mesh.faces.len())
        .map(|f| value_of_id[&mesh.face_object(f)])
        .collect())
}

/// Rasterizes the annotated mesh into every camera.
pub fn gt_masks(
    mesh: &Mesh,
    labels: &ObjectLabels,
    cameras: &[Camera],
    params: &GtMaskParams,
) -> Result<GtMasks> {
    let face_values = face_mask_values(mesh, labels, params)?;
    let mut masks = Vec::with_capacity(cameras.len());
    let mut present = BTreeSet::new();
    for (i, camera) in cameras.iter().enumerate() {
        let mask = frame_mask(mesh, &face_values, camera, params)
            .map_err(|e| anyhow::anyhow!("camera {i}: {e}"))?;
        present.extend(
            mask.data
                .iter()
                .copied()
                .filter(|&v| v != NO_OBJECT && v != UNOWNED),
        );
        masks.push(mask);
    }
    let labels = present
        .into_iter()
        .map(|id| (id, labels[&id].clone()))
        .collect();
    Ok(GtMasks { masks, labels })
}

/// One frame's id map, with objects below the per-frame pixel threshold set to 0.
pub fn frame_mask(
    mesh: &Mesh,
    face_values: &[u16],
    camera: &Camera,
    params: &GtMaskParams,
) -> Result<IdMap, String> {
    let raster = rasterize(&mesh.positions, &mesh.faces, camera, &params.raster)?;
    let data: Vec<u16> = raster
        .face
        .iter()
        .map(|&f| {
            if f == NO_FACE {
                UNOWNED
            } else {
                face_values[f as usize]
            }
        })
        .collect();
    Ok(drop_small_objects(
        raster.width,
        raster.height,
        data,
        params,
    ))
}

/// The id map of a frame from the value of the nearest surface at each pixel
/// ([`UNOWNED`] where none), with objects below the per-frame pixel threshold set to 0.
/// Shared by the CPU and wgpu backends, which differ only in how `data` is rasterized.
pub fn drop_small_objects(
    width: u32,
    height: u32,
    mut data: Vec<u16>,
    params: &GtMaskParams,
) -> IdMap {
    let mut counts = vec![0u64; UNOWNED as usize + 1];
    for &v in &data {
        counts[v as usize] += 1;
    }
    let threshold = params.threshold(data.len() as u64);
    let too_small = |v: u16| v != NO_OBJECT && v != UNOWNED && counts[v as usize] < threshold;
    if counts
        .iter()
        .enumerate()
        .any(|(v, &c)| c > 0 && too_small(v as u16))
    {
        for v in &mut data {
            if too_small(*v) {
                *v = NO_OBJECT;
            }
        }
    }
    IdMap {
        width,
        height,
        data,
    }
}
