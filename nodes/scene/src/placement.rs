//! Where an object sits in the scene: a pivot in the object's own (model) frame and a
//! similarity transform (translation, rotation, uniform scale) placing it in the world.
//!
//! `world(p) = translation + scale · R(rotation) · (p − pivot)`. The pivot is the point of
//! the model the glTF node's origin sits on (the object's centre), so the exported node
//! carries `translation`/`rotation`/`scale` and its vertices are `p − pivot`.
//!
//! Rigid edits act on a placement without touching the model: a move adds to
//! `translation`, a rotation multiplies `rotation` on the left (so it turns the object
//! about its pivot, which stays at `translation`), a scale multiplies `scale`.
//!
//! The viewer page (`viewer/viewer.js`) repeats [`Placement::moved`],
//! [`Placement::rotated`], [`Placement::scaled`], [`quat_from_axis_angle`], [`quat_mul`]
//! and [`quat_normalized`] operation for operation, so an edit done by hand and the same
//! edit replayed by `edit_scene` produce the same doubles, and the same f32 node transform.

use serde::{Deserialize, Serialize};

/// A pivot in the model's frame and the similarity transform placing it in the world.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Placement {
    /// The model point that becomes the node's origin (model frame).
    pub pivot: [f64; 3],
    /// Where the pivot lands in the world.
    pub translation: [f64; 3],
    /// Quaternion `[x, y, z, w]` (glTF order); normalised where it is used.
    pub rotation: [f64; 4],
    /// Uniform scale about the pivot, > 0.
    pub scale: f64,
}

pub const IDENTITY_ROTATION: [f64; 4] = [0.0, 0.0, 0.0, 1.0];

impl Placement {
    /// Model coordinates are world coordinates and the node origin is the world origin.
    pub const IDENTITY: Placement = Placement {
        pivot: [0.0; 3],
        translation: [0.0; 3],
        rotation: IDENTITY_ROTATION,
        scale: 1.0,
    };

    /// The model where it was trained, with its node origin on `pivot`.
    pub fn at(pivot: [f64; 3]) -> Placement {
        Placement {
            pivot,
            translation: pivot,
            rotation: IDENTITY_ROTATION,
            scale: 1.0,
        }
    }

    /// A model point in the node's (object) frame: `p − pivot`.
    pub fn local(&self, p: [f64; 3]) -> [f64; 3] {
        [
            p[0] - self.pivot[0],
            p[1] - self.pivot[1],
            p[2] - self.pivot[2],
        ]
    }

    /// A point of the node's frame in the world: `translation + scale · R · q`.
    pub fn node_to_world(&self, q: [f64; 3]) -> [f64; 3] {
        let r = quat_to_matrix(self.rotation);
        let mut out = self.translation;
        for (i, o) in out.iter_mut().enumerate() {
            *o += self.scale * (r[i][0] * q[0] + r[i][1] * q[1] + r[i][2] * q[2]);
        }
        out
    }

    /// A model point in the world.
    pub fn world(&self, p: [f64; 3]) -> [f64; 3] {
        self.node_to_world(self.local(p))
    }

    /// The world rotation as a row-major 3×3 matrix.
    pub fn rotation_matrix(&self) -> [[f64; 3]; 3] {
        quat_to_matrix(self.rotation)
    }

    /// Moved by `by` (world units).
    pub fn moved(&self, by: [f64; 3]) -> Placement {
        Placement {
            translation: [
                self.translation[0] + by[0],
                self.translation[1] + by[1],
                self.translation[2] + by[2],
            ],
            ..*self
        }
    }

    /// Turned about its pivot by `degrees` around the world axis `axis` (any length > 0).
    pub fn rotated(&self, axis: [f64; 3], degrees: f64) -> Placement {
        Placement {
            rotation: quat_mul(quat_from_axis_angle(axis, degrees), self.rotation),
            ..*self
        }
    }

    /// Scaled about its pivot by `factor`.
    pub fn scaled(&self, factor: f64) -> Placement {
        Placement {
            scale: self.scale * factor,
            ..*self
        }
    }

    pub fn is_identity(&self) -> bool {
        *self == Placement::IDENTITY
    }

    /// The model is where it was trained (`world(p) = p`, whatever the pivot).
    pub fn is_unmoved(&self) -> bool {
        self.translation == self.pivot && self.rotation == IDENTITY_ROTATION && self.scale == 1.0
    }

