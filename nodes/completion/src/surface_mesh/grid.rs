//! A support surface's plane and a square-cell occupancy grid laid on it.
//!
//! Everything the 3D completion decides (what the surface covers, where objects stand,
//! where the hole is) is a set of grid cells; cell `(i, j)` spans
//! `[i, i+1) × [j, j+1)` in cell coordinates, and its centre decides whether a
//! triangle covers it.

use glam::{DVec2, DVec3};

/// An orthonormal frame on a plane: `normal` points to the side the cameras are on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneFrame {
    pub origin: DVec3,
    pub normal: DVec3,
    pub e1: DVec3,
    pub e2: DVec3,
}

impl PlaneFrame {
    /// The plane through `origin` with unit `normal`, with in-plane axes chosen from it.
    pub fn new(origin: DVec3, normal: DVec3) -> PlaneFrame {
        let normal = normal.normalize();
        let helper = if normal.x.abs() < 0.9 {
            DVec3::X
        } else {
            DVec3::Y
        };
        let e1 = normal.cross(helper).normalize();
        let e2 = normal.cross(e1);
        PlaneFrame {
            origin,
            normal,
            e1,
            e2,
        }
    }

    /// In-plane coordinates and signed height above the plane.
    pub fn project(&self, p: DVec3) -> (DVec2, f64) {
        let d = p - self.origin;
        (
            DVec2::new(d.dot(self.e1), d.dot(self.e2)),
            d.dot(self.normal),
        )
    }

    /// The point of the plane at in-plane coordinates `q`.
    pub fn lift(&self, q: DVec2) -> DVec3 {
        self.origin + self.e1 * q.x + self.e2 * q.y
    }
}

/// A `width × height` grid of square cells of side `cell` whose corner (0, 0) is `min`
/// in plane coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    pub min: DVec2,
    pub cell: f64,
    pub width: usize,
    pub height: usize,
}

impl Grid {
    /// Covers the box `[lo, hi]` with cells of side `(longer side) / resolution`, plus a
    /// border of `border` cells on every side.
    pub fn covering(lo: DVec2, hi: DVec2, resolution: usize, border: usize) -> Grid {
        let extent = (hi - lo).max_element().max(f64::MIN_POSITIVE);
        let cell = extent / resolution as f64;
        let b = border as f64 * cell;
        let size = (hi - lo) + 2.0 * b;
        Grid {
            min: lo - DVec2::splat(b),
            cell,
            width: (size.x / cell).ceil() as usize + 1,
            height: (size.y / cell).ceil() as usize + 1,
        }
    }

