//! Completing support surfaces in 3D: closing the holes that resting objects leave in
//! a trained tabletop, so that moving or removing an object shows a surface under it.
//!
//! For every component that `surface_completion` completed (it carries
//! `completion.json`, which says it is a planar support surface), the matching scene
//! member's model is completed:
//!
//! All of it happens in the frame the surface was trained in (a member's model frame is
//! the capture's world), so placements from edits do not matter; resting objects are
//! taken where they were trained too, which is where they hid the surface.
//!
//! 1. **Plane.** RANSAC ([`fit_plane`]) over the centroids of the model's visible faces,
//!    with a tolerance of `planarity_tolerance` × their bounding-box diagonal, refined by
//!    a least-squares fit to the inlier faces (weighted by area and by how parallel they
//!    lie to the plane) and, when points are given, the inlier scene points on the
//!    surface's pixels (they never choose the plane: picked without a depth test, they
//!    include the floor under a table). The surface must be planar: at least
//!    `min_plane_fraction` of its visible face area on the plane. The normal points to
//!    the side most of the surface's frames look from.
//! 2. **Outline.** The inlier faces are rasterized into a grid of square cells on the
//!    plane; a cell is `cell_scale` × the median edge of those faces (so the patch's
//!    triangles are as large as the trained ones and render like them), but at most
//!    `max_resolution` cells along the longer side. Gaps of one cell are closed, and
//!    the convex hull of the largest connected part is the surface's outline. Nothing
//!    is ever added outside it.
//! 3. **Hole.** Every other object whose lowest visible vertices above the outline lie
//!    within `contact_tolerance` × the outline's diagonal rests on the surface; the
//!    shadow of its parts above the plane, dilated by two cells, is its footprint. The
//!    hole is the part of the outline under footprints that the surface's faces do not
//!    cover (fragments under four cells are dropped).
//! 4. **Triangles.** The hole is triangulated by a constrained Delaunay triangulation
//!    ([`triangulate_cells`], `spade`) whose constraints are the hole's boundary, with
//!    interior vertices every `vertex_step` cells, and lifted onto the plane.
//! 5. **Colour.** Each new vertex takes the mean colour of the pixels it projects to in
//!    the surface's frames where the surface's completed mask owns the pixel: the
//!    NS-inpainted `targets/` where `surface_completion` wrote one, the photo elsewhere.
//!    A vertex no frame colours takes the mean colour of the surface's in-plane vertices.
//!    The triangles are opaque, view-independent (SH degree 0 terms only) and appended
//!    to the surface's model, which records them in `model.json` metadata
//!    (`surface_completion_3d`).
//!
//! A surface is skipped, with a reason, when it has no member in the scene, is seen in
//! fewer than two frames, is not planar, has no resting object over an uncovered part,
//! or when resting objects hide more than `max_hole_fraction` of its outline (too
//! little of the surface was seen to complete the rest of it).

pub mod grid;
pub mod triangulate;

use crate::plane::fit_plane;
use crate::surface::{COMPLETION_JSON, RANSAC_ITERATIONS, ScenePoints, surface_points};
use anyhow::{Context, Result, bail};
use glam::{DMat3, DVec2, DVec3};
use grid::{Grid, PlaneFrame};
use objectsplat_core::ComponentFolder;
use objectsplat_core::ComponentKind;
use objectsplat_core::component::{self, OWN};
use objectsplat_core::image::read_rgb8_sized;
use objectsplat_raster::Model;
use objectsplat_raster::model::inverse_sigmoid;
use objectsplat_raster::sh::SH_DC;
use objectsplat_runtime::ParamType;
use objectsplat_scene::Scene;
use objectsplat_scene::surface::visible_faces;
use serde::Serialize;
use std::path::PathBuf;
use triangulate::triangulate_cells;

