//! The Scene artifact: the trained components side by side in the shared world frame.
//!
//! Encoding (a folder, see the crate README):
//! - `scene.json`: `{"objects": [{"name", "kind": "object" | "background", "id", "label",
//!   "source", "placement"?}], "edits"?: [RON text]}`, background entries first, then
//!   objects by id; `placement` (absent = the model is where it was trained) places the
//!   model in the world, `edits` records the edits that made the scene from the composed one;
//! - `objects/<name>/`: one Model folder per entry (`model.ply` + `model.json`), in the
//!   member's model frame (the frame it was trained in);
//! - `fills/<frame stem>.png` (optional, written by `edit_scene`): background images
//!   that `render` shows wherever no triangle covers a pixel.

use crate::Placement;
use crate::sh_rotation::ShRotation;
use anyhow::{Context, Result, bail, ensure};
use glam::DMat3;
use objectsplat_core::artifact::{SCENE_JSON, SCENE_OBJECTS_DIR};
use objectsplat_core::{ComponentInfo, ComponentKind};
use objectsplat_raster::{Model, load_model, save_model};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::collections::HashSet;
use std::path::Path;

/// One entry of `scene.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneEntry {
    /// Unique within the scene; also the folder name under `objects/`.
    pub name: String,
    pub kind: ComponentKind,
    /// Object id (1..=65534); null for the background.
    pub id: Option<u16>,
    /// Object label; null for the background.
    pub label: Option<String>,
    /// The component (collection item) the model was trained as; a duplicate keeps its original's.
    pub source: String,
    /// Where the model sits in the world; `None`: where it was trained (scenes written
    /// before placements existed, and members no rigid edit touched).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub placement: Option<Placement>,
}

impl SceneEntry {
    pub fn from_component(info: &ComponentInfo, source: &str) -> SceneEntry {
        SceneEntry {
            name: info.name.clone(),
            kind: info.kind,
            id: info.object_id,
            label: info.label.clone(),
            source: source.to_string(),
            placement: None,
        }
    }

    /// An object entry named by the core naming rule `obj_<id>_<label>`.
    pub fn object(id: u16, label: &str, source: &str) -> SceneEntry {
        SceneEntry::from_component(&ComponentInfo::object(id, label), source)
    }

    pub fn component(&self) -> ComponentInfo {
        ComponentInfo {
            name: self.name.clone(),
            kind: self.kind,
            object_id: self.id,
            label: self.label.clone(),
        }
    }

    /// Background entries sort before objects, objects by id; names break ties.
    fn order_key(&self) -> (u8, u16, String) {
        match self.kind {
            ComponentKind::Background => (0, 0, self.name.clone()),
            ComponentKind::Object => (1, self.id.unwrap_or(0), self.name.clone()),
        }
    }
}

#[derive(Debug, Serialize, Deserialize)]
struct SceneJson {
    objects: Vec<SceneEntry>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    edits: Vec<String>,
}

/// One member of a scene: its description and its model (model frame; see
/// [`SceneObject::world_model`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneObject {
    pub entry: SceneEntry,
    pub model: Model<f32>,
}

/// The mean vertex of `model` (the origin for an empty model), rounded to f32 so that a
/// glTF node (f32) sits exactly on it.
pub fn model_centroid(model: &Model<f32>) -> [f64; 3] {
    let n = model.vertices.len();
    if n == 0 {
        return [0.0; 3];
    }
    let mut sum = [0.0f64; 3];
    for v in &model.vertices {
        for k in 0..3 {
            sum[k] += f64::from(v[k]);
        }
    }
    sum.map(|s| f64::from((s / n as f64) as f32))
}

impl SceneObject {
    /// The member's placement: the stored one, else its model where it was trained with
    /// the pivot on the model's centroid ([`model_centroid`]).
    pub fn placement(&self) -> Placement {
        self.entry
            .placement
            .unwrap_or_else(|| Placement::at(model_centroid(&self.model)))
    }

    /// The model in world coordinates: vertices through the placement, view-dependent
    /// colour (SH) rotated with it. Without a stored placement, the model itself.
    pub fn world_model(&self) -> Result<Cow<'_, Model<f32>>> {
        let Some(placement) = self.entry.placement else {
            return Ok(Cow::Borrowed(&self.model));
        };
        Ok(Cow::Owned(
            place_model(&self.model, &placement)
                .with_context(|| format!("scene member {:?}", self.entry.name))?,
        ))
    }
}

