//! Importing SAM-family object masks as a Masks artifact.
//!
//! Formats (files are matched to frames by the frame's file stem):
//! - `davis`: `<path>/<stem>.png`, indexed PNG (SAM2 video output); pixel = palette
//!   *index* = object id, 0 = background, index 255 = void (treated as no object). Grey
//!   8/16-bit PNGs are read the same way.
//! - `per_object_png`: either the SA-V layout `<path>/<object id>/<stem>.png` (one folder
//!   per tracked object) or the SAM automatic-mask-generator layout `<path>/<stem>/<i>.png`
//!   (+ optional `metadata.csv` for `predicted_iou`); non-zero = in the mask.
//! - `coco_rle`: `<path>/<stem>.json`, a SAM AMG list of `{segmentation: RLE, predicted_iou, …}`
//!   or a Grounded-SAM-2 image result `{annotations: [{class_name, segmentation, score}]}`.
//! - `grounded_sam2`: the tracking demo's `mask_data/mask_<stem>.npy` (instance id map) with
//!   `json_data/mask_<stem>.json` (labels); without `mask_data/`, per-frame image results as
//!   in `coco_rle`.
//!
//! Ids: tracked sources (davis, SA-V folders, Grounded-SAM-2 tracking) keep one object per
//! source id across frames; untracked ones (SAM AMG masks, per-image detections) make every
//! mask its own object. Objects are numbered 1..N in source order (tracked: by source id;
//! untracked: by frame, then position in the file). Labels come from the source
//! (`class_name`) when it has them, else "object".
//!
//! Overlaps (only sources that can overlap) are resolved per pixel by an explicit policy:
//! `lower_id` (the mask first in source order wins), `smaller_area` (the smaller mask in
//! that frame wins; ties by source order), `higher_score` (higher `predicted_iou`/`score`
//! wins; ties by source order). A mask that loses every pixel is no object (counted as
//! hidden in the summary), so every id in `objects.json` owns pixels somewhere.
//!
//! Masks may be at the frame's size or an exact integer multiple of it (the frames were
//! downscaled by the scene source); they are then sampled at pixel centres. Any other
//! size is an error naming the file.

use crate::rle::{self, BinaryMask};
use crate::{label_png, npy};
use anyhow::{Context, Result, bail};
use objectsplat_core::frames::frame_stem;
use objectsplat_core::masks::{self, IdMap, ObjectLabels};
use objectsplat_core::{Frame, Frames};
use serde_json::Value;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MaskFormat {
    Davis,
    PerObjectPng,
    CocoRle,
    GroundedSam2,
}

