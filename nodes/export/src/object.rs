//! The export input: one component's mesh with sRGB vertex colours, and its validation.

use anyhow::{Result, bail, ensure};
use objectsplat_core::ComponentInfo;
use objectsplat_core::geometry::triangle_cross;
use objectsplat_scene::Placement;

/// Per-vertex colours as stored by the capture: sRGB-encoded.
#[derive(Debug, Clone, PartialEq)]
pub enum SrgbColors {
    U8(Vec<[u8; 3]>),
    /// Values in [0, 1].
    F32(Vec<[f32; 3]>),
}

impl SrgbColors {
    pub fn len(&self) -> usize {
        match self {
            SrgbColors::U8(c) => c.len(),
            SrgbColors::F32(c) => c.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// View-dependent colour: spherical-harmonics coefficients per vertex (the 3DGS
/// basis, as the renderer evaluates them): the colour seen along the unit
/// direction `d` from the eye to a vertex, in the model frame, is
/// `max(0, 0.5 + Σ_k Y_k(d)·c_k)` per sRGB channel, `k < (degree + 1)²`.
#[derive(Debug, Clone, PartialEq)]
pub struct ShColors {
    /// 1..=3 (degree 0 is the view-independent colour alone).
    pub degree: u32,
    /// `(degree + 1)²` coefficients `[r, g, b]` per vertex, vertex after vertex.
    pub coefficients: Vec<[f32; 3]>,
}

impl ShColors {
    /// Coefficients per vertex.
    pub fn per_vertex(&self) -> usize {
        ((self.degree + 1) * (self.degree + 1)) as usize
    }
}

/// One component of the scene to export (an object or the background).
#[derive(Debug, Clone, PartialEq)]
pub struct ExportObject {
    pub component: ComponentInfo,
    /// Model coordinates in metres; [`ExportObject::placement`] maps them into the
    /// capture's world frame (Z up).
    pub positions: Vec<[f32; 3]>,
    pub faces: Vec<[u32; 3]>,
    pub colors_srgb: SrgbColors,
    /// The object's pivot and world transform: the `.glb` node carries the transform
    /// and its vertices are `position − pivot`. [`Placement::IDENTITY`] (the
    /// constructors' default) writes world coordinates under an untransformed node.
    pub placement: Placement,
    /// The view-dependent colour beside `colors_srgb` (its DC term), when there is one.
    pub sh: Option<ShColors>,
}

impl ExportObject {
    pub fn object(
        id: u16,
        label: &str,
        positions: Vec<[f32; 3]>,
        faces: Vec<[u32; 3]>,
        colors_srgb: SrgbColors,
    ) -> Self {
        ExportObject {
            component: ComponentInfo::object(id, label),
            positions,
            faces,
            colors_srgb,
            placement: Placement::IDENTITY,
            sh: None,
        }
    }

    pub fn background(
        positions: Vec<[f32; 3]>,
        faces: Vec<[u32; 3]>,
        colors_srgb: SrgbColors,
    ) -> Self {
        ExportObject {
            component: ComponentInfo::background(),
            positions,
            faces,
            colors_srgb,
            placement: Placement::IDENTITY,
            sh: None,
        }
    }

    /// The same object with view-dependent colour.
    pub fn with_sh(self, sh: ShColors) -> Self {
        ExportObject {
            sh: Some(sh),
            ..self
        }
    }

    /// The same object with `placement` (positions stay in the model frame).
    pub fn placed(self, placement: Placement) -> Self {
        ExportObject { placement, ..self }
    }

    /// Vertex `v` in the capture's world frame.
    pub fn world_position(&self, v: usize) -> [f32; 3] {
        let p = self.positions[v];
        if self.placement.is_unmoved() {
            // Exact: the PLY of an object that was not moved keeps the input's bits.
            return p;
        }
        self.placement.world(p.map(f64::from)).map(|x| x as f32)
    }

    /// Vertex `v` in the node's frame (relative to the pivot), as the `.glb` stores it.
    pub fn local_position(&self, v: usize) -> [f32; 3] {
        let p = self.positions[v];
        if self.placement.pivot == [0.0; 3] {
            return p;
        }
        self.placement.local(p.map(f64::from)).map(|x| x as f32)
    }
}

/// A component's faces after validation, re-indexed onto the vertices they use.
pub(crate) struct CleanMesh {
    /// For each output vertex, its index in the input.
    pub vertex_source: Vec<u32>,
    pub faces: Vec<[u32; 3]>,
    pub degenerate_dropped: usize,
}

/// Rejects non-finite or out-of-range data (naming the component and element), drops
/// degenerate faces and the vertices no kept face uses.
pub(crate) fn clean_mesh(object: &ExportObject) -> Result<CleanMesh> {
    let name = &object.component.name;
    let n = object.positions.len();
    ensure!(
        object.colors_srgb.len() == n,
        "{name}: {} colours for {n} vertices",
        object.colors_srgb.len()
    );
    // glTF forbids the index type's maximum value as an index (primitive restart).
    ensure!(
        (n as u64) < u32::MAX as u64,
        "{name}: {n} vertices exceed the u32 index range"
    );
    let placement = &object.placement;
    ensure!(
        placement
            .pivot
            .iter()
            .chain(&placement.translation)
            .chain(&placement.rotation)
            .all(|v| v.is_finite()),
        "{name}: placement {placement:?} has a non-finite value"
    );
    ensure!(
        placement.scale.is_finite() && placement.scale > 0.0,
        "{name}: placement scale {} must be finite and positive",
        placement.scale
    );
    ensure!(
        placement.rotation.iter().any(|&v| v != 0.0),
        "{name}: placement rotation is the zero quaternion"
    );
    if let Some(i) = object
        .positions
        .iter()
        .position(|p| p.iter().any(|v| !v.is_finite()))
    {
        bail!(
            "{name}: vertex {i} has a non-finite coordinate {:?}",
            object.positions[i]
        );
    }
    if let SrgbColors::F32(colors) = &object.colors_srgb
        && let Some(i) = colors
            .iter()
            .position(|c| c.iter().any(|v| !(0.0..=1.0).contains(v)))
    {
        bail!(
            "{name}: vertex {i} colour {:?} is not in [0, 1] (NaN or out of range)",
            colors[i]
        );
    }
    if let Some(sh) = &object.sh {
        ensure!(
            (1..=3).contains(&sh.degree),
            "{name}: SH degree {} is not 1, 2 or 3",
            sh.degree
        );
        ensure!(
            sh.coefficients.len() == n * sh.per_vertex(),
            "{name}: {} SH coefficients for {n} vertices of degree {} ({} each)",
            sh.coefficients.len(),
            sh.degree,
            sh.per_vertex()
        );
        if let Some(i) = sh
            .coefficients
            .iter()
            .position(|c| c.iter().any(|v| !v.is_finite()))
        {
            bail!(
                "{name}: vertex {} has a non-finite SH coefficient {:?}",
                i / sh.per_vertex(),
                sh.coefficients[i]
            );
        }
    }
    if let Some((i, f)) = object
        .faces
        .iter()
        .enumerate()
        .find(|(_, f)| f.iter().any(|&v| v as usize >= n))
    {
        bail!("{name}: face {i} refers to vertex {f:?} but there are only {n} vertices");
    }

    let mut faces: Vec<[u32; 3]> = object
        .faces
        .iter()
        .filter(|f| !is_degenerate(f, &object.positions))
        .copied()
        .collect();
    let degenerate_dropped = object.faces.len() - faces.len();

    // Compact so every written vertex is drawn: bounds then describe the visible object.
    const UNSEEN: u32 = u32::MAX;
    let mut new_index = vec![UNSEEN; n];
    let mut vertex_source = Vec::new();
    for face in &mut faces {
        for v in face.iter_mut() {
            let old = *v as usize;
            if new_index[old] == UNSEEN {
                // Fits in u32: vertex_source.len() < n < u32::MAX, checked above.
                new_index[old] = vertex_source.len() as u32;
                vertex_source.push(*v);
            }
            *v = new_index[old];
        }
    }
    Ok(CleanMesh {
        vertex_source,
        faces,
        degenerate_dropped,
    })
}

/// Every component at most once: its name becomes a file and a glTF node name.
pub fn ensure_unique_names(objects: &[ExportObject]) -> Result<()> {
    let mut names = std::collections::HashSet::new();
    for o in objects {
        ensure!(
            names.insert(o.component.name.as_str()),
            "component {} appears twice in the export",
            o.component.name
        );
    }
    Ok(())
}

/// A face is degenerate when two corners share an index or its corners are exactly collinear.
fn is_degenerate(face: &[u32; 3], positions: &[[f32; 3]]) -> bool {
    let [a, b, c] = *face;
    if a == b || b == c || a == c {
        return true;
    }
    let p = |i: u32| positions[i as usize].map(f64::from);
    triangle_cross(&[p(a), p(b), p(c)])
        .iter()
        .all(|&x| x == 0.0)
}