/// `model` moved into the world by `placement`.
pub fn place_model(model: &Model<f32>, placement: &Placement) -> Result<Model<f32>> {
    let mut out = model.clone();
    for v in &mut out.vertices {
        *v = placement.world(v.map(f64::from)).map(|x| x as f32);
    }
    let r = placement.rotation_matrix();
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if r != identity {
        // DMat3 is column-major: column j holds row entries r[·][j].
        let m = DMat3::from_cols_array_2d(&[
            [r[0][0], r[1][0], r[2][0]],
            [r[0][1], r[1][1], r[2][1]],
            [r[0][2], r[1][2], r[2][2]],
        ]);
        let sh = ShRotation::new(m)?;
        for rows in &mut out.sh {
            *rows = sh.apply(rows);
        }
    }
    Ok(out)
}

/// A composed scene: separable members in the deterministic order of `scene.json`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scene {
    pub objects: Vec<SceneObject>,
    /// The edits (RON text, in order) that made this scene from the composed one; replaying
    /// them with `edit_scene` on that scene gives this one.
    pub edits: Vec<String>,
}

/// The union of a scene's models as one model, and which member each face came from.
#[derive(Debug, Clone)]
pub struct MergedModel {
    pub model: Model<f32>,
    /// Per merged face, the index of its member in `Scene::objects`.
    pub face_owner: Vec<usize>,
}

impl Scene {
    /// Builds a scene, sorting members into the canonical order and checking the entries.
    pub fn new(mut objects: Vec<SceneObject>) -> Result<Scene> {
        objects.sort_by_key(|o| o.entry.order_key());
        let scene = Scene {
            objects,
            edits: Vec::new(),
        };
        scene.validate()?;
        Ok(scene)
    }

    /// Names unique and usable as folder names, ids present exactly on objects and unique,
    /// every model valid.
    pub fn validate(&self) -> Result<()> {
        let mut names = HashSet::new();
        let mut ids = HashSet::new();
        for o in &self.objects {
            let e = &o.entry;
            ensure!(
                !e.name.is_empty()
                    && e.name
                        .chars()
                        .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-'),
                "scene member name {:?} must be non-empty and use only [A-Za-z0-9_-]",
                e.name
            );
            ensure!(
                names.insert(e.name.as_str()),
                "scene member {:?} appears twice",
                e.name
            );
            match (e.kind, e.id) {
                (ComponentKind::Object, Some(id)) => {
                    ensure!(
                        (1..=65534).contains(&id),
                        "object {:?} has id {id}; ids are 1..=65534",
                        e.name
                    );
                    ensure!(
                        ids.insert(id),
                        "object id {id} is used by two scene members"
                    );
                }
                (ComponentKind::Object, None) => bail!("object {:?} has no id", e.name),
                (ComponentKind::Background, Some(id)) => {
                    bail!("background {:?} must not carry an object id ({id})", e.name)
                }
                (ComponentKind::Background, None) => {}
            }
            if let Some(p) = &e.placement {
                ensure!(
                    p.pivot
                        .iter()
                        .chain(&p.translation)
                        .chain(&p.rotation)
                        .all(|v| v.is_finite())
                        && p.scale.is_finite()
                        && p.scale > 0.0
                        && p.rotation.iter().any(|&v| v != 0.0),
                    "scene member {:?} has an invalid placement {p:?} (finite values, a non-zero rotation and a positive scale are required)",
                    e.name
                );
            }
            o.model
                .validate()
                .with_context(|| format!("scene member {:?}", e.name))?;
        }
        Ok(())
    }

    pub fn find_id(&self, id: u16) -> Option<usize> {
        self.objects.iter().position(|o| o.entry.id == Some(id))
    }

    /// The largest object id in use (0 when there is none).
    pub fn max_id(&self) -> u16 {
        self.objects
            .iter()
            .filter_map(|o| o.entry.id)
            .max()
            .unwrap_or(0)
    }

    pub fn face_count(&self) -> usize {
        self.objects.iter().map(|o| o.model.face_count()).sum()
    }