impl MaskFormat {
    pub const NAMES: [&'static str; 4] = ["davis", "per_object_png", "coco_rle", "grounded_sam2"];

    pub fn parse(name: &str) -> Result<MaskFormat> {
        Ok(match name {
            "davis" => MaskFormat::Davis,
            "per_object_png" => MaskFormat::PerObjectPng,
            "coco_rle" => MaskFormat::CocoRle,
            "grounded_sam2" => MaskFormat::GroundedSam2,
            other => bail!(
                "unknown mask format {other:?}; expected one of {:?}",
                MaskFormat::NAMES
            ),
        })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OverlapPolicy {
    LowerId,
    SmallerArea,
    HigherScore,
}

impl OverlapPolicy {
    pub const NAMES: [&'static str; 3] = ["lower_id", "smaller_area", "higher_score"];

    pub fn parse(name: &str) -> Result<OverlapPolicy> {
        Ok(match name {
            "lower_id" => OverlapPolicy::LowerId,
            "smaller_area" => OverlapPolicy::SmallerArea,
            "higher_score" => OverlapPolicy::HigherScore,
            other => bail!(
                "unknown overlap policy {other:?}; expected one of {:?}",
                OverlapPolicy::NAMES
            ),
        })
    }
}

/// Per-object cross-frame consistency.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectSummary {
    pub id: u16,
    pub label: String,
    /// Frames in which the object owns at least one pixel.
    pub frames_present: usize,
    pub area_min: u64,
    pub area_max: u64,
    pub area_mean: f64,
    /// Standard deviation / mean of the area over the frames it is present in.
    pub area_cv: f64,
}

#[derive(Debug, Clone, PartialEq, Default)]
pub struct ImportSummary {
    pub frames: usize,
    /// Frames for which the source had no mask file (written as all background).
    pub frames_without_masks: Vec<String>,
    pub objects: Vec<ObjectSummary>,
    /// Pixels claimed by more than one mask (resolved by the policy).
    pub overlapping_pixels: u64,
    /// DAVIS void (255) pixels, written as background.
    pub void_pixels: u64,
    /// Source masks that lost every pixel to overlap resolution: they become no object.
    pub hidden_masks: usize,
}

impl ObjectSummary {
    /// One line for the run report.
    pub fn describe(&self, frames: usize) -> String {
        format!(
            "{}: in {}/{} frames, area mean {:.0} px (min {}, max {}, cv {:.2})",
            self.label,
            self.frames_present,
            frames,
            self.area_mean,
            self.area_min,
            self.area_max,
            self.area_cv
        )
    }
}

/// An object's identity in the source: tracked objects use `(0, source id)`, untracked
/// masks `(frame index + 1, position in the frame's file)`. Sorting keys gives the id order.
type SourceKey = (u64, u64);

struct Candidate {
    key: SourceKey,
    label: Option<String>,
    score: Option<f64>,
    /// Where the mask came from, for error messages.
    origin: String,
    mask: BinaryMask,
}

/// What a source yields for one frame.
enum FrameMasks {
    Missing,
    /// Already exclusive: per-pixel source ids (0 = none), with labels by id when known.
    Exclusive {
        ids: Vec<u64>,
        labels: HashMap<u64, String>,
    },
    Overlapping(Vec<Candidate>),
}

/// Imports masks from `source` for the frames in `frames_dir`, writing a Masks artifact into `out`.
pub fn import(
    source: &Path,
    format: MaskFormat,
    policy: OverlapPolicy,
    frames_dir: &Path,
    out: &Path,
    progress: impl FnMut(usize, usize),
) -> Result<ImportSummary> {
    import_with_budget(
        source,
        format,
        policy,
        frames_dir,
        out,
        progress,
        DEFAULT_MEMORY_BUDGET_PIXELS,
    )
}

/// Id maps are held in memory (and written once, with final ids) up to this many pixels;
/// beyond it they are written as they come and renumbered on disk at the end.
pub const DEFAULT_MEMORY_BUDGET_PIXELS: usize = 1 << 26;

/// [`import`] with an explicit in-memory budget (in pixels) for the id maps.
pub fn import_with_budget(
    source: &Path,
    format: MaskFormat,
    policy: OverlapPolicy,
    frames_dir: &Path,
    out: &Path,
    mut progress: impl FnMut(usize, usize),
    memory_budget_pixels: usize,
) -> Result<ImportSummary> {
    let frames = Frames::read(frames_dir)?;
    let mut stems = std::collections::HashSet::new();
    if let Some(f) = frames
        .frames
        .iter()
        .find(|f| !stems.insert(frame_stem(&f.name)))
    {
        bail!(
            "{}: frame {:?} shares its file stem with another frame; their masks would collide",
            frames_dir.display(),
            f.name
        );
    }
    if !source.is_dir() {
        bail!("{}: mask source is not a folder", source.display());
    }
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    let amg_layout = format == MaskFormat::PerObjectPng
        && frames
            .frames
            .iter()
            .any(|f| source.join(frame_stem(&f.name)).is_dir());
    let tracked_folders = if format == MaskFormat::PerObjectPng && !amg_layout {
        object_folders(source)?
    } else {
        vec![]
    };
    let gsam_tracking = format == MaskFormat::GroundedSam2 && source.join("mask_data").is_dir();

    let mut summary = ImportSummary {
        frames: frames.frames.len(),
        ..ImportSummary::default()
    };
    let mut provisional: HashMap<SourceKey, u16> = HashMap::new();
    let mut keys_in_order: Vec<SourceKey> = Vec::new();
    let mut labels: HashMap<SourceKey, String> = HashMap::new();
    let mut areas: HashMap<SourceKey, Vec<u64>> = HashMap::new();
    let mut candidate_keys: std::collections::HashSet<SourceKey> = std::collections::HashSet::new();
    let mut held: Vec<(PathBuf, IdMap)> = Vec::new();
    let mut held_pixels = 0usize;
    let mut spilled = false;
    for (index, frame) in frames.frames.iter().enumerate() {
        progress(index, frames.frames.len());
        let stem = frame_stem(&frame.name);
        let masks = match format {
            MaskFormat::Davis => davis_frame(source, stem, frame, &mut summary.void_pixels)?,
            MaskFormat::PerObjectPng if amg_layout => amg_png_frame(source, stem, frame, index)?,
            MaskFormat::PerObjectPng => sav_frame(&tracked_folders, stem, frame)?,
            MaskFormat::CocoRle => {
                rle_json_frame(&source.join(format!("{stem}.json")), frame, index)?
            }
            MaskFormat::GroundedSam2 if gsam_tracking => gsam_tracking_frame(source, stem, frame)?,
            MaskFormat::GroundedSam2 => {
                rle_json_frame(&source.join(format!("{stem}.json")), frame, index)?
            }
        };
        let (keys_map, frame_labels): (Vec<Option<SourceKey>>, Vec<(SourceKey, String)>) =
            match masks {
                FrameMasks::Missing => {
                    summary.frames_without_masks.push(frame.name.clone());
                    (
                        vec![None; (frame.camera.width * frame.camera.height) as usize],
                        vec![],
                    )
                }
                FrameMasks::Exclusive { ids, labels } => {
                    let found: Vec<(SourceKey, String)> =
                        labels.into_iter().map(|(id, l)| ((0, id), l)).collect();
                    (
                        ids.into_iter()
                            .map(|id| (id != 0).then_some((0, id)))
                            .collect(),
                        found,
                    )
                }
                FrameMasks::Overlapping(cands) => {
                    candidate_keys.extend(cands.iter().map(|c| c.key));
                    let found = cands
                        .iter()
                        .filter_map(|c| c.label.clone().map(|l| (c.key, l)))
                        .collect();
                    let (map, overlaps) = resolve(cands, policy, frame)?;
                    summary.overlapping_pixels += overlaps;
                    (map, found)
                }
            };
        for (key, label) in frame_labels {
            labels.entry(key).or_insert(label);
        }
        let mut map = IdMap::new(frame.camera.width, frame.camera.height);
        let mut area_by_id = vec![0u64; keys_in_order.len() + 1];
        // Runs of one key are long; remember the last lookup instead of hashing every pixel.
        let mut last: Option<(SourceKey, u16)> = None;
        for (px, key) in keys_map.iter().enumerate() {
            let Some(key) = key else { continue };
            let id = match last {
                Some((k, id)) if k == *key => id,
                _ => {
                    let id = match provisional.get(key) {
                        Some(&id) => id,
                        None => {
                            let id = u16::try_from(keys_in_order.len() + 1)
                                .ok()
                                .filter(|&id| id < masks::UNOWNED)
                                .with_context(|| {
                                    format!(
                                        "{}: more than 65534 objects; masks cannot number them",
                                        source.display()
                                    )
                                })?;
                            provisional.insert(*key, id);
                            keys_in_order.push(*key);
                            area_by_id.push(0);
                            id
                        }
                    };
                    last = Some((*key, id));
                    id
                }
            };
            map.data[px] = id;
            area_by_id[id as usize] += 1;
        }
        for (id, &area) in area_by_id.iter().enumerate().skip(1) {
            if area > 0 {
                areas.entry(keys_in_order[id - 1]).or_default().push(area);
            }
        }
        let path = out.join(format!("{stem}.png"));
        if !spilled && held_pixels + map.data.len() <= memory_budget_pixels {
            held_pixels += map.data.len();
            held.push((path, map));
        } else {
            // Over budget: write what is held with provisional ids; renumbered from disk below.
            for (p, m) in held.drain(..) {
                m.save(&p)?;
            }
            spilled = true;
            map.save(&path)?;
        }
    }
    progress(frames.frames.len(), frames.frames.len());

    // Final ids follow source order; renumber the written maps when first appearance differed.
    let mut sorted = keys_in_order.clone();
    sorted.sort();
    let final_id: HashMap<SourceKey, u16> = sorted
        .iter()
        .enumerate()
        .map(|(i, k)| (*k, i as u16 + 1))
        .collect();
    let mut remap = vec![0u16; keys_in_order.len() + 1];
    for (k, &p) in &provisional {
        remap[p as usize] = final_id[k];
    }
    let renumber = sorted != keys_in_order;
    for (path, mut map) in held {
        if renumber {
            for v in &mut map.data {
                *v = remap[*v as usize];
            }
        }
        map.save(&path)?;
    }
    if spilled && renumber {
        for frame in &frames.frames {
            let path = out.join(format!("{}.png", frame_stem(&frame.name)));
            let mut map = IdMap::load(&path)?;
            for v in &mut map.data {
                *v = remap[*v as usize];
            }
            map.save(&path)?;
        }
    }
    summary.hidden_masks = candidate_keys
        .iter()
        .filter(|k| !final_id.contains_key(k))
        .count();
    let mut object_labels = ObjectLabels::new();
    for key in &sorted {
        let id = final_id[key];
        let label = labels
            .get(key)
            .cloned()
            .unwrap_or_else(|| "object".to_string());
        object_labels.insert(id, label.clone());
        let a = &areas[key];
        let mean = a.iter().sum::<u64>() as f64 / a.len() as f64;
        let var = a.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / a.len() as f64;
        summary.objects.push(ObjectSummary {
            id,
            label,
            frames_present: a.len(),
            area_min: *a.iter().min().unwrap_or(&0),
            area_max: *a.iter().max().unwrap_or(&0),
            area_mean: mean,
            area_cv: if mean > 0.0 { var.sqrt() / mean } else { 0.0 },
        });
    }
    masks::write_objects(out, &object_labels)?;
    Ok(summary)
}

/// Resolves overlapping candidates into one key per pixel; returns the map and the overlap count.
fn resolve(
    mut cands: Vec<Candidate>,
    policy: OverlapPolicy,
    frame: &Frame,
) -> Result<(Vec<Option<SourceKey>>, u64)> {
    let areas: HashMap<SourceKey, usize> = cands.iter().map(|c| (c.key, c.mask.area())).collect();
    match policy {
        OverlapPolicy::LowerId => cands.sort_by_key(|c| c.key),
        OverlapPolicy::SmallerArea => cands.sort_by_key(|c| (areas[&c.key], c.key)),
        OverlapPolicy::HigherScore => {
            if let Some(c) = cands.iter().find(|c| c.score.is_none()) {
                bail!(
                    "{}: has no score (predicted_iou or score); the higher_score policy needs one — use lower_id or smaller_area",
                    c.origin
                );
            }
            // Scores were checked finite when read, so the comparison is total.
            cands.sort_by(|a, b| {
                b.score
                    .partial_cmp(&a.score)
                    .unwrap_or(std::cmp::Ordering::Equal)
                    .then(a.key.cmp(&b.key))
            });
        }
    }
    let mut map: Vec<Option<SourceKey>> =
        vec![None; (frame.camera.width * frame.camera.height) as usize];
    let mut overlaps = 0u64;
    for c in &cands {
        for (px, &set) in c.mask.data.iter().enumerate() {
            if set {
                match map[px] {
                    None => map[px] = Some(c.key),
                    Some(_) => overlaps += 1,
                }
            }
        }
    }
    Ok((map, overlaps))
}

/// Brings a `w`×`h` grid of values to the frame's size: equal, or an exact integer multiple
/// sampled at pixel centres. Anything else is an error naming `origin`.
fn fit_to_frame<T: Copy>(
    data: Vec<T>,
    w: u32,
    h: u32,
    frame: &Frame,
    origin: &Path,
) -> Result<Vec<T>> {
    let (fw, fh) = (frame.camera.width, frame.camera.height);
    if (w, h) == (fw, fh) {
        return Ok(data);
    }
    let k = w / fw;
    if k < 2 || w != k * fw || h != k * fh {
        bail!(
            "{}: mask is {w}×{h} but frame {:?} is {fw}×{fh} (masks must match the frame or be an exact integer multiple of it)",
            origin.display(),
            frame.name
        );
    }
    let mut out = Vec::with_capacity((fw * fh) as usize);
    for y in 0..fh {
        for x in 0..fw {
            let (sx, sy) = (x * k + k / 2, y * k + k / 2);
            out.push(data[(sy * w + sx) as usize]);
        }
    }
    Ok(out)
}

fn binary(data: Vec<bool>, w: u32, h: u32, frame: &Frame, origin: &Path) -> Result<BinaryMask> {
    let data = fit_to_frame(data, w, h, frame, origin)?;
    Ok(BinaryMask {
        width: frame.camera.width,
        height: frame.camera.height,
        data,
    })
}

fn davis_frame(source: &Path, stem: &str, frame: &Frame, void: &mut u64) -> Result<FrameMasks> {
    let path = source.join(format!("{stem}.png"));
    if !path.is_file() {
        return Ok(FrameMasks::Missing);
    }
    let l = label_png::read(&path)?;
    let ids = fit_to_frame(l.data, l.width, l.height, frame, &path)?;
    let ids = ids
        .into_iter()
        .map(|v| {
            if v == 255 && l.indexed {
                *void += 1;
                0
            } else {
                v as u64
            }
        })
        .collect();
    Ok(FrameMasks::Exclusive {
        ids,
        labels: HashMap::new(),
    })
}

/// SA-V layout: `(object id, folder)` for every integer-named sub-folder.
fn object_folders(source: &Path) -> Result<Vec<(u64, PathBuf)>> {
    let mut out = Vec::new();
    for e in
        std::fs::read_dir(source).with_context(|| format!("{}: cannot list", source.display()))?
    {
        let e = e.with_context(|| format!("{}: cannot list", source.display()))?;
        if !e.path().is_dir() {
            continue;
        }
        let name = e.file_name().to_string_lossy().into_owned();
        let id: u64 = name.parse().with_context(|| {
            format!(
                "{}: folder {name:?} is neither a frame stem (SAM layout) nor an object id (SA-V layout)",
                source.display()
            )
        })?;
        out.push((id, e.path()));
    }
    out.sort();
    if out.is_empty() {
        bail!(
            "{}: no per-object folders (<id>/<frame>.png) and no per-frame folders (<frame>/<i>.png)",
            source.display()
        );
    }
    Ok(out)
}

fn read_binary_png(path: &Path, frame: &Frame) -> Result<BinaryMask> {
    let l = label_png::read(path)?;
    binary(
        l.data.iter().map(|&v| v != 0).collect(),
        l.width,
        l.height,
        frame,
        path,
    )
}

fn sav_frame(folders: &[(u64, PathBuf)], stem: &str, frame: &Frame) -> Result<FrameMasks> {
    let mut cands = Vec::new();
    for (id, dir) in folders {
        let path = dir.join(format!("{stem}.png"));
        if path.is_file() {
            let mask = read_binary_png(&path, frame)?;
            cands.push(Candidate {
                key: (0, *id),
                label: None,
                score: None,
                origin: path.display().to_string(),
                mask,
            });
        }
    }
    Ok(if cands.is_empty() {
        FrameMasks::Missing
    } else {
        FrameMasks::Overlapping(cands)
    })
}

/// SAM AMG folder: `<stem>/<i>.png` plus optional `metadata.csv` (`id,…,predicted_iou,…`).
fn amg_png_frame(source: &Path, stem: &str, frame: &Frame, index: usize) -> Result<FrameMasks> {
    let dir = source.join(stem);
    if !dir.is_dir() {
        return Ok(FrameMasks::Missing);
    }
    let scores = amg_scores(&dir.join("metadata.csv"))?;
    let mut files: Vec<(u64, PathBuf)> = Vec::new();
    for e in std::fs::read_dir(&dir).with_context(|| format!("{}: cannot list", dir.display()))? {
        let p = e
            .with_context(|| format!("{}: cannot list", dir.display()))?
            .path();
        if p.extension().is_some_and(|x| x == "png") {
            let i: u64 = p
                .file_stem()
                .and_then(|s| s.to_str())
                .and_then(|s| s.parse().ok())
                .with_context(|| {
                    format!("{}: SAM mask files are named <index>.png", p.display())
                })?;
            files.push((i, p));
        }
    }
    files.sort();
    let mut cands = Vec::new();
    for (i, path) in files {
        let mask = read_binary_png(&path, frame)?;
        let score = scores.get(&i).copied();
        cands.push(Candidate {
            key: (index as u64 + 1, i),
            label: None,
            score,
            origin: path.display().to_string(),
            mask,
        });
    }
    Ok(FrameMasks::Overlapping(cands))
}

fn amg_scores(path: &Path) -> Result<HashMap<u64, f64>> {
    let mut out = HashMap::new();
    if !path.is_file() {
        return Ok(out);
    }
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let mut lines = text.lines().enumerate();
    let Some((_, header)) = lines.next() else {
        return Ok(out);
    };
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let col = |name: &str| cols.iter().position(|c| *c == name);
    let (Some(id_col), Some(iou_col)) = (col("id"), col("predicted_iou")) else {
        bail!(
            "{}: header lacks the id and predicted_iou columns",
            path.display()
        );
    };
    for (n, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let parsed = f
            .get(id_col)
            .and_then(|s| s.parse::<u64>().ok())
            .zip(f.get(iou_col).and_then(|s| s.parse::<f64>().ok()));
        match parsed {
            Some((id, iou)) if iou.is_finite() => {
                out.insert(id, iou);
            }
            _ => bail!(
                "{}:{}: expected an integer id and a finite predicted_iou",
                path.display(),
                n + 1
            ),
        }
    }
    Ok(out)
}

fn score_of(ann: &Value) -> Result<Option<f64>, String> {
    let v = ann.get("predicted_iou").or_else(|| ann.get("score"));
    let v = match v {
        None | Some(Value::Null) => return Ok(None),
        // Grounded-SAM-2 sometimes stores the score as a one-element list.
        Some(Value::Array(a)) if a.len() == 1 => &a[0],
        Some(v) => v,
    };
    match v.as_f64() {
        Some(s) if s.is_finite() => Ok(Some(s)),
        _ => Err(format!("score {v} is not a finite number")),
    }
}

/// SAM AMG list or Grounded-SAM-2 image result (`annotations`) with COCO-RLE segmentations.
fn rle_json_frame(path: &Path, frame: &Frame, index: usize) -> Result<FrameMasks> {
    if !path.is_file() {
        return Ok(FrameMasks::Missing);
    }
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let doc: Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    let anns = match &doc {
        Value::Array(a) => a,
        Value::Object(o) => match o.get("annotations") {
            Some(Value::Array(a)) => a,
            _ => bail!(
                "{}: expected a list of masks or an object with \"annotations\"",
                path.display()
            ),
        },
        _ => bail!(
            "{}: expected a list of masks or an object with \"annotations\"",
            path.display()
        ),
    };
    let mut cands = Vec::with_capacity(anns.len());
    for (i, ann) in anns.iter().enumerate() {
        let seg = ann
            .get("segmentation")
            .with_context(|| format!("{}: mask {i} has no segmentation", path.display()))?;
        let m =
            rle::decode(seg).map_err(|e| anyhow::anyhow!("{}: mask {i}: {e}", path.display()))?;
        let origin = format!("{} mask {i}", path.display());
        let mask = binary(m.data, m.width, m.height, frame, Path::new(&origin))?;
        let score = score_of(ann).map_err(|e| anyhow::anyhow!("{origin}: {e}"))?;
        let label = ann
            .get("class_name")
            .and_then(Value::as_str)
            .map(str::to_string);
        cands.push(Candidate {
            key: (index as u64 + 1, i as u64),
            label,
            score,
            origin,
            mask,
        });
    }
    Ok(FrameMasks::Overlapping(cands))
}

/// Grounded-SAM-2 tracking output: `mask_data/mask_<stem>.npy` + `json_data/mask_<stem>.json`.
fn gsam_tracking_frame(source: &Path, stem: &str, frame: &Frame) -> Result<FrameMasks> {
    let npy_path = source.join("mask_data").join(format!("mask_{stem}.npy"));
    if !npy_path.is_file() {
        return Ok(FrameMasks::Missing);
    }
    let arr = npy::read(&npy_path)?;
    let ids = fit_to_frame(arr.data, arr.width, arr.height, frame, &npy_path)?;
    let json_path = source.join("json_data").join(format!("mask_{stem}.json"));
    let text = std::fs::read_to_string(&json_path).with_context(|| {
        format!(
            "{}: cannot read the labels for {}",
            json_path.display(),
            npy_path.display()
        )
    })?;
    let doc: Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: not JSON", json_path.display()))?;
    let mut labels = HashMap::new();
    if let Some(map) = doc.get("labels").and_then(Value::as_object) {
        for (k, v) in map {
            let id: u64 = match v.get("instance_id").and_then(Value::as_u64) {
                Some(id) => id,
                None => k.parse().with_context(|| {
                    format!(
                        "{}: label key {k:?} is not an instance id",
                        json_path.display()
                    )
                })?,
            };
            let class = v
                .get("class_name")
                .and_then(Value::as_str)
                .unwrap_or("object");
            labels.insert(id, class.to_string());
        }
    } else {
        bail!("{}: has no \"labels\" object", json_path.display());
    }
    if let Some(&missing) = ids.iter().find(|&&id| id != 0 && !labels.contains_key(&id)) {
        bail!(
            "{}: instance id {missing} appears in {} but has no entry in \"labels\"",
            json_path.display(),
            npy_path.display()
        );
    }
    Ok(FrameMasks::Exclusive { ids, labels })
}
