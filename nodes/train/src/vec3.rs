//! The few 3-vector operations the mesh steps (connectivity, surface filter) share.

use objectsplat_core::geometry::triangle_cross;

pub(crate) type V3 = [f64; 3];

pub(crate) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A face's cross product and its length (twice its area); `None` for a
/// degenerate face.
pub(crate) fn proper_cross(corners: [V3; 3]) -> Option<(V3, f64)> {
    let [a, b, c] = corners;
    let m = triangle_cross(&corners);
    let twice_area = dot(m, m).sqrt();
    // Relative to the face's size: a sliver whose normal is rounding noise has none.
    let scale = dot(sub(b, a), sub(b, a)).max(dot(sub(c, a), sub(c, a)));
    if !(twice_area > 1e-9 * scale) || !twice_area.is_finite() {
        return None;
    }
    Some((m, twice_area))
}
