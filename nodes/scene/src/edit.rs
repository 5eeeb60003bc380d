//! Scene edits: move, rotate, scale, duplicate, remove and recolor members, given in RON.
//!
//! ```ron
//! [
//!     Move(target: Id(3), by: (0.5, 0.0, 0.0)),
//!     Rotate(target: Label("chair"), axis: (0, 0, 1), degrees: 90),
//!     Scale(target: Id(2), factor: 1.5),
//!     Duplicate(target: Id(4), offset: (1, 0, 0)),
//!     Remove(target: Label("cup")),
//!     Recolor(target: Name("background"), rgb: (1, 0, 0)),
//! ]
//! ```
//!
//! - Targets: `Id(n)` the object with that id; `Label("chair")` every object with that
//!   label; `Name("obj_3_chair")` the member of that name (the only way to reach the
//!   background). A target that matches nothing is an error naming the edit.
//! - Edits apply in list order; each sees the result of the previous ones.
//! - Rigid edits (`Move`, `Rotate`, `Scale`, the offset of a `Duplicate`) change the
//!   member's [`Placement`](crate::Placement), not its model: the model
//!   stays in the frame it was trained in and the placement maps it into the world
//!   (the exported `.glb` node carries it as its transform).
//! - `Rotate` and `Scale` act about the member's pivot: its centroid (mean vertex
//!   position, rounded to f32) where it was trained, carried along by every edit, so
//!   it stays the centroid. Rotation also rotates the view-dependent SH colour (when
//!   the scene is placed in the world), so the object looks the same from the rotated
//!   viewpoints. `Scale` is uniform and must be positive.
//! - `Duplicate` adds a copy shifted by `offset` with the next free object id
//!   (largest id in the scene + 1) and the name `obj_<id>_<label>`.
//! - `Recolor` sets a view-independent sRGB colour in [0, 1] (SH DC term; higher
//!   bands zeroed); opacities are kept.
//! - The scene records every applied edit (its RON text) in `Scene::edits`, after the
//!   edits it already carried, so a viewer can export the whole list.

use crate::scene::{Scene, SceneEntry, SceneObject};
use anyhow::{Context, Result, bail, ensure};
use glam::DVec3;
use objectsplat_core::ComponentKind;
use objectsplat_raster::SH_COEFFS;
use objectsplat_raster::sh::SH_DC;
use serde::Deserialize;
use std::fmt;

/// A number written either as an integer or a float in RON (`1` or `1.0`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Num, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Num;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number")
            }
            fn visit_f64<E>(self, v: f64) -> Result<Num, E> {
                Ok(Num(v))
            }
            fn visit_i64<E>(self, v: i64) -> Result<Num, E> {
                Ok(Num(v as f64))
            }
            fn visit_u64<E>(self, v: u64) -> Result<Num, E> {
                Ok(Num(v as f64))
            }
        }
        d.deserialize_any(V)
    }
}

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
pub enum Target {
    Id(u16),
    Label(String),
    Name(String),
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            Target::Id(id) => write!(f, "Id({id})"),
            Target::Label(l) => write!(f, "Label({l:?})"),
            Target::Name(n) => write!(f, "Name({n:?})"),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Edit {
    Move {
        target: Target,
        by: [Num; 3],
    },
    Rotate {
        target: Target,
        axis: [Num; 3],
        degrees: Num,
    },
    Scale {
        target: Target,
        factor: Num,
    },
    Duplicate {
        target: Target,
        offset: [Num; 3],
    },
    Remove {
        target: Target,
    },
    Recolor {
        target: Target,
        rgb: [Num; 3],
    },
}

fn vec3(v: &[Num; 3]) -> DVec3 {
    DVec3::new(v[0].0, v[1].0, v[2].0)
}

fn array3(v: &[Num; 3]) -> [f64; 3] {
    v.map(|x| x.0)
}

fn show3(v: &[Num; 3]) -> String {
    format!("({}, {}, {})", v[0], v[1], v[2])
}

impl fmt::Display for Edit {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            Edit::Move { target, by } => write!(f, "Move(target: {target}, by: {})", show3(by)),
            Edit::Rotate {
                target,
                axis,
                degrees,
            } => write!(
                f,
                "Rotate(target: {target}, axis: {}, degrees: {degrees})",
                show3(axis)
            ),
            Edit::Scale { target, factor } => {
                write!(f, "Scale(target: {target}, factor: {factor})")
            }
            Edit::Duplicate { target, offset } => {
                write!(f, "Duplicate(target: {target}, offset: {})", show3(offset))
            }
            Edit::Remove { target } => write!(f, "Remove(target: {target})"),
            Edit::Recolor { target, rgb } => {
                write!(f, "Recolor(target: {target}, rgb: {})", show3(rgb))
            }
        }
    }
}