/// The `model.json` metadata key under which a completed surface records its patch.
pub const METADATA_KEY: &str = "surface_completion_3d";
/// A surface model with fewer visible faces cannot be tested for planarity.
pub const MIN_SURFACE_FACES: usize = 16;
/// Fewest grid cells along the longer side of a surface.
pub const MIN_RESOLUTION: usize = 8;
/// Hole fragments smaller than this many cells are dropped (slivers along seams).
pub const MIN_HOLE_CELLS: usize = 4;
/// Footprints are dilated by this many cells to close the seam around an object's base.
pub const FOOTPRINT_MARGIN_CELLS: usize = 2;
/// Fraction of an object's vertices above the outline allowed below its "lowest" point
/// (floaters under a trained object must not decide whether it rests on the surface).
const LOW_PERCENTILE: f64 = 0.02;

objectsplat_runtime::node_params! {
    /// The parameters of `complete_surfaces`.
    pub struct SurfaceMeshParams {
        /// plane tolerance relative to the surface model's bounding-box diagonal
        planarity_tolerance: f64 = "0.02" as ParamType::float_range(1e-6, 1.0),
        /// fraction of the surface's visible face area that must lie on its plane
        min_plane_fraction: f64 = "0.5" as ParamType::float_range(1e-6, 1.0),
        /// how far an object's base may be from the plane to rest on it, relative to the
        /// surface's diagonal
        contact_tolerance: f64 = "0.03" as ParamType::float_range(1e-6, 1.0),
        /// grid cell side relative to the median edge of the surface's in-plane faces (patch
        /// triangles come out about as large as the trained ones)
        cell_scale: f64 = "0.5" as ParamType::float_range(1e-3, 100.0),
        /// most grid cells along the surface's longer side
        max_resolution: usize = "512" as ParamType::int_range(8, 4096),
        /// interior vertices of a patch every this many cells
        vertex_step: usize = "2" as ParamType::int_range(1, 256),
        /// skip a surface whose hole would take more than this fraction of its outline
        max_hole_fraction: f64 = "0.5" as ParamType::float_range(1e-6, 1.0),
    }
}

/// What happened to one support surface.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SurfaceMeshOutcome {
    pub component: String,
    /// The scene member completed (absent when none matched).
    pub member: Option<String>,
    pub completed: bool,
    pub reason: String,
    pub plane_fraction: Option<f64>,
    /// The objects found resting on the surface.
    pub resting: Vec<String>,
    pub outline_area: f64,
    pub hole_area: f64,
    pub faces_added: usize,
    pub vertices_added: usize,
    /// Frames that gave at least one vertex a colour.
    pub colour_frames: usize,
    /// Vertices no frame coloured (they take the surface's mean colour).
    pub uncoloured_vertices: usize,
}

/// What [`complete_scene_surfaces`] did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SurfaceMeshReport {
    pub surfaces: Vec<SurfaceMeshOutcome>,
    /// Set when no surface was completed: why (the scene is unchanged).
    pub skipped: Option<String>,
}

/// Completes the support surfaces among `components` (collection items: name, folder)
/// in `scene`, in place.
pub fn complete_scene_surfaces(
    scene: &mut Scene,
    components: &[(String, PathBuf)],
    points: Option<ScenePoints<'_>>,
    params: &SurfaceMeshParams,
) -> Result<SurfaceMeshReport> {
    check_params(params)?;
    let mut surfaces = Vec::new();
    for (name, dir) in components {
        if !dir.join(COMPLETION_JSON).is_file() {
            continue;
        }
        let component = ComponentFolder::read_item(name, dir)?;
        if component.info.kind != ComponentKind::Object {
            continue;
        }
        surfaces.push(component);
    }
    if surfaces.is_empty() {
        return Ok(SurfaceMeshReport {
            surfaces: Vec::new(),
            skipped: Some(format!(
                "no support surface: no component carries {COMPLETION_JSON} (surface_completion completed none; its notes say why)"
            )),
        });
    }
    let mut outcomes = Vec::new();
    for surface in &surfaces {
        let outcome = complete_one(scene, surface, points, params)
            .with_context(|| format!("completing support surface {:?}", surface.name))?;
        outcomes.push(outcome);
    }
    let skipped = if outcomes.iter().any(|o| o.completed) {
        None
    } else {
        Some(
            outcomes
                .iter()
                .map(|o| format!("{}: {}", o.component, o.reason))
                .collect::<Vec<_>>()
                .join("; "),
        )
    };
    Ok(SurfaceMeshReport {
        surfaces: outcomes,
        skipped,
    })
}

