//! PLY encodings of [`Mesh`] and [`Points`], and the Mesh artifact folder.
//!
//! Reading is permissive about what peers write: positions of any numeric type
//! (doubles are rounded to f32), colours as `uchar` (or as floats in 0..1, scaled
//! to 0..255), faces under `vertex_indices` or `vertex_index` with any index type,
//! polygons with more than three corners split into a fan of triangles. Writing
//! follows the encoding in `geometry.rs` exactly: binary little-endian, `float
//! x,y,z`, `uchar red,green,blue`, `int object_id`, `list uchar int vertex_indices`.
//!
//! Mesh artifact: `mesh.ply` plus, when the mesh carries object ids, `objects.json`
//! (id → label). Object ids are −1 (none) or 1..=65534, the same id space as masks,
//! and every id used by a vertex must have a label.

use crate::artifact::{MESH_PLY, OBJECTS_JSON};
use crate::geometry::{Mesh, Points};
use crate::masks::{self, NO_OBJECT, ObjectLabels, UNOWNED};
use crate::ply::{Column, Element, Format, Ply, Property, ScalarType};
use anyhow::{Context, Result, bail};
use std::path::Path;

fn at(path: &Path, message: String) -> anyhow::Error {
    anyhow::anyhow!("{}: {message}", path.display())
}

fn read_positions(path: &Path, vertex: &Element) -> Result<Vec<[f32; 3]>> {
    let x = vertex.scalar_f32("x").map_err(|e| at(path, e))?;
    let y = vertex.scalar_f32("y").map_err(|e| at(path, e))?;
    let z = vertex.scalar_f32("z").map_err(|e| at(path, e))?;
    let positions: Vec<[f32; 3]> = x
        .into_iter()
        .zip(y)
        .zip(z)
        .map(|((x, y), z)| [x, y, z])
        .collect();
    if let Some(i) = positions
        .iter()
        .position(|p| p.iter().any(|v| !v.is_finite()))
    {
        bail!(
            "{}: vertex {i} has a non-finite coordinate {:?}",
            path.display(),
            positions[i]
        );
    }
    Ok(positions)
}

/// `red,green,blue` when present: `uchar` as is, floats in 0..1 scaled to 0..255.
fn read_colors(path: &Path, vertex: &Element) -> Result<Option<Vec<[u8; 3]>>> {
    let names = ["red", "green", "blue"];
    let present = names.iter().filter(|n| vertex.has(n)).count();
    if present == 0 {
        return Ok(None);
    }
    if present < 3 {
        bail!(
            "{}: vertex colour needs all of red, green, blue; only some are present",
            path.display()
        );
    }
    let mut channels: Vec<Vec<u8>> = Vec::with_capacity(3);
    for name in names {
        let column = vertex.column(name).map_err(|e| at(path, e))?;
        let values = if column.scalar_type().is_integer() {
            vertex.scalar_u8(name).map_err(|e| at(path, e))?
        } else {
            let raw = vertex.scalar_f64(name).map_err(|e| at(path, e))?;
            if let Some(i) = raw.iter().position(|v| !(0.0..=1.0).contains(v)) {
                bail!(
                    "{}: vertex {i} float colour {name} = {} is outside 0..1",
                    path.display(),
                    raw[i]
                );
            }
            raw.into_iter().map(|v| (v * 255.0).round() as u8).collect()
        };
        channels.push(values);
    }
    let n = channels[0].len();
    Ok(Some(
        (0..n)
            .map(|i| [channels[0][i], channels[1][i], channels[2][i]])
            .collect(),
    ))
}

fn read_faces(path: &Path, ply: &Ply, vertex_count: usize) -> Result<Vec<[u32; 3]>> {
    let Ok(face) = ply.element("face") else {
        return Ok(Vec::new());
    };
    let name = if face.has("vertex_indices") {
        "vertex_indices"
    } else if face.has("vertex_index") {
        "vertex_index"
    } else {
        bail!(
            "{}: element \"face\" has neither vertex_indices nor vertex_index",
            path.display()
        );
    };
    let list = face.list_u32(name).map_err(|e| at(path, e))?;
    let mut faces = Vec::with_capacity(list.len());
    for (f, corners) in list.rows().enumerate() {
        if corners.len() < 3 {
            bail!(
                "{}: face {f} has {} corners; a face needs at least 3",
                path.display(),
                corners.len()
            );
        }
        if let Some(&v) = corners.iter().find(|&&v| v as usize >= vertex_count) {
            bail!(
                "{}: face {f} refers to vertex {v} but there are only {vertex_count} vertices",
                path.display()
            );
        }
        for k in 1..corners.len() - 1 {
            faces.push([corners[0], corners[k], corners[k + 1]]);
        }
    }
    Ok(faces)
}