impl Edit {
    pub fn target(&self) -> &Target {
        match self {
            Edit::Move { target, .. }
            | Edit::Rotate { target, .. }
            | Edit::Scale { target, .. }
            | Edit::Duplicate { target, .. }
            | Edit::Remove { target }
            | Edit::Recolor { target, .. } => target,
        }
    }

    /// Rejects non-finite numbers, a zero rotation axis, a non-positive scale and colours outside [0, 1].
    pub fn validate(&self) -> Result<()> {
        let finite3 = |name: &str, v: &[Num; 3]| -> Result<()> {
            ensure!(
                v.iter().all(|x| x.0.is_finite()),
                "{name} {} must be finite",
                show3(v)
            );
            Ok(())
        };
        match self {
            Edit::Move { by, .. } => finite3("by", by),
            Edit::Duplicate { offset, .. } => finite3("offset", offset),
            Edit::Rotate { axis, degrees, .. } => {
                finite3("axis", axis)?;
                ensure!(
                    vec3(axis).length() > 1e-12,
                    "axis {} has zero length",
                    show3(axis)
                );
                ensure!(degrees.0.is_finite(), "degrees {degrees} must be finite");
                Ok(())
            }
            Edit::Scale { factor, .. } => {
                ensure!(
                    factor.0.is_finite() && factor.0 > 0.0,
                    "factor {factor} must be finite and positive"
                );
                Ok(())
            }
            Edit::Remove { .. } => Ok(()),
            Edit::Recolor { rgb, .. } => {
                ensure!(
                    rgb.iter().all(|x| (0.0..=1.0).contains(&x.0)),
                    "rgb {} must lie in [0, 1]",
                    show3(rgb)
                );
                Ok(())
            }
        }
    }
}

/// Each edit's fields, as [`Edit`] declares them (a test keeps the two in step): what
/// a check of the graph names when an edit has a field it does not know.
pub const EDIT_FIELDS: &[(&str, &[&str])] = &[
    ("Move", &["target", "by"]),
    ("Rotate", &["target", "axis", "degrees"]),
    ("Scale", &["target", "factor"]),
    ("Duplicate", &["target", "offset"]),
    ("Remove", &["target"]),
    ("Recolor", &["target", "rgb"]),
];

/// What is wrong with one item of the `edits` list, and where inside it: `[]` for
/// the whole item, `["tagret"]` for an unknown field. `None` when it is a valid edit.
pub fn edit_item_problem(item: &objectsplat_runtime::Value) -> Option<(Vec<String>, String)> {
    use objectsplat_runtime::Value;
    let kinds = || {
        EDIT_FIELDS
            .iter()
            .map(|(k, _)| *k)
            .collect::<Vec<_>>()
            .join(", ")
    };
    if let Value::Struct(Some(kind), fields) = item {
        let Some((_, known)) = EDIT_FIELDS.iter().find(|(k, _)| k == kind) else {
            return Some((
                vec![],
                format!("unknown edit `{kind}`; edits are {}", kinds()),
            ));
        };
        if let Some((name, _)) = fields.iter().find(|(f, _)| !known.contains(&f.as_str())) {
            return Some((
                vec![name.clone()],
                format!(
                    "`{kind}` has no field `{name}`; its fields are {}",
                    known.join(", ")
                ),
            ));
        }
    }
    match item.deserialize::<Edit>() {
        Err(e) => Some((
            vec![],
            format!(
                "not an edit ({e}); expected one of {}, e.g. Move(target: Id(3), by: (0.5, 0, 0))",
                kinds()
            ),
        )),
        Ok(edit) => edit.validate().err().map(|e| (vec![], format!("{e:#}"))),
    }
}

