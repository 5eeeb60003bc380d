//! Pinhole cameras in the OpenCV convention.
//!
//! Camera axes: +x right, +y down, +z forward. `world_to_camera` maps world
//! points into that frame. Pixel coordinates are continuous with the centre of
//! the top-left pixel at (0.5, 0.5) (the COLMAP convention), so a camera-space
//! point projects to `u = fx·x/z + cx`, `v = fy·y/z + cy` and pixel `(i, j)` is
//! sampled at `(i + 0.5, j + 0.5)`.

use glam::{DMat3, DMat4, DVec3};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    pub width: u32,
    pub height: u32,
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    /// 4×4 row-major world→camera transform (rigid).
    pub world_to_camera: [[f64; 4]; 4],
}

impl Camera {
    /// The world→camera transform as a glam matrix (glam is column-major).
    pub fn view(&self) -> DMat4 {
        DMat4::from_cols_array_2d(&self.world_to_camera).transpose()
    }

    pub fn from_view(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        view: DMat4,
    ) -> Self {
        Camera {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            world_to_camera: view.transpose().to_cols_array_2d(),
        }
    }

    /// Rotation part of world→camera.
    pub fn rotation(&self) -> DMat3 {
        DMat3::from_mat4(self.view())
    }

    pub fn translation(&self) -> DVec3 {
        let m = &self.world_to_camera;
        DVec3::new(m[0][3], m[1][3], m[2][3])
    }

    /// Camera centre in world coordinates, `C = −Rᵀt`.
    pub fn center(&self) -> DVec3 {
        -(self.rotation().transpose() * self.translation())
    }

    pub fn to_camera(&self, p_world: DVec3) -> DVec3 {
        self.rotation() * p_world + self.translation()
    }

    /// Projects a world point to continuous pixel coordinates and depth.
    /// `None` when the point is not in front of the camera.
    pub fn project(&self, p_world: DVec3) -> Option<(f64, f64, f64)> {
        let c = self.to_camera(p_world);
        if c.z <= 0.0 {
            return None;
        }
        Some((
            self.fx * c.x / c.z + self.cx,
            self.fy * c.y / c.z + self.cy,
            c.z,
        ))
    }

    /// A camera at `eye` looking at `target`, with world `up` mapped to −y (image up).
    pub fn look_at(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        eye: DVec3,
        target: DVec3,
        up: DVec3,
    ) -> Self {
        let z = (target - eye).normalize();
        let x = z.cross(up).normalize();
        let y = z.cross(x);
        let r = DMat3::from_cols(x, y, z).transpose();
        let t = -(r * eye);
        let view = DMat4::from_cols(
            r.x_axis.extend(0.0),
            r.y_axis.extend(0.0),
            r.z_axis.extend(0.0),
            t.extend(1.0),
        );
        Camera::from_view(
            width,
            height,
            fx,
            fy,
            width as f64 / 2.0,
            height as f64 / 2.0,
            view,
        )
    }

    /// Checks that the numbers make a usable camera; the error says which one does not.
    pub fn validate(&self) -> Result<(), String> {
        if self.width == 0 || self.height == 0 {
            return Err(format!(
                "image size {}×{} is empty",
                self.width, self.height
            ));
        }
        for (name, v) in [("fx", self.fx), ("fy", self.fy)] {
            if !v.is_finite() || v <= 0.0 {
                return Err(format!("{name} = {v} must be finite and positive"));
            }
        }
        for (name, v) in [("cx", self.cx), ("cy", self.cy)] {
            if !v.is_finite() {
                return Err(format!("{name} = {v} must be finite"));
            }
        }
        if self
            .world_to_camera
            .iter()
            .flatten()
            .any(|v| !v.is_finite())
        {
            return Err("world_to_camera has a non-finite entry".into());
        }
        let r = self.rotation();
        let rtr = r.transpose() * r;
        let err = (rtr - DMat3::IDENTITY)
            .to_cols_array()
            .iter()
            .map(|v| v.abs())
            .fold(0.0, f64::max);
        if err > 1e-6 || r.determinant() < 0.0 {
            return Err(format!(
                "world_to_camera rotation is not a proper rotation (|RᵀR − I| = {err:.2e})"
            ));
        }
        let last = self.world_to_camera[3];
        if last != [0.0, 0.0, 0.0, 1.0] {
            return Err(format!(
                "world_to_camera last row must be [0,0,0,1], got {last:?}"
            ));
        }
        Ok(())
    }

    /// The same camera for an image downscaled by `factor` (pixel-centre convention preserved).
    pub fn scaled(&self, width: u32, height: u32) -> Camera {
        let sx = width as f64 / self.width as f64;
        let sy = height as f64 / self.height as f64;
        Camera {
            width,
            height,
            fx: self.fx * sx,
            fy: self.fy * sy,
            cx: self.cx * sx,
            cy: self.cy * sy,
            ..*self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_projects_target_to_principal_point() {
        let cam = Camera::look_at(
            64,
            48,
            50.0,
            50.0,
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::ZERO,
            DVec3::Z,
        );
        cam.validate().unwrap();
        let (u, v, z) = cam.project(DVec3::ZERO).unwrap();
        assert!((u - 32.0).abs() < 1e-9 && (v - 24.0).abs() < 1e-9);
        assert!((z - 14f64.sqrt()).abs() < 1e-9);
        assert!((cam.center() - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
        // World up projects upwards in the image (smaller v).
        let (_, v_up, _) = cam.project(DVec3::new(0.0, 0.0, 0.1)).unwrap();
        assert!(v_up < v);
    }
}
