//! Builds the annotated triangle mesh of the room, one labelled object per part.
//!
//! Every face carries its material and its outward normal; every vertex carries the
//! id of the object it belongs to (objects never share vertices).

use super::texture::Material;
use glam::DVec3;
use objectsplat_core::{Mesh, ObjectLabels};

#[derive(Debug, Default)]
pub struct MeshBuilder {
    pub positions: Vec<[f32; 3]>,
    pub faces: Vec<[u32; 3]>,
    pub object_ids: Vec<i32>,
    pub face_material: Vec<Material>,
    pub face_normal: Vec<DVec3>,
    pub labels: ObjectLabels,
}

impl MeshBuilder {
    /// Starts a new object with `label`; returns its id (1, 2, …).
    pub fn object(&mut self, label: &str) -> i32 {
        let id = self.labels.len() as u16 + 1;
        self.labels.insert(id, label.to_string());
        id as i32
    }

    fn vertex(&mut self, p: DVec3, id: i32) -> u32 {
        self.positions.push([p.x as f32, p.y as f32, p.z as f32]);
        self.object_ids.push(id);
        (self.positions.len() - 1) as u32
    }

    fn triangle(&mut self, v: [u32; 3], material: Material, normal: DVec3) {
        self.faces.push(v);
        self.face_material.push(material);
        self.face_normal.push(normal);
    }

    /// A parallelogram `origin + s·u + t·v` (s, t ∈ [0, 1]) split into `nu × nv` cells,
    /// facing `u × v`.
    pub fn grid(
        &mut self,
        id: i32,
        material: Material,
        origin: DVec3,
        (u, v): (DVec3, DVec3),
        (nu, nv): (usize, usize),
    ) {
        let normal = u.cross(v).normalize();
        let base = self.positions.len() as u32;
        for j in 0..=nv {
            for i in 0..=nu {
                self.vertex(
                    origin + u * (i as f64 / nu as f64) + v * (j as f64 / nv as f64),
                    id,
                );
            }
        }
        let row = nu as u32 + 1;
        for j in 0..nv as u32 {
            for i in 0..nu as u32 {
                let a = base + j * row + i;
                self.triangle([a, a + 1, a + row + 1], material, normal);
                self.triangle([a, a + row + 1, a + row], material, normal);
            }
        }
    }

    /// A closed box centred at `center` with half sizes `half`, turned by `yaw` about z.
    pub fn cuboid(
        &mut self,
        id: i32,
        material: Material,
        center: DVec3,
        half: DVec3,
        yaw: f64,
        cell: f64,
    ) {
        let (s, c) = yaw.sin_cos();
        let ax = DVec3::new(c, s, 0.0) * half.x;
        let ay = DVec3::new(-s, c, 0.0) * half.y;
        let az = DVec3::Z * half.z;
        let cells = |len: f64| ((len / cell).ceil() as usize).max(1);
        // Each face: origin corner and two edge vectors whose cross product points outward.
        let sides = [
            (center + ax - ay - az, ay * 2.0, az * 2.0),
            (center - ax + ay - az, -ay * 2.0, az * 2.0),
            (center + ay + ax - az, -ax * 2.0, az * 2.0),
            (center - ay - ax - az, ax * 2.0, az * 2.0),
            (center + az - ax - ay, ax * 2.0, ay * 2.0),
            (center - az - ax + ay, ax * 2.0, -ay * 2.0),
        ];
        for (origin, u, v) in sides {
            self.grid(
                id,
                material,
                origin,
                (u, v),
                (cells(u.length()), cells(v.length())),
            );
        }
    }

    /// A closed upright cylinder standing on `base` (bottom centre).
    pub fn cylinder(
        &mut self,
        id: i32,
        material: Material,
        base: DVec3,
        radius: f64,
        height: f64,
        segments: usize,
    ) {
        let ring = |k: usize, z: f64| {
            let a = std::f64::consts::TAU * k as f64 / segments as f64;
            base + DVec3::new(radius * a.cos(), radius * a.sin(), z)
        };
        let stacks = ((height / 0.05).ceil() as usize).max(1);
        for k in 0..segments {
            let mid = std::f64::consts::TAU * (k as f64 + 0.5) / segments as f64;
            let normal = DVec3::new(mid.cos(), mid.sin(), 0.0);
            for j in 0..stacks {
                let (z0, z1) = (
                    height * j as f64 / stacks as f64,
                    height * (j + 1) as f64 / stacks as f64,
                );
                let a = self.vertex(ring(k, z0), id);
                let b = self.vertex(ring(k + 1, z0), id);
                let c = self.vertex(ring(k + 1, z1), id);
                let d = self.vertex(ring(k, z1), id);
                self.triangle([a, b, c], material, normal);
                self.triangle([a, c, d], material, normal);
            }
        }
        for (z, normal) in [(height, DVec3::Z), (0.0, -DVec3::Z)] {
            let centre = self.vertex(base + DVec3::Z * z, id);
            for k in 0..segments {
                let a = self.vertex(ring(k, z), id);
                let b = self.vertex(ring(k + 1, z), id);
                let tri = if normal.z > 0.0 {
                    [centre, a, b]
                } else {
                    [centre, b, a]
                };
                self.triangle(tri, material, normal);
            }
        }
    }

    /// A UV sphere.
    pub fn sphere(
        &mut self,
        id: i32,
        material: Material,
        center: DVec3,
        radius: f64,
        rings: usize,
        segments: usize,
    ) {
        let point = |i: usize, k: usize| {
            let polar = std::f64::consts::PI * i as f64 / rings as f64;
            let az = std::f64::consts::TAU * k as f64 / segments as f64;
            center
                + radius * DVec3::new(polar.sin() * az.cos(), polar.sin() * az.sin(), polar.cos())
        };
        for i in 0..rings {
            for k in 0..segments {
                let corners = [
                    point(i, k),
                    point(i + 1, k),
                    point(i + 1, k + 1),
                    point(i, k + 1),
                ];
                let normal = ((corners[0] + corners[1] + corners[2] + corners[3]) * 0.25 - center)
                    .normalize();
                let v = corners.map(|p| self.vertex(p, id));
                // Skip the zero-area halves of the quads at the poles.
                if i != rings - 1 {
                    self.triangle([v[0], v[1], v[2]], material, normal);
                }
                if i != 0 {
                    self.triangle([v[0], v[2], v[3]], material, normal);
                }
            }
        }
    }

    pub fn into_mesh(
        self,
        colors: Vec<[u8; 3]>,
    ) -> (Mesh, ObjectLabels, Vec<Material>, Vec<DVec3>) {
        let mesh = Mesh {
            positions: self.positions,
            faces: self.faces,
            colors: Some(colors),
            object_ids: Some(self.object_ids),
        };
        (mesh, self.labels, self.face_material, self.face_normal)
    }
}
