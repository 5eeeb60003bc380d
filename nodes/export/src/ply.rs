//! Per-component PLY export: the same cleaned triangles as the `.glb`, in the capture's
//! frame (Z up) with 8-bit sRGB colours, written in the Mesh encoding of `objectsplat-core`
//! (binary little-endian, `float x,y,z`, `uchar red,green,blue`, `list uchar int vertex_indices`).

use crate::object::{ExportObject, SrgbColors, clean_mesh, ensure_unique_names};
use anyhow::{Context, Result};
use objectsplat_core::Mesh;
use std::path::{Path, PathBuf};

/// The component as a core [`Mesh`]: degenerate faces and unused vertices removed,
/// colours quantised to 8-bit sRGB.
pub fn component_mesh(object: &ExportObject) -> Result<Mesh> {
    let clean = clean_mesh(object)?;
    let positions = clean
        .vertex_source
        .iter()
        .map(|&v| object.world_position(v as usize))
        .collect();
    let colors = clean
        .vertex_source
        .iter()
        .map(|&v| match &object.colors_srgb {
            SrgbColors::U8(c) => c[v as usize],
            // clean_mesh has checked these are in [0, 1], so the cast cannot saturate.
            SrgbColors::F32(c) => c[v as usize].map(|x| (x * 255.0).round() as u8),
        })
        .collect();
    Ok(Mesh {
        positions,
        faces: clean.faces,
        colors: Some(colors),
        object_ids: None,
    })
}

/// Writes one component to `path`.
pub fn write_component_ply(path: &Path, object: &ExportObject) -> Result<()> {
    let mesh = component_mesh(object)
        .with_context(|| format!("{}: cannot export the component", path.display()))?;
    mesh.write_ply(path)
}

/// Writes `<dir>/<component name>.ply` for every component; returns the paths in input order.
pub fn write_component_plys(dir: &Path, objects: &[ExportObject]) -> Result<Vec<PathBuf>> {
    ensure_unique_names(objects)?;
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create folder", dir.display()))?;
    objects
        .iter()
        .map(|o| {
            let path = dir.join(format!("{}.ply", o.component.name));
            write_component_ply(&path, o)?;
            Ok(path)
        })
        .collect()
}