fn check_params(p: &SurfaceMeshParams) -> Result<()> {
    for (name, v) in [
        ("planarity_tolerance", p.planarity_tolerance),
        ("min_plane_fraction", p.min_plane_fraction),
        ("contact_tolerance", p.contact_tolerance),
        ("max_hole_fraction", p.max_hole_fraction),
    ] {
        if !(v.is_finite() && v > 0.0 && v <= 1.0) {
            bail!("{name} = {v} must be in (0, 1]");
        }
    }
    if !(p.cell_scale.is_finite() && p.cell_scale > 0.0 && p.cell_scale <= 100.0) {
        bail!("cell_scale = {} must be in (0, 100]", p.cell_scale);
    }
    if !(8..=4096).contains(&p.max_resolution) {
        bail!("max_resolution = {} must be in 8..=4096", p.max_resolution);
    }
    if !(1..=256).contains(&p.vertex_step) {
        bail!("vertex_step = {} must be in 1..=256", p.vertex_step);
    }
    Ok(())
}

/// One visible face of a model: corners, centroid and area.
struct Face {
    corners: [DVec3; 3],
    centroid: DVec3,
    area: f64,
}

fn faces_of(model: &Model<f32>) -> Vec<Face> {
    visible_faces(model)
        .iter()
        .map(|f| {
            let corners = f.map(|v| DVec3::from_array(model.vertices[v as usize].map(f64::from)));
            Face {
                corners,
                centroid: (corners[0] + corners[1] + corners[2]) / 3.0,
                area: 0.5
                    * (corners[1] - corners[0])
                        .cross(corners[2] - corners[0])
                        .length(),
            }
        })
        .collect()
}

fn skip(outcome: &mut SurfaceMeshOutcome, reason: String) -> Result<SurfaceMeshOutcome> {
    outcome.reason = reason;
    outcome.completed = false;
    Ok(outcome.clone())
}

