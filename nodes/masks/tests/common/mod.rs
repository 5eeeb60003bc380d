//! Shared fixtures for the integration tests: simple scenes with known geometry and
//! brute-force ray casting as the independent oracle.
#![allow(dead_code)]

use glam::DVec3;
use objectsplat_core::{Camera, Mesh, ObjectLabels};

/// An axis-aligned box given by its min and max corners, labelled.
#[derive(Debug, Clone, Copy)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
    pub id: i32,
}

/// Triangulates boxes into one annotated mesh (12 triangles each, vertices per box).
pub fn boxes_mesh(boxes: &[Aabb]) -> Mesh {
    let mut mesh = Mesh {
        object_ids: Some(vec![]),
        ..Mesh::default()
    };
    for b in boxes {
        let base = mesh.positions.len() as u32;
        for k in 0..8 {
            let pick = |bit: usize, lo: f64, hi: f64| if k >> bit & 1 == 1 { hi } else { lo };
            mesh.positions.push([
                pick(0, b.min.x, b.max.x) as f32,
                pick(1, b.min.y, b.max.y) as f32,
                pick(2, b.min.z, b.max.z) as f32,
            ]);
            mesh.object_ids.as_mut().unwrap().push(b.id);
        }
        // Corner index = x + 2y + 4z; each face as two triangles.
        let quads = [
            [0, 2, 6, 4],
            [1, 5, 7, 3],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 1, 3, 2],
            [4, 6, 7, 5],
        ];
        for q in quads {
            mesh.faces.push([base + q[0], base + q[1], base + q[2]]);
            mesh.faces.push([base + q[0], base + q[2], base + q[3]]);
        }
    }
    mesh
}

/// Distance along the ray to the box (slab method), if it is hit in front.
pub fn ray_box(origin: DVec3, dir: DVec3, b: &Aabb) -> Option<f64> {
    let inv = DVec3::ONE / dir;
    let t0 = (b.min - origin) * inv;
    let t1 = (b.max - origin) * inv;
    let near = t0.min(t1).max_element();
    let far = t0.max(t1).min_element();
    (far >= near.max(0.0)).then_some(if near > 0.0 { near } else { far })
}

/// The id of the nearest box along the ray, and whether the answer is certain
/// (the ray does not pass within `eps` of any box's silhouette, the two nearest
/// hits are not nearly tied).
pub fn cast(origin: DVec3, dir: DVec3, boxes: &[Aabb]) -> (Option<i32>, bool) {
    let mut hits: Vec<(f64, i32)> = boxes
        .iter()
        .filter_map(|b| ray_box(origin, dir, b).map(|t| (t, b.id)))
        .collect();
    hits.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Near a silhouette a slightly shrunken/grown box disagrees about the hit.
    let eps = 1e-4;
    let certain = boxes.iter().all(|b| {
        let grown = Aabb {
            min: b.min - DVec3::splat(eps),
            max: b.max + DVec3::splat(eps),
            id: b.id,
        };
        let shrunk = Aabb {
            min: b.min + DVec3::splat(eps),
            max: b.max - DVec3::splat(eps),
            id: b.id,
        };
        ray_box(origin, dir, &grown).is_some() == ray_box(origin, dir, &shrunk).is_some()
    }) && (hits.len() < 2 || hits[1].0 - hits[0].0 > 1e-6);
    (hits.first().map(|h| h.1), certain)
}

pub fn labels(pairs: &[(u16, &str)]) -> ObjectLabels {
    pairs.iter().map(|(id, l)| (*id, l.to_string())).collect()
}

pub fn camera(width: u32, height: u32, eye: DVec3, target: DVec3) -> Camera {
    let f = width as f64 * 0.8;
    Camera::look_at(width, height, f, f, eye, target, DVec3::Z)
}