/// Parses the `edits` list, one item at a time so an error names the bad item.
pub fn parse_edits(items: &[objectsplat_runtime::Value]) -> Result<Vec<Edit>> {
    items
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let edit: Edit = v
                .deserialize()
                .map_err(|e| anyhow::anyhow!("edit {i} `{}`: {e}", v.to_ron()))?;
            edit.validate()
                .with_context(|| format!("edit {i} `{edit}`"))?;
            Ok(edit)
        })
        .collect()
}

/// What the edits did, for the run report and for background filling.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EditLog {
    /// Names of members whose geometry moved away from where they were trained
    /// (moved, rotated, scaled or removed): what they covered may now be revealed.
    pub displaced: Vec<String>,
    /// Names of the members the duplicates created.
    pub added: Vec<String>,
    pub removed: Vec<String>,
}

fn resolve(scene: &Scene, target: &Target) -> Result<Vec<usize>> {
    let found: Vec<usize> = match target {
        Target::Id(id) => scene.find_id(*id).into_iter().collect(),
        Target::Label(label) => (0..scene.objects.len())
            .filter(|&i| scene.objects[i].entry.label.as_deref() == Some(label.as_str()))
            .collect(),
        Target::Name(name) => (0..scene.objects.len())
            .filter(|&i| scene.objects[i].entry.name == *name)
            .collect(),
    };
    if found.is_empty() {
        let known: Vec<String> = scene
            .objects
            .iter()
            .map(|o| match (o.entry.id, &o.entry.label) {
                (Some(id), Some(label)) => format!("{} (id {id}, label {label:?})", o.entry.name),
                _ => o.entry.name.clone(),
            })
            .collect();
        let what = match target {
            Target::Id(id) => format!("no object has id {id}"),
            Target::Label(label) => format!("no object has label {label:?}"),
            Target::Name(name) => format!("no scene member is named {name:?}"),
        };
        bail!("{what}; the scene has: {}", known.join(", "));
    }
    Ok(found)
}

/// Replaces the member's placement by `f` of its current one.
fn replace_placement(object: &mut SceneObject, f: impl Fn(crate::Placement) -> crate::Placement) {
    object.entry.placement = Some(f(object.placement()));
}

/// Applies `edits` in order and appends them to the scene's edit record. On error the
/// scene is left partially edited; callers work on a copy (the nodes always do).
pub fn apply_edits(scene: &mut Scene, edits: &[Edit]) -> Result<EditLog> {
    let mut log = EditLog::default();
    for (i, edit) in edits.iter().enumerate() {
        apply_one(scene, edit, &mut log).with_context(|| format!("edit {i} `{edit}`"))?;
    }
    let mut record = std::mem::take(&mut scene.edits);
    record.extend(edits.iter().map(|e| e.to_string()));
    *scene = Scene::new(std::mem::take(&mut scene.objects))?;
    scene.edits = record;
    Ok(log)
}

fn note_displaced(log: &mut EditLog, name: &str) {
    if !log.displaced.iter().any(|n| n == name) {
        log.displaced.push(name.to_string());
    }
}