    /// The glTF node transform: translation, unit rotation `[x, y, z, w]` and scale, as f32.
    pub fn node_trs(&self) -> ([f32; 3], [f32; 4], [f32; 3]) {
        let q = quat_normalized(self.rotation);
        (
            self.translation.map(|v| v as f32),
            q.map(|v| v as f32),
            [self.scale as f32; 3],
        )
    }
}

/// The rotation by `degrees` about `axis` (normalised here; must not be zero).
pub fn quat_from_axis_angle(axis: [f64; 3], degrees: f64) -> [f64; 4] {
    let length = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    let half = degrees * (std::f64::consts::PI / 180.0) * 0.5;
    let s = half.sin() / length;
    [axis[0] * s, axis[1] * s, axis[2] * s, half.cos()]
}

/// The Hamilton product `a ⊗ b` (apply `b`, then `a`), both `[x, y, z, w]`.
pub fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let [ax, ay, az, aw] = a;
    let [bx, by, bz, bw] = b;
    [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]
}

/// `q / |q|` (the identity for a zero quaternion, which no edit can produce).
pub fn quat_normalized(q: [f64; 4]) -> [f64; 4] {
    let length = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if length == 0.0 || !length.is_finite() {
        return IDENTITY_ROTATION;
    }
    q.map(|v| v / length)
}

/// The rotation matrix (row-major) of the normalised quaternion.
pub fn quat_to_matrix(q: [f64; 4]) -> [[f64; 3]; 3] {
    let [x, y, z, w] = quat_normalized(q);
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - z * w),
            2.0 * (x * z + y * w),
        ],
        [
            2.0 * (x * y + z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - x * w),
        ],
        [
            2.0 * (x * z - y * w),
            2.0 * (y * z + x * w),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() <= tol)
    }

    #[test]
    fn identity_maps_points_to_themselves_exactly() {
        let p = [0.1, -2.5, 1e-3];
        assert_eq!(Placement::IDENTITY.world(p), p);
        assert_eq!(
            Placement::at([0.5, 0.25, -1.0]).world([0.75, 0.5, 2.0]),
            [0.75, 0.5, 2.0]
        );
    }

    #[test]
    fn quarter_turn_about_z_maps_x_to_y() {
        let q = quat_from_axis_angle([0.0, 0.0, 2.0], 90.0);
        let r = quat_to_matrix(q);
        let x = [r[0][0], r[1][0], r[2][0]];
        assert!(close(x, [0.0, 1.0, 0.0], 1e-15), "{x:?}");
        // Two quarter turns make a half turn: x → −x.
        let r2 = quat_to_matrix(quat_mul(q, q));
        assert!(close(
            [r2[0][0], r2[1][0], r2[2][0]],
            [-1.0, 0.0, 0.0],
            1e-15
        ));
    }

    #[test]
    fn product_applies_the_right_factor_first() {
        // 90° about X then 90° about Z: Y → Z (first) → Z (Z-turn keeps it).
        let about_x = quat_from_axis_angle([1.0, 0.0, 0.0], 90.0);
        let about_z = quat_from_axis_angle([0.0, 0.0, 1.0], 90.0);
        let r = quat_to_matrix(quat_mul(about_z, about_x));
        let y = [r[0][1], r[1][1], r[2][1]];
        assert!(close(y, [0.0, 0.0, 1.0], 1e-15), "{y:?}");
        // And X → X (first) → Y.
        assert!(close([r[0][0], r[1][0], r[2][0]], [0.0, 1.0, 0.0], 1e-15));
    }

    #[test]
    fn edits_turn_and_scale_about_the_pivot() {
        let pivot = [1.0, 2.0, 0.5];
        let p = Placement::at(pivot)
            .rotated([0.0, 0.0, 1.0], 90.0)
            .scaled(2.0)
            .moved([0.0, 0.0, 1.0]);
        // The pivot itself only moves.
        assert!(close(p.world(pivot), [1.0, 2.0, 1.5], 1e-15));
        // A point 1 along +X of the pivot ends 2 along +Y of it.
        assert!(close(p.world([2.0, 2.0, 0.5]), [1.0, 4.0, 1.5], 1e-15));
        let (t, q, s) = p.node_trs();
        assert_eq!(t, [1.0, 2.0, 1.5]);
        assert_eq!(s, [2.0; 3]);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        assert!((q[2] - h).abs() < 1e-7 && (q[3] - h).abs() < 1e-7 && q[0] == 0.0);
    }
}