fn complete_one(
    scene: &mut Scene,
    surface: &ComponentFolder,
    points: Option<ScenePoints<'_>>,
    params: &SurfaceMeshParams,
) -> Result<SurfaceMeshOutcome> {
    let mut outcome = SurfaceMeshOutcome {
        component: surface.name.clone(),
        ..Default::default()
    };
    // The member trained from this component (a duplicate keeps its original's source;
    // the original is the one named like it).
    let candidates: Vec<usize> = (0..scene.objects.len())
        .filter(|&i| scene.objects[i].entry.source == surface.name)
        .collect();
    let Some(&member) = candidates
        .iter()
        .find(|&&i| scene.objects[i].entry.name == surface.name)
        .or(candidates.first())
    else {
        return skip(
            &mut outcome,
            "no scene member was trained from this component".into(),
        );
    };
    outcome.member = Some(scene.objects[member].entry.name.clone());

    let views = views_with_surface(surface)?;
    if views < 2 {
        return skip(
            &mut outcome,
            format!(
                "seen in {views} view{}: at least two are needed to tell the surface from what rests on it",
                if views == 1 { "" } else { "s" }
            ),
        );
    }

    let model = &scene.objects[member].model;
    let faces = faces_of(model);
    if faces.len() < MIN_SURFACE_FACES {
        return skip(
            &mut outcome,
            format!(
                "the trained surface has {} visible faces (< {MIN_SURFACE_FACES}); too few to fit its plane",
                faces.len()
            ),
        );
    }
    // The plane and its tolerance come from the trained faces alone: the scene points
    // on the surface's pixels are chosen without a depth test, so they include what the
    // surface hides (the floor under a table, often the larger plane); they only join
    // the refinement, where they are within the tolerance of the faces' plane.
    let centroids: Vec<DVec3> = faces.iter().map(|f| f.centroid).collect();
    let surface_points = match points {
        Some(points) => surface_points(surface, points)?,
        None => Vec::new(),
    };
    let Some(fit) = fit_plane(&centroids, params.planarity_tolerance, RANSAC_ITERATIONS) else {
        return skip(
            &mut outcome,
            "the trained surface's faces are collinear; no plane fits them".into(),
        );
    };
    let tolerance = fit.tolerance;
    let (normal, offset) = refine_plane(&faces, &surface_points, fit.normal, fit.offset, tolerance);
    let total_area: f64 = faces.iter().map(|f| f.area).sum();
    let inliers: Vec<&Face> = faces
        .iter()
        .filter(|f| (normal.dot(f.centroid) - offset).abs() <= tolerance)
        .collect();
    let fraction = inliers.iter().map(|f| f.area).sum::<f64>() / total_area.max(f64::MIN_POSITIVE);
    outcome.plane_fraction = Some(fraction);
    if fraction < params.min_plane_fraction {
        return skip(
            &mut outcome,
            format!(
                "not planar: {:.0}% of its visible area lies within {tolerance:.3} of its best plane (need {:.0}%)",
                fraction * 100.0,
                params.min_plane_fraction * 100.0
            ),
        );
    }
    let centre = inliers.iter().map(|f| f.centroid * f.area).sum::<DVec3>()
        / inliers.iter().map(|f| f.area).sum::<f64>();
    let origin = centre - normal * (normal.dot(centre) - offset);
    let up = camera_side(surface, origin, normal);
    let plane = PlaneFrame::new(origin, normal * up);

    // The outline: inlier faces on a grid, gaps closed, largest part, convex hull.
    let projected: Vec<[DVec2; 3]> = inliers
        .iter()
        .map(|f| f.corners.map(|c| plane.project(c).0))
        .collect();
    let (lo, hi) = projected.iter().flatten().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), q| (lo.min(*q), hi.max(*q)),
    );
    let extent = (hi - lo).max_element();
    let mut edges: Vec<f64> = projected
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[(k + 1) % 3] - t[k]).length()))
        .collect();
    edges.sort_by(f64::total_cmp);
    let median_edge = edges[edges.len() / 2];
    let resolution = ((extent / (params.cell_scale * median_edge)).ceil() as usize)
        .clamp(MIN_RESOLUTION, params.max_resolution);
    let grid = Grid::covering(lo, hi, resolution, FOOTPRINT_MARGIN_CELLS + 2);
    let mut covered = vec![false; grid.len()];
    for t in &projected {
        grid.fill_triangle(t.map(|q| grid.to_cells(q)), &mut covered);
    }
    let covered = grid.erode(&grid.dilate(&covered, 1), 1);
    let Some(largest) = grid.components(&covered).into_iter().max_by_key(Vec::len) else {
        return skip(&mut outcome, "the surface's plane holds no faces".into());
    };
    let outline = grid.convex_hull_cells(&largest);
    let cell_area = grid.cell * grid.cell;
    let outline_cells = outline.iter().filter(|&&o| o).count();
    outcome.outline_area = outline_cells as f64 * cell_area;
    let outline_diagonal = (hi - lo).length();
    let contact = params.contact_tolerance * outline_diagonal;

    // Footprints of the objects resting on the surface.
    let mut footprint = vec![false; grid.len()];
    for (index, other) in scene.objects.iter().enumerate() {
        if index == member
            || other.entry.kind != ComponentKind::Object
            || other.entry.source == surface.name
        {
            continue;
        }
        let shadow = resting_shadow(&other.model, &plane, &grid, &outline, contact);
        if let Some(shadow) = shadow {
            outcome.resting.push(other.entry.name.clone());
            for (f, s) in footprint.iter_mut().zip(shadow) {
                *f |= s;
            }
        }
    }
    if outcome.resting.is_empty() {
        return skip(
            &mut outcome,
            format!(
                "no object rests on the surface: nothing can have hidden part of it ({:.0}% of its visible area on its plane)",
                fraction * 100.0
            ),
        );
    }
    let footprint = grid.dilate(&footprint, FOOTPRINT_MARGIN_CELLS);
    let raw_hole: Vec<bool> = (0..grid.len())
        .map(|k| footprint[k] && outline[k] && !covered[k])
        .collect();
    let mut hole = vec![false; grid.len()];
    for part in grid.components(&raw_hole) {
        if part.len() >= MIN_HOLE_CELLS {
            for k in part {
                hole[k] = true;
            }
        }
    }
    let hole_cells = hole.iter().filter(|&&h| h).count();
    outcome.hole_area = hole_cells as f64 * cell_area;
    if hole_cells == 0 {
        let why = format!(
            "nothing to fill: the surface covers the footprints of {}",
            outcome.resting.join(", ")
        );
        return skip(&mut outcome, why);
    }
    let hole_fraction = hole_cells as f64 / outline_cells.max(1) as f64;
    if hole_fraction > params.max_hole_fraction {
        return skip(
            &mut outcome,
            format!(
                "objects cover {:.0}% of the surface's outline (more than {:.0}%): too little of it was seen to complete the rest",
                hole_fraction * 100.0,
                params.max_hole_fraction * 100.0
            ),
        );
    }

    let cells = triangulate_cells(&grid, &hole, params.vertex_step)?;
    let positions: Vec<DVec3> = cells
        .vertices
        .iter()
        .map(|&c| plane.lift(grid.to_plane(c)))
        .collect();
    let colours = vertex_colours(surface, &positions, &mut outcome)?;
    let fallback = mean_colour(model, &inliers_vertices(model, normal, offset, tolerance));
    let colours: Vec<[f64; 3]> = colours.into_iter().map(|c| c.unwrap_or(fallback)).collect();

    let model = &mut scene.objects[member].model;
    let first_vertex = model.vertices.len();
    let first_face = model.faces.len();
    if first_vertex + positions.len() > u32::MAX as usize {
        bail!("the completed model would have more vertices than u32 indices can address");
    }
    let opaque = inverse_sigmoid(1.0) as f32;
    for (p, c) in positions.iter().zip(&colours) {
        model.vertices.push(p.to_array().map(|v| v as f32));
        let mut sh = [[0.0f32; 3]; objectsplat_raster::SH_COEFFS];
        sh[0] = c.map(|v| ((v - 0.5) / SH_DC) as f32);
        if !model.flat_dc.is_empty() {
            model.flat_dc.push(sh[0]);
        }
        model.sh.push(sh);
        model.opacity_logits.push(opaque);
    }
    // `first_vertex` fits in u32: checked above.
    let base = first_vertex as u32;
    model
        .faces
        .extend(cells.faces.iter().map(|f| f.map(|v| v + base)));
    if !model.face_sigma.is_empty() {
        let sigma = model.sigma;
        model
            .face_sigma
            .extend(std::iter::repeat_n(sigma, cells.faces.len()));
    }
    model.metadata.insert(
        METADATA_KEY.into(),
        serde_json::json!({
            "first_vertex": first_vertex,
            "first_face": first_face,
            "faces": cells.faces.len(),
            "plane_normal": plane.normal.to_array(),
            "plane_origin": plane.origin.to_array(),
            "hole_area": outcome.hole_area,
            "resting": outcome.resting,
        }),
    );
    model
        .validate()
        .context("the completed surface model is invalid")?;
    outcome.faces_added = cells.faces.len();
    outcome.vertices_added = positions.len();
    outcome.completed = true;
    outcome.reason = format!(
        "completed {:.4} m² under {} with {} triangles ({:.0}% of its visible area on the plane)",
        outcome.hole_area,
        outcome.resting.join(", "),
        outcome.faces_added,
        fraction * 100.0
    );
    Ok(outcome)
}