    pub fn len(&self) -> usize {
        self.width * self.height
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Plane coordinates → continuous cell coordinates.
    pub fn to_cells(&self, q: DVec2) -> DVec2 {
        (q - self.min) / self.cell
    }

    /// Continuous cell coordinates → plane coordinates.
    pub fn to_plane(&self, c: DVec2) -> DVec2 {
        self.min + c * self.cell
    }

    /// The cell containing continuous cell coordinates `c`, if inside the grid.
    pub fn cell_at(&self, c: DVec2) -> Option<usize> {
        if c.x < 0.0 || c.y < 0.0 {
            return None;
        }
        let (i, j) = (c.x as usize, c.y as usize);
        (i < self.width && j < self.height).then(|| j * self.width + i)
    }

    /// Marks the cells whose centres a triangle (cell coordinates) covers, and the cells
    /// holding its corners (so a triangle smaller than a cell still marks one).
    pub fn fill_triangle(&self, t: [DVec2; 3], out: &mut [bool]) {
        let lo = t[0].min(t[1]).min(t[2]);
        let hi = t[0].max(t[1]).max(t[2]);
        for corner in t {
            if let Some(k) = self.cell_at(corner) {
                out[k] = true;
            }
        }
        let area = cross(t[1] - t[0], t[2] - t[0]);
        if area == 0.0 || !area.is_finite() {
            return;
        }
        let i0 = (lo.x - 0.5).ceil().max(0.0) as usize;
        let j0 = (lo.y - 0.5).ceil().max(0.0) as usize;
        let i1 = ((hi.x - 0.5).floor()).min(self.width as f64 - 1.0);
        let j1 = ((hi.y - 0.5).floor()).min(self.height as f64 - 1.0);
        if i1 < 0.0 || j1 < 0.0 {
            return;
        }
        for j in j0..=j1 as usize {
            for i in i0..=i1 as usize {
                let p = DVec2::new(i as f64 + 0.5, j as f64 + 0.5);
                let inside = (0..3).all(|k| {
                    let e = cross(t[(k + 1) % 3] - t[k], p - t[k]);
                    e * area >= 0.0
                });
                if inside {
                    out[j * self.width + i] = true;
                }
            }
        }
    }

    /// Every cell within `radius` cells (square neighbourhood) of a set cell.
    pub fn dilate(&self, set: &[bool], radius: usize) -> Vec<bool> {
        let r = radius as isize;
        let (w, h) = (self.width as isize, self.height as isize);
        // Separable: rows then columns.
        let mut rows = vec![false; set.len()];
        for j in 0..h {
            for i in 0..w {
                if set[(j * w + i) as usize] {
                    for x in (i - r).max(0)..=(i + r).min(w - 1) {
                        rows[(j * w + x) as usize] = true;
                    }
                }
            }
        }
        let mut out = vec![false; set.len()];
        for j in 0..h {
            for i in 0..w {
                if rows[(j * w + i) as usize] {
                    for y in (j - r).max(0)..=(j + r).min(h - 1) {
                        out[(y * w + i) as usize] = true;
                    }
                }
            }
        }
        out
    }

    /// Cells whose whole `radius` neighbourhood is set (cells outside the grid count as unset).
    pub fn erode(&self, set: &[bool], radius: usize) -> Vec<bool> {
        let inverted: Vec<bool> = set.iter().map(|&s| !s).collect();
        let mut grown = self.dilate(&inverted, radius);
        let r = radius;
        for j in 0..self.height {
            for i in 0..self.width {
                if i < r || j < r || i + r >= self.width || j + r >= self.height {
                    grown[j * self.width + i] = true;
                }
            }
        }
        grown.iter().map(|&g| !g).collect()
    }

    /// The 8-connected components of `set`, as lists of cell indices.
    pub fn components(&self, set: &[bool]) -> Vec<Vec<usize>> {
        let mut seen = vec![false; set.len()];
        let mut out = Vec::new();
        for start in 0..set.len() {
            if !set[start] || seen[start] {
                continue;
            }
            seen[start] = true;
            let mut stack = vec![start];
            let mut cells = Vec::new();
            while let Some(k) = stack.pop() {
                cells.push(k);
                let (i, j) = ((k % self.width) as isize, (k / self.width) as isize);
                for dj in -1..=1 {
                    for di in -1..=1 {
                        let (x, y) = (i + di, j + dj);
                        if x < 0 || y < 0 || x >= self.width as isize || y >= self.height as isize {
                            continue;
                        }
                        let n = y as usize * self.width + x as usize;
                        if set[n] && !seen[n] {
                            seen[n] = true;
                            stack.push(n);
                        }
                    }
                }
            }
            out.push(cells);
        }
        out
    }

    /// The cells whose centres lie in the convex hull of the given cells' corners.
    pub fn convex_hull_cells(&self, cells: &[usize]) -> Vec<bool> {
        let mut corners: Vec<DVec2> = Vec::with_capacity(cells.len() * 4);
        for &k in cells {
            let (i, j) = ((k % self.width) as f64, (k / self.width) as f64);
            corners.extend([
                DVec2::new(i, j),
                DVec2::new(i + 1.0, j),
                DVec2::new(i, j + 1.0),
                DVec2::new(i + 1.0, j + 1.0),
            ]);
        }
        let hull = convex_hull(corners);
        let mut out = vec![false; self.len()];
        if hull.len() < 3 {
            return out;
        }
        // The hull is convex: fan it into triangles from its first corner.
        for k in 1..hull.len() - 1 {
            self.fill_triangle([hull[0], hull[k], hull[k + 1]], &mut out);
        }
        out
    }
}

fn cross(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Andrew's monotone chain: the hull's corners counter-clockwise, collinear points dropped.
pub fn convex_hull(mut points: Vec<DVec2>) -> Vec<DVec2> {
    points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let mut hull: Vec<DVec2> = Vec::with_capacity(points.len() * 2);
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 {
            Box::new(points.iter())
        } else {
            Box::new(points.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(
                    hull[hull.len() - 1] - hull[hull.len() - 2],
                    p - hull[hull.len() - 2],
                ) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_frame_round_trips() {
        let frame = PlaneFrame::new(DVec3::new(1.0, 2.0, 3.0), DVec3::new(0.2, -0.3, 1.0));
        let p = DVec3::new(0.4, 2.5, 3.7);
        let (q, h) = frame.project(p);
        let back = frame.lift(q) + frame.normal * h;
        assert!((back - p).length() < 1e-12);
        assert!(frame.e1.dot(frame.e2).abs() < 1e-12);
    }

    #[test]
    fn a_square_hull_fills_its_cells() {
        let grid = Grid {
            min: DVec2::ZERO,
            cell: 1.0,
            width: 10,
            height: 10,
        };
        // Two opposite cells of a 4×4 block span the whole block's hull.
        let cells = [2 * 10 + 2, 5 * 10 + 5];
        let hull = grid.convex_hull_cells(&cells);
        // The hull of the two cells' corners is a hexagon inside [2, 6]²; its centre cells are in.
        assert!(hull[3 * 10 + 3] && hull[4 * 10 + 4]);
        assert!(!hull[10 + 1] && !hull[7 * 10 + 7]);
        let square = convex_hull(vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.5, 0.5),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
        ]);
        assert_eq!(square.len(), 4);
    }

    #[test]
    fn closing_bridges_a_one_cell_gap() {
        let grid = Grid {
            min: DVec2::ZERO,
            cell: 1.0,
            width: 9,
            height: 9,
        };
        let mut set = vec![false; 81];
        for j in 1..8 {
            for i in 1..8 {
                set[j * 9 + i] = i != 4;
            }
        }
        let closed = grid.erode(&grid.dilate(&set, 1), 1);
        assert!(closed[4 * 9 + 4]);
        assert_eq!(grid.components(&set).len(), 2);
        assert_eq!(grid.components(&closed).len(), 1);
    }
}
