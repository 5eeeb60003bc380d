//! A ScanNet++ scene folder (`<root>/data/<scene>`) as posed views, an annotated mesh
//! and SfM points.
//!
//! Images: `dslr/resized_undistorted_images` (or `dslr/undistorted_images`), with
//! validity masks from `dslr/resized_undistorted_masks` (or `undistorted_anon_masks`)
//! when present. Intrinsics of the undistorted images come from
//! `dslr/nerfstudio/transforms_undistorted.json` (or, without it, from the camera in
//! `dslr/colmap`). Without undistorted images the distorted (fisheye) ones are used:
//! `dslr/resized_images` with `dslr/nerfstudio/transforms.json` (or `dslr/colmap`) and
//! masks from `dslr/resized_anon_masks`, undistorted here when the frames are written.
//! Poses come from `dslr/colmap/images.txt`, which is in the mesh frame. The nerfstudio JSON lives in another world frame: JSON world = M · mesh world
//! with `M = [[0,1,0],[1,0,0],[0,0,−1]]` (M is its own inverse), so a JSON pose maps to the
//! mesh frame as `M · c2w_json`, then to OpenCV axes. When both are present every JSON
//! camera centre must land within 1 mm of COLMAP's; when only the JSON is present, every
//! camera centre must fall inside the mesh's bounding box (grown by 1 m), which the
//! wrong frame would miss.
//!
//! Objects: `segments.json` gives each vertex a segment, `segments_anno.json` groups
//! segments into objects (`objectId`, `label`). A vertex whose segment belongs to
//! several groups goes to one by an explicit policy: `smallest` (fewest vertices, the
//! toolkit's training prep), `first` or `last` (file order; the toolkit's `anno.py`
//! lets the last win). Groups whose label is listed in `background_labels` (compared
//! case-insensitively) stay background (−1), and so do groups with an `objectId` ≤ 0
//! (the toolkit's rule). Object ids are the annotation's own `objectId`s, so masks,
//! components, metrics and exported names use the dataset's ids; masks store ids in
//! 16 bits, so an `objectId` above 65534 is an error.
//!
//! Split lists: `dslr/train_test_lists.json` is `{"train": [image names], "test": [image
//! names]}` (the names of the DSLR images, as in `file_path` and the COLMAP model);
//! [`read_train_test_lists`] reads it for `split: "lists"`.
//!
//! Points: `dslr/colmap/points3D.txt`; when that is missing or empty, the mesh vertices.

use crate::colmap::{self, ColmapModel};
use crate::nerfstudio::{self, Roots};
use crate::scene::SourceView;
use anyhow::{Context, Result, bail};
use glam::{DMat3, DMat4, DVec3};
use objectsplat_core::{Camera, Mesh, ObjectLabels, Points, Split};
use serde_json::Value;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// The ScanNet++ JSON world frame change (JSON world = M · mesh world).
pub const JSON_FROM_MESH: [[f64; 3]; 3] = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]];

pub const MESH_FILE: &str = "scans/mesh_aligned_0.05.ply";
pub const TRAIN_TEST_LISTS: &str = "dslr/train_test_lists.json";

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GroupOverlap {
    Smallest,
    First,
    Last,
}