/// Frames in which the surface owns at least one pixel.
fn views_with_surface(surface: &ComponentFolder) -> Result<usize> {
    let mut views = 0;
    for frame in &surface.frames.frames {
        if surface.load_mask(frame)?.contains(&OWN) {
            views += 1;
        }
    }
    Ok(views)
}

/// Weighted least-squares plane through the faces and points within `tolerance` of
/// the RANSAC plane: the smallest-variance direction of their centroids (and the
/// points), found by power iteration on `trace·I − covariance` from the RANSAC normal.
fn refine_plane(
    faces: &[Face],
    points: &[DVec3],
    normal: DVec3,
    offset: f64,
    tolerance: f64,
) -> (DVec3, f64) {
    // Faces across the plane (a rim, a leg's top) say little about its tilt: each face
    // weighs its area times how parallel it is to the RANSAC plane.
    let mut weighted: Vec<(DVec3, f64)> = faces
        .iter()
        .filter(|f| (normal.dot(f.centroid) - offset).abs() <= tolerance && f.area > 0.0)
        .map(|f| {
            let n = (f.corners[1] - f.corners[0]).cross(f.corners[2] - f.corners[0]);
            (f.centroid, f.area * n.normalize_or_zero().dot(normal).abs())
        })
        .filter(|(_, w)| *w > 0.0)
        .collect();
    // A point weighs as much as a typical face.
    let mut areas: Vec<f64> = weighted.iter().map(|(_, w)| *w).collect();
    areas.sort_by(f64::total_cmp);
    let point_weight = areas.get(areas.len() / 2).copied().unwrap_or(0.0);
    weighted.extend(
        points
            .iter()
            .filter(|p| (normal.dot(**p) - offset).abs() <= tolerance)
            .map(|p| (*p, point_weight)),
    );
    let weight: f64 = weighted.iter().map(|(_, w)| w).sum();
    if weighted.len() < 3 || weight <= 0.0 {
        return (normal, offset);
    }
    let mean = weighted.iter().map(|(c, w)| *c * *w).sum::<DVec3>() / weight;
    let mut cov = DMat3::ZERO;
    for (c, w) in &weighted {
        let d = *c - mean;
        cov += DMat3::from_cols(d * d.x, d * d.y, d * d.z) * *w;
    }
    let cov = cov * (1.0 / weight);
    let trace = cov.x_axis.x + cov.y_axis.y + cov.z_axis.z;
    let shifted = DMat3::from_diagonal(DVec3::splat(trace)) - cov;
    let mut n = normal;
    for _ in 0..64 {
        let next = shifted * n;
        if !next.is_finite() || next.length_squared() == 0.0 {
            return (normal, offset);
        }
        n = next.normalize();
    }
    (n, n.dot(mean))
}