impl Mesh {
    pub fn read_ply(path: &Path) -> Result<Mesh> {
        Mesh::from_ply(&Ply::read(path)?, path)
    }

    /// Converts a parsed PLY (`path` names it in errors).
    pub fn from_ply(ply: &Ply, path: &Path) -> Result<Mesh> {
        let vertex = ply.element("vertex").map_err(|e| at(path, e))?;
        let positions = read_positions(path, vertex)?;
        let colors = read_colors(path, vertex)?;
        let object_ids = if vertex.has("object_id") {
            Some(vertex.scalar_i32("object_id").map_err(|e| at(path, e))?)
        } else {
            None
        };
        let faces = read_faces(path, ply, positions.len())?;
        let mesh = Mesh {
            positions,
            faces,
            colors,
            object_ids,
        };
        mesh.validate().map_err(|e| at(path, e))?;
        Ok(mesh)
    }

    pub fn to_ply(&self) -> Result<Ply, String> {
        self.validate()?;
        let n = self.positions.len();
        let mut vertex = xyz_element(&self.positions);
        if let Some(colors) = &self.colors {
            vertex = with_colors(vertex, colors);
        }
        if let Some(ids) = &self.object_ids {
            vertex = vertex.with(Property::scalar("object_id", Column::I32(ids.clone())));
        }
        debug_assert_eq!(vertex.count, n);
        let offsets: Vec<usize> = (0..=self.faces.len()).map(|f| 3 * f).collect();
        let indices: Vec<i32> = self.faces.iter().flatten().map(|&v| v as i32).collect();
        if n > i32::MAX as usize {
            return Err(format!(
                "{n} vertices cannot be indexed by the int vertex_indices of the encoding"
            ));
        }
        let face = Element::new("face", self.faces.len()).with(Property::list(
            "vertex_indices",
            ScalarType::U8,
            offsets,
            Column::I32(indices),
        ));
        Ok(Ply::new(vec![vertex, face]))
    }

    pub fn write_ply(&self, path: &Path) -> Result<()> {
        let ply = self.to_ply().map_err(|e| at(path, e))?;
        Ok(ply.write(path, Format::BinaryLittleEndian)?)
    }
}

fn xyz_element(positions: &[[f32; 3]]) -> Element {
    let axis = |k: usize| Column::F32(positions.iter().map(|p| p[k]).collect());
    Element::new("vertex", positions.len())
        .with(Property::scalar("x", axis(0)))
        .with(Property::scalar("y", axis(1)))
        .with(Property::scalar("z", axis(2)))
}

fn with_colors(vertex: Element, colors: &[[u8; 3]]) -> Element {
    let channel = |k: usize| Column::U8(colors.iter().map(|c| c[k]).collect());
    vertex
        .with(Property::scalar("red", channel(0)))
        .with(Property::scalar("green", channel(1)))
        .with(Property::scalar("blue", channel(2)))
}

impl Points {
    /// Reads a point cloud; colours are required (the Points encoding always has them).
    pub fn read_ply(path: &Path) -> Result<Points> {
        let ply = Ply::read(path)?;
        let vertex = ply.element("vertex").map_err(|e| at(path, e))?;
        let positions = read_positions(path, vertex)?;
        let colors = read_colors(path, vertex)?.with_context(|| {
            format!(
                "{}: points need red, green, blue per vertex",
                path.display()
            )
        })?;
        Ok(Points { positions, colors })
    }