    /// Concatenates all members' triangles, placed in the world, into one model (no re-optimization).
    ///
    /// Every member renders as it was trained ([`Model::union`]): its own σ per face,
    /// its opacities and its SH degree.
    pub fn merged_model(&self) -> Result<MergedModel> {
        let placed = self
            .objects
            .iter()
            .map(|o| o.world_model())
            .collect::<Result<Vec<_>>>()?;
        let parts: Vec<&Model<f32>> = placed.iter().map(|m| m.as_ref()).collect();
        let model = Model::union(&parts).context("merging the scene's members")?;
        let face_owner = self
            .objects
            .iter()
            .enumerate()
            .flat_map(|(index, o)| std::iter::repeat_n(index, o.model.faces.len()))
            .collect();
        Ok(MergedModel { model, face_owner })
    }
}

/// Writes `scene.json` and `objects/<name>/` into `dir` (created if missing).
pub fn save_scene(scene: &Scene, dir: &Path) -> Result<()> {
    scene
        .validate()
        .context("refusing to save an invalid scene")?;
    let mut sorted = scene.clone();
    sorted.objects.sort_by_key(|o| o.entry.order_key());
    std::fs::create_dir_all(dir.join(SCENE_OBJECTS_DIR))
        .with_context(|| format!("{}: cannot create scene folder", dir.display()))?;
    for o in &sorted.objects {
        save_model(&o.model, &dir.join(SCENE_OBJECTS_DIR).join(&o.entry.name))
            .with_context(|| format!("{}: scene member {:?}", dir.display(), o.entry.name))?;
    }
    let json = SceneJson {
        objects: sorted.objects.iter().map(|o| o.entry.clone()).collect(),
        edits: sorted.edits.clone(),
    };
    let path = dir.join(SCENE_JSON);
    std::fs::write(&path, serde_json::to_string_pretty(&json)? + "\n")
        .with_context(|| format!("{}: cannot write", path.display()))
}

/// Reads a Scene folder written by [`save_scene`] and validates it.
pub fn load_scene(dir: &Path) -> Result<Scene> {
    let path = dir.join(SCENE_JSON);
    let json: SceneJson = objectsplat_core::files::read_json(&path, "scene description")?;
    let mut objects = Vec::with_capacity(json.objects.len());
    for entry in json.objects {
        // Checked before the name is used as a path, so it cannot leave the folder.
        ensure!(
            !entry.name.is_empty()
                && entry
                    .name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-'),
            "{}: member name {:?} must use only [A-Za-z0-9_-]",
            path.display(),
            entry.name
        );
        let model = load_model(&dir.join(SCENE_OBJECTS_DIR).join(&entry.name))
            .with_context(|| format!("{}: member {:?}", path.display(), entry.name))?;
        objects.push(SceneObject { entry, model });
    }
    let scene = Scene {
        objects,
        edits: json.edits,
    };
    scene
        .validate()
        .with_context(|| format!("{}: invalid scene", path.display()))?;
    Ok(scene)
}

/// The component a collection item stands for: model.json's `metadata.component`
/// (a ComponentInfo) when present, else parsed from the item name
/// (`background` or `obj_<id>_<label>`).
pub fn component_of_item(item: &str, model: &Model<f32>) -> Result<ComponentInfo> {
    if let Some(value) = model.metadata.get("component") {
        let info: ComponentInfo = serde_json::from_value(value.clone()).with_context(|| {
            format!("item {item:?}: model.json metadata.component is not a component description")
        })?;
        return Ok(info);
    }
    parse_item_name(item)
}

/// `background` (or `background_<anything>`) → the background; `scene` → the holistic
/// baseline's single component (a background owning every pixel); `obj_<id>_<label>` → that object.
pub fn parse_item_name(item: &str) -> Result<ComponentInfo> {
    if item == "background" || item.starts_with("background_") || item == "scene" {
        let mut info = ComponentInfo::background();
        info.name = item.to_string();
        return Ok(info);
    }
    let bad = || {
        anyhow::anyhow!(
            "item {item:?} is neither `background`, `scene` nor `obj_<id>_<label>`, and its model.json has no metadata.component"
        )
    };
    let rest = item.strip_prefix("obj_").ok_or_else(bad)?;
    let (id_text, label) = rest.split_once('_').unwrap_or((rest, ""));
    let id: u16 = id_text.parse().map_err(|_| bad())?;
    ensure!(
        (1..=65534).contains(&id),
        "item {item:?}: object id {id} is outside 1..=65534"
    );
    let mut info = ComponentInfo::object(id, label);
    // The member keeps the item's own name, so a scene member is traceable to its item.
    info.name = item.to_string();
    Ok(info)
}