/// +1 when most of the surface's frames look at the plane from the side `normal`
/// points to, −1 otherwise.
fn camera_side(surface: &ComponentFolder, origin: DVec3, normal: DVec3) -> f64 {
    let balance: i64 = surface
        .frames
        .frames
        .iter()
        .map(|f| {
            if normal.dot(f.camera().center() - origin) >= 0.0 {
                1
            } else {
                -1
            }
        })
        .sum();
    if balance >= 0 { 1.0 } else { -1.0 }
}

/// The grid cells under an object resting on the surface: the shadow of its faces above
/// `-contact`, when its low vertices over the outline are within `contact` of the plane.
fn resting_shadow(
    model: &Model<f32>,
    plane: &PlaneFrame,
    grid: &Grid,
    outline: &[bool],
    contact: f64,
) -> Option<Vec<bool>> {
    let faces = visible_faces(model);
    let mut used = vec![false; model.vertices.len()];
    for f in &faces {
        for &v in f {
            used[v as usize] = true;
        }
    }
    let projected: Vec<(DVec2, f64)> = model
        .vertices
        .iter()
        .map(|p| plane.project(DVec3::from_array(p.map(f64::from))))
        .collect();
    let mut heights: Vec<f64> = projected
        .iter()
        .zip(&used)
        .filter(|((q, _), used)| {
            **used && grid.cell_at(grid.to_cells(*q)).is_some_and(|k| outline[k])
        })
        .map(|((_, h), _)| *h)
        .collect();
    if heights.is_empty() {
        return None;
    }
    heights.sort_by(f64::total_cmp);
    let low = heights[((heights.len() - 1) as f64 * LOW_PERCENTILE) as usize];
    if low.abs() > contact {
        return None;
    }
    let mut shadow = vec![false; grid.len()];
    for f in &faces {
        let corners = f.map(|v| projected[v as usize]);
        if corners.iter().any(|(_, h)| *h < -contact) {
            continue;
        }
        grid.fill_triangle(corners.map(|(q, _)| grid.to_cells(q)), &mut shadow);
    }
    Some(shadow)
}