    /// One colour per point and finite positions.
    pub fn validate(&self) -> Result<()> {
        if self.colors.len() != self.positions.len() {
            bail!(
                "{} colours for {} points",
                self.colors.len(),
                self.positions.len()
            );
        }
        if let Some(i) = self
            .positions
            .iter()
            .position(|p| p.iter().any(|v| !v.is_finite()))
        {
            bail!(
                "point {i} has a non-finite coordinate {:?}",
                self.positions[i]
            );
        }
        Ok(())
    }

    pub fn write_ply(&self, path: &Path) -> Result<()> {
        self.validate()
            .with_context(|| format!("{}: cannot write points", path.display()))?;
        let ply = Ply::new(vec![with_colors(
            xyz_element(&self.positions),
            &self.colors,
        )]);
        Ok(ply.write(path, Format::BinaryLittleEndian)?)
    }
}

/// Checks the mesh's object ids against the labels (see the module doc for the rules).
fn check_ids(mesh: &Mesh, labels: &ObjectLabels) -> Result<(), String> {
    let Some(ids) = &mesh.object_ids else {
        if !labels.is_empty() {
            return Err(format!(
                "{} object labels given for a mesh without object ids",
                labels.len()
            ));
        }
        return Ok(());
    };
    for (v, &id) in ids.iter().enumerate() {
        if id == -1 {
            continue;
        }
        if id <= NO_OBJECT as i32 || id >= UNOWNED as i32 {
            return Err(format!(
                "vertex {v} has object id {id}; ids are -1 (none) or 1..=65534"
            ));
        }
        if !labels.contains_key(&(id as u16)) {
            return Err(format!(
                "vertex {v} has object id {id}, which has no label in objects.json"
            ));
        }
    }
    Ok(())
}

/// Reads a Mesh artifact folder: the mesh and its object labels (empty when unannotated).
pub fn read_mesh_artifact(dir: &Path) -> Result<(Mesh, ObjectLabels)> {
    let mesh = Mesh::read_ply(&dir.join(MESH_PLY))?;
    let labels = if dir.join(OBJECTS_JSON).exists() {
        masks::read_objects(dir)?
    } else {
        ObjectLabels::new()
    };
    check_ids(&mesh, &labels).map_err(|e| anyhow::anyhow!("{}: {e}", dir.display()))?;
    Ok((mesh, labels))
}

/// Writes a Mesh artifact folder (`mesh.ply`, plus `objects.json` when the mesh has object ids).
pub fn write_mesh_artifact(dir: &Path, mesh: &Mesh, labels: &ObjectLabels) -> Result<()> {
    check_ids(mesh, labels).map_err(|e| anyhow::anyhow!("{}: {e}", dir.display()))?;
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create folder", dir.display()))?;
    mesh.write_ply(&dir.join(MESH_PLY))?;
    if mesh.object_ids.is_some() {
        masks::write_objects(dir, labels)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artifact::POINTS_PLY;

    fn annotated() -> (Mesh, ObjectLabels) {
        let mesh = Mesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.5],
                [1.0, 1.0, -0.25],
            ],
            faces: vec![[0, 1, 2], [2, 1, 3]],
            colors: Some(vec![[255, 0, 0], [0, 255, 0], [0, 0, 255], [9, 8, 7]]),
            object_ids: Some(vec![-1, 3, 3, 12]),
        };
        (
            mesh,
            [(3, "chair".to_string()), (12, "table".to_string())].into(),
        )
    }

    #[test]
    fn mesh_artifact_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let (mesh, labels) = annotated();
        write_mesh_artifact(dir.path(), &mesh, &labels).unwrap();
        assert_eq!(read_mesh_artifact(dir.path()).unwrap(), (mesh, labels));
    }

    #[test]
    fn unlabelled_object_id_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let (mesh, mut labels) = annotated();
        labels.remove(&12);
        let err = write_mesh_artifact(dir.path(), &mesh, &labels)
            .unwrap_err()
            .to_string();
        assert!(err.contains("object id 12"), "{err}");
    }

    #[test]
    fn points_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let pts = Points {
            positions: vec![[1.5, -2.0, 3.25], [0.0, 0.0, 1e-7]],
            colors: vec![[1, 2, 3], [250, 251, 252]],
        };
        let path = dir.path().join(POINTS_PLY);
        pts.write_ply(&path).unwrap();
        assert_eq!(Points::read_ply(&path).unwrap(), pts);
    }
}