impl GroupOverlap {
    pub const NAMES: [&'static str; 3] = ["smallest", "first", "last"];

    pub fn parse(name: &str) -> Result<GroupOverlap> {
        Ok(match name {
            "smallest" => GroupOverlap::Smallest,
            "first" => GroupOverlap::First,
            "last" => GroupOverlap::Last,
            other => bail!(
                "unknown overlap policy {other:?}; expected one of {:?}",
                GroupOverlap::NAMES
            ),
        })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PoseSource {
    Colmap,
    /// Poses from the nerfstudio JSON with the frame change applied.
    NerfstudioJson,
}

pub struct ScannetppScene {
    pub views: Vec<SourceView>,
    pub pose_source: PoseSource,
    pub mesh: Mesh,
    pub labels: ObjectLabels,
    pub points: Points,
    /// Vertices whose segment belonged to more than one (non-background) group.
    pub contested_vertices: usize,
    /// Frames skipped because the JSON marks them `is_bad`.
    pub skipped_bad: usize,
    /// The image folder used, relative to the scene folder.
    pub images: String,
    /// True when the images are the distorted ones (undistorted when written).
    pub distorted: bool,
    /// Annotation groups left as background because their `objectId` is ≤ 0.
    pub nonpositive_object_ids: usize,
}

fn first_dir(root: &Path, names: &[&str]) -> Option<PathBuf> {
    names.iter().map(|n| root.join(n)).find(|p| p.is_dir())
}

/// The ScanNet++ JSON → mesh frame change as a 4×4 matrix (M is its own inverse).
pub fn mesh_change() -> DMat4 {
    let m = DMat3::from_cols_array_2d(&JSON_FROM_MESH).transpose();
    DMat4::from_mat3(m)
}

pub fn load(
    root: &Path,
    overlap: GroupOverlap,
    background_labels: &[String],
) -> Result<ScannetppScene> {
    let dslr = root.join("dslr");
    let undistorted = first_dir(&dslr, &["resized_undistorted_images", "undistorted_images"]);
    let (images, masks, json, distorted) = match undistorted {
        Some(images) => (
            images,
            first_dir(
                &dslr,
                &["resized_undistorted_masks", "undistorted_anon_masks"],
            ),
            dslr.join("nerfstudio/transforms_undistorted.json"),
            false,
        ),
        None => {
            let images = first_dir(&dslr, &["resized_images"]).with_context(|| {
                format!(
                    "{}: no dslr/resized_undistorted_images, dslr/undistorted_images or dslr/resized_images",
                    root.display()
                )
            })?;
            (
                images,
                first_dir(&dslr, &["resized_anon_masks"]),
                dslr.join("nerfstudio/transforms.json"),
                true,
            )
        }
    };
    let colmap_dir = dslr.join("colmap");
    let model = if colmap_dir.is_dir() {
        Some(colmap::read_model(&colmap_dir)?)
    } else {
        None
    };

    let mesh_path = root.join(MESH_FILE);
    let mut mesh = Mesh::read_ply(&mesh_path)?;
    let (ids, labels, contested, nonpositive) =
        object_ids(root, &mesh, overlap, background_labels)?;
    mesh.object_ids = Some(ids);

    let (views, pose_source, skipped_bad) = if json.is_file() {
        let t = nerfstudio::read(
            &json,
            &Roots {
                images: Some(images.clone()),
                masks: masks.clone(),
            },
        )?;
        let mut views = t.views(mesh_change())?;
        if masks.is_none() {
            for v in &mut views {
                v.valid_mask = None;
            }
        }
        match &model {
            Some(model) => {
                replace_with_colmap_poses(&mut views, model, &json)?;
                (views, PoseSource::Colmap, t.skipped_bad)
            }
            None => {
                check_inside_mesh(&views, &mesh, &json)?;
                (views, PoseSource::NerfstudioJson, t.skipped_bad)
            }
        }
    } else if let Some(model) = &model {
        let views = crate::colmap_scene::views(model, &images)?;
        if !distorted && views.iter().any(|v| v.distortion.is_some()) {
            bail!(
                "{}: the images in {} are undistorted but dslr/colmap's camera is the distorted one, and \
                 without {} nothing gives the undistorted intrinsics",
                root.display(),
                images.display(),
                json.display()
            );
        }
        (views, PoseSource::Colmap, 0)
    } else {
        bail!(
            "{}: neither {} nor dslr/colmap is present",
            root.display(),
            json.strip_prefix(root).unwrap_or(&json).display()
        );
    };
    let points = match &model {
        Some(m) if !m.points.is_empty() => crate::colmap_scene::points(m),
        _ => {
            let colors = mesh.colors.clone().with_context(|| {
                format!(
                    "{}: no COLMAP points and the mesh has no colours to use instead",
                    mesh_path.display()
                )
            })?;
            Points {
                positions: mesh.positions.clone(),
                colors,
            }
        }
    };
    Ok(ScannetppScene {
        views,
        pose_source,
        mesh,
        labels,
        points,
        contested_vertices: contested,
        skipped_bad,
        images: images
            .strip_prefix(root)
            .unwrap_or(&images)
            .display()
            .to_string(),
        distorted,
        nonpositive_object_ids: nonpositive,
    })
}

fn replace_with_colmap_poses(
    views: &mut [SourceView],
    model: &ColmapModel,
    json: &Path,
) -> Result<()> {
    let by_name: HashMap<&str, &colmap::ColmapImage> = model
        .images
        .values()
        .map(|i| (i.name.as_str(), i))
        .collect();
    for v in views.iter_mut() {
        let img = by_name.get(v.name.as_str()).with_context(|| {
            format!(
                "{}: frame {:?} has no pose in {}",
                json.display(),
                v.name,
                model.dir.display()
            )
        })?;
        let from_colmap = Camera {
            world_to_camera: img.pose.matrix(),
            ..v.camera
        };
        let gap = (from_colmap.center() - v.camera.center()).length();
        if gap.is_nan() || gap > 1e-3 {
            bail!(
                "{}: frame {:?}: its camera centre, moved into the mesh frame, is {gap:.4} m from COLMAP's \
                 ({}); the two pose sources disagree",
                json.display(),
                v.name,
                model.dir.display()
            );
        }
        v.camera = from_colmap;
    }
    Ok(())
}

fn check_inside_mesh(views: &[SourceView], mesh: &Mesh, json: &Path) -> Result<()> {
    if mesh.positions.is_empty() {
        bail!(
            "{}: the mesh has no vertices to check the poses against",
            json.display()
        );
    }
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in &mesh.positions {
        let p = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let margin = DVec3::splat(1.0);
    for v in views {
        let c = v.camera.center();
        if c.cmplt(lo - margin).any() || c.cmpgt(hi + margin).any() {
            bail!(
                "{}: frame {:?}: camera centre {c:?} (after the frame change to the mesh frame) lies outside the mesh \
                 bounds {lo:?}..{hi:?}; the JSON is not in the documented frame",
                json.display(),
                v.name
            );
        }
    }
    Ok(())
}

struct Group {
    object_id: i64,
    label: String,
    segments: Vec<i64>,
}

fn read_json(path: &Path) -> Result<Value> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))
}

/// Per-vertex object ids (−1 = none), their labels, the number of contested vertices and
/// the number of groups left as background for an `objectId` ≤ 0.
fn object_ids(
    root: &Path,
    mesh: &Mesh,
    overlap: GroupOverlap,
    background_labels: &[String],
) -> Result<(Vec<i32>, ObjectLabels, usize, usize)> {
    let seg_path = root.join("scans/segments.json");
    let anno_path = root.join("scans/segments_anno.json");
    let seg = read_json(&seg_path)?;
    let seg_indices: Vec<i64> = seg
        .get("segIndices")
        .and_then(Value::as_array)
        .with_context(|| format!("{}: no segIndices list", seg_path.display()))?
        .iter()
        .enumerate()
        .map(|(i, v)| {
            v.as_i64().with_context(|| {
                format!("{}: segIndices[{i}] is not an integer", seg_path.display())
            })
        })
        .collect::<Result<_>>()?;
    if seg_indices.len() != mesh.positions.len() {
        bail!(
            "{}: {} segIndices for {} mesh vertices",
            seg_path.display(),
            seg_indices.len(),
            mesh.positions.len()
        );
    }
    let anno = read_json(&anno_path)?;
    let groups_json = anno
        .get("segGroups")
        .and_then(Value::as_array)
        .with_context(|| format!("{}: no segGroups list", anno_path.display()))?;
    let background: Vec<String> = background_labels.iter().map(|l| l.to_lowercase()).collect();
    let mut groups = Vec::new();
    let mut nonpositive = 0;
    for (g, v) in groups_json.iter().enumerate() {
        let at = || format!("{}: segGroups[{g}]", anno_path.display());
        let object_id = v
            .get("objectId")
            .and_then(Value::as_i64)
            .with_context(|| format!("{}: no integer objectId", at()))?;
        let label = v
            .get("label")
            .and_then(Value::as_str)
            .with_context(|| format!("{}: no label", at()))?
            .to_string();
        let segments = v
            .get("segments")
            .and_then(Value::as_array)
            .with_context(|| format!("{}: no segments list", at()))?
            .iter()
            .map(|s| {
                s.as_i64()
                    .with_context(|| format!("{}: a segment id is not an integer", at()))
            })
            .collect::<Result<Vec<_>>>()?;
        if background.contains(&label.to_lowercase()) {
            continue;
        }
        // The toolkit treats ids ≤ 0 as background.
        if object_id <= 0 {
            nonpositive += 1;
            continue;
        }
        if object_id >= objectsplat_core::masks::UNOWNED as i64 {
            bail!(
                "{}: objectId {object_id} (label {label:?}) does not fit a mask: masks store object ids in \
                 16 bits, so ids must be 1..=65534",
                at()
            );
        }
        groups.push(Group {
            object_id,
            label,
            segments,
        });
    }
    // Segment → groups containing it, in file order.
    let mut seg_groups: HashMap<i64, Vec<usize>> = HashMap::new();
    for (g, group) in groups.iter().enumerate() {
        for s in &group.segments {
            let entry = seg_groups.entry(*s).or_default();
            if entry.last() != Some(&g) {
                entry.push(g);
            }
        }
    }
    let mut size = vec![0usize; groups.len()];
    for s in &seg_indices {
        for &g in seg_groups.get(s).map(Vec::as_slice).unwrap_or(&[]) {
            size[g] += 1;
        }
    }
    let mut owner: Vec<Option<usize>> = vec![None; seg_indices.len()];
    let mut contested = 0;
    for (v, s) in seg_indices.iter().enumerate() {
        let Some(candidates) = seg_groups.get(s) else {
            continue;
        };
        if candidates.len() > 1 {
            contested += 1;
        }
        owner[v] = match overlap {
            GroupOverlap::First => candidates.first().copied(),
            GroupOverlap::Last => candidates.last().copied(),
            GroupOverlap::Smallest => candidates.iter().copied().min_by_key(|&g| (size[g], g)),
        };
    }
    let mut used: BTreeMap<i64, String> = BTreeMap::new();
    for g in owner.iter().flatten() {
        used.entry(groups[*g].object_id)
            .or_insert_with(|| groups[*g].label.clone());
    }
    // Ids were checked to lie in 1..=65534 when the groups were read.
    let ids = owner
        .iter()
        .map(|o| o.map_or(-1, |g| groups[g].object_id as i32))
        .collect();
    let labels = used.into_iter().map(|(o, l)| (o as u16, l)).collect();
    Ok((ids, labels, contested, nonpositive))
}

/// Reads `dslr/train_test_lists.json`: image name → its split. Errors name the file
/// and the field.
pub fn read_train_test_lists(root: &Path) -> Result<(PathBuf, HashMap<String, Split>)> {
    let path = root.join(TRAIN_TEST_LISTS);
    if !path.is_file() {
        bail!(
            "{}: not found; split \"lists\" reads the scene's official train/test lists from it \
             (use split \"sparse\", \"dense\" or \"all\" for a scene without one)",
            path.display()
        );
    }
    let doc = read_json(&path)?;
    let mut out = HashMap::new();
    for (key, split) in [("train", Split::Train), ("test", Split::Test)] {
        let list = doc
            .get(key)
            .and_then(Value::as_array)
            .with_context(|| format!("{}: no \"{key}\" list of image names", path.display()))?;
        for (i, name) in list.iter().enumerate() {
            let name = name.as_str().with_context(|| {
                format!(
                    "{}: {key}[{i}] is not an image name (a string)",
                    path.display()
                )
            })?;
            if let Some(previous) = out.insert(name.to_string(), split)
                && previous != split
            {
                bail!(
                    "{}: image {name:?} is in both the train and the test list",
                    path.display()
                );
            }
        }
    }
    Ok((path, out))
}