fn apply_one(scene: &mut Scene, edit: &Edit, log: &mut EditLog) -> Result<()> {
    edit.validate()?;
    let targets = resolve(scene, edit.target())?;
    match edit {
        Edit::Move { by, .. } => {
            for &t in &targets {
                replace_placement(&mut scene.objects[t], |p| p.moved(array3(by)));
                note_displaced(log, &scene.objects[t].entry.name.clone());
            }
        }
        Edit::Rotate { axis, degrees, .. } => {
            for &t in &targets {
                replace_placement(&mut scene.objects[t], |p| {
                    p.rotated(array3(axis), degrees.0)
                });
                note_displaced(log, &scene.objects[t].entry.name.clone());
            }
        }
        Edit::Scale { factor, .. } => {
            for &t in &targets {
                replace_placement(&mut scene.objects[t], |p| p.scaled(factor.0));
                note_displaced(log, &scene.objects[t].entry.name.clone());
            }
        }
        Edit::Duplicate { offset, .. } => {
            let offset = array3(offset);
            for &t in &targets {
                let original = &scene.objects[t];
                ensure!(
                    original.entry.kind == ComponentKind::Object,
                    "{:?} is the background; only objects can be duplicated",
                    original.entry.name
                );
                let next = u32::from(scene.max_id()) + 1;
                ensure!(
                    next <= 65534,
                    "no free object id is left for a copy of {:?}",
                    original.entry.name
                );
                // Fits in u16: checked against 65534 above.
                let id = next as u16;
                let label = original.entry.label.clone().unwrap_or_default();
                let mut copy = SceneObject {
                    entry: SceneEntry::object(id, &label, &original.entry.source),
                    model: original.model.clone(),
                };
                copy.entry.placement = Some(original.placement().moved(offset));
                log.added.push(copy.entry.name.clone());
                scene.objects.push(copy);
            }
        }
        Edit::Remove { .. } => {
            // Remove from the back so earlier indices stay valid.
            for &t in targets.iter().rev() {
                let removed = scene.objects.remove(t);
                note_displaced(log, &removed.entry.name);
                log.removed.push(removed.entry.name);
            }
        }
        Edit::Recolor { rgb, .. } => {
            let dc = rgb.map(|c| ((c.0 - 0.5) / SH_DC) as f32);
            for &t in &targets {
                let model = &mut scene.objects[t].model;
                for rows in &mut model.sh {
                    *rows = [[0.0; 3]; SH_COEFFS];
                    rows[0] = dc;
                }
                // The recoloured member is flat everywhere: no bake to keep.
                model.flat_dc.clear();
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod field_table {
    use super::*;

    #[test]
    fn edit_fields_list_every_variant_and_its_fields() {
        let parse = |t: &str| objectsplat_runtime::syntax::parse(t).unwrap().to_value();
        let samples = [
            "Move(target: Id(1), by: (1, 0, 0))",
            "Rotate(target: Id(1), axis: (0, 0, 1), degrees: 90)",
            "Scale(target: Id(1), factor: 2)",
            "Duplicate(target: Id(1), offset: (1, 0, 0))",
            "Remove(target: Id(1))",
            "Recolor(target: Id(1), rgb: (1, 0, 0))",
        ];
        assert_eq!(samples.len(), EDIT_FIELDS.len());
        for (text, (kind, fields)) in samples.iter().zip(EDIT_FIELDS) {
            let v = parse(text);
            assert!(v.deserialize::<Edit>().is_ok(), "{text}");
            assert!(edit_item_problem(&v).is_none(), "{text}");
            let objectsplat_runtime::Value::Struct(Some(k), f) = &v else {
                panic!("{text} is not a named struct");
            };
            assert_eq!(k, kind);
            let names: Vec<&str> = f.iter().map(|(n, _)| n.as_str()).collect();
            assert_eq!(&names, fields);
        }
        let typo = parse("Move(tagret: Id(1), by: (1, 0, 0))");
        assert_eq!(edit_item_problem(&typo).unwrap().0, ["tagret"]);
    }
}