/// Mean colour (sRGB in [0, 1]) of each point over the surface's frames where the
/// surface's (completed) mask owns the pixel it projects to: the inpainted target
/// where `surface_completion` wrote one, the photo elsewhere. `None`: no frame saw it.
fn vertex_colours(
    surface: &ComponentFolder,
    positions: &[DVec3],
    outcome: &mut SurfaceMeshOutcome,
) -> Result<Vec<Option<[f64; 3]>>> {
    let mut sums = vec![[0.0f64; 3]; positions.len()];
    let mut counts = vec![0u32; positions.len()];
    for frame in &surface.frames.frames {
        let camera = frame.camera();
        let (w, h) = (frame.camera.width as usize, frame.camera.height as usize);
        let pixels: Vec<Option<usize>> = positions
            .iter()
            .map(|&p| {
                let (u, v, _) = camera.project(p)?;
                (u >= 0.0 && v >= 0.0 && u < w as f64 && v < h as f64)
                    .then(|| v as usize * w + u as usize)
            })
            .collect();
        if pixels.iter().all(Option::is_none) {
            continue;
        }
        let mask = surface.load_mask(frame)?;
        if !pixels.iter().flatten().any(|&p| mask[p] == OWN) {
            continue;
        }
        let target = component::target_path(&surface.dir, frame);
        let source = if target.is_file() {
            target
        } else {
            surface.frames.image_path(frame)
        };
        let rgb = read_rgb8_sized(&source, frame.camera.width, frame.camera.height)?;
        let mut used = false;
        for (k, pixel) in pixels.iter().enumerate() {
            if let Some(p) = *pixel
                && mask[p] == OWN
            {
                for c in 0..3 {
                    sums[k][c] += f64::from(rgb[p * 3 + c]) / 255.0;
                }
                counts[k] += 1;
                used = true;
            }
        }
        outcome.colour_frames += usize::from(used);
    }
    outcome.uncoloured_vertices = counts.iter().filter(|&&n| n == 0).count();
    Ok(sums
        .iter()
        .zip(&counts)
        .map(|(s, &n)| (n > 0).then(|| s.map(|v| v / f64::from(n))))
        .collect())
}

/// Vertices of `model` within `tolerance` of the plane `normal · p = offset`.
fn inliers_vertices(model: &Model<f32>, normal: DVec3, offset: f64, tolerance: f64) -> Vec<usize> {
    (0..model.vertices.len())
        .filter(|&v| {
            let p = DVec3::from_array(model.vertices[v].map(f64::from));
            (normal.dot(p) - offset).abs() <= tolerance
        })
        .collect()
}

/// Mean display colour (the flat colour, sRGB in [0, 1]) of the given vertices; mid
/// grey for none.
fn mean_colour(model: &Model<f32>, vertices: &[usize]) -> [f64; 3] {
    if vertices.is_empty() {
        return [0.5; 3];
    }
    let mut sum = [0.0; 3];
    for &v in vertices {
        for (c, s) in sum.iter_mut().enumerate() {
            *s += (0.5 + SH_DC * f64::from(model.flat_dc(v)[c])).clamp(0.0, 1.0);
        }
    }
    sum.map(|s| s / vertices.len() as f64)
}
