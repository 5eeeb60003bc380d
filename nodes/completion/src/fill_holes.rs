//! Binary hole filling with the semantics of `scipy.ndimage.binary_fill_holes`.
//!
//! SciPy grows the background inward from outside the image (a border marker),
//! constrained to background pixels, with the given structuring element; whatever
//! the growth cannot reach is a hole and becomes set. The same set is found by a
//! flood fill from every background pixel on the image border.
//!
//! `connectivity` is that of the *background* flood, i.e. SciPy's `structure`:
//! [`Connectivity::Four`] (SciPy's default cross) lets a background region enclosed
//! by diagonal walls count as a hole; [`Connectivity::Eight`] (a full 3×3 structure)
//! lets the background leak through diagonal gaps.

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Connectivity {
    Four,
    Eight,
}

impl Connectivity {
    pub fn from_number(n: i64) -> Result<Connectivity, String> {
        match n {
            4 => Ok(Connectivity::Four),
            8 => Ok(Connectivity::Eight),
            other => Err(format!("connectivity must be 4 or 8, not {other}")),
        }
    }

    fn steps(self) -> &'static [(i64, i64)] {
        match self {
            Connectivity::Four => &[(-1, 0), (0, -1), (0, 1), (1, 0)],
            Connectivity::Eight => &[
                (-1, -1),
                (-1, 0),
                (-1, 1),
                (0, -1),
                (0, 1),
                (1, -1),
                (1, 0),
                (1, 1),
            ],
        }
    }
}

/// `set` (`width × height`, row-major) with its holes filled.
///
/// Panics only if `set.len() != width * height`, which is a caller bug; node code
/// checks sizes when it decodes masks.
pub fn fill_holes(
    set: &[bool],
    width: usize,
    height: usize,
    connectivity: Connectivity,
) -> Vec<bool> {
    assert_eq!(
        set.len(),
        width * height,
        "mask buffer does not match its size"
    );
    let mut outside = vec![false; set.len()];
    let mut stack = Vec::new();
    let seed = |x: usize, y: usize, outside: &mut [bool], stack: &mut Vec<usize>| {
        let i = y * width + x;
        if !set[i] && !outside[i] {
            outside[i] = true;
            stack.push(i);
        }
    };
    for x in 0..width {
        seed(x, 0, &mut outside, &mut stack);
        seed(x, height.saturating_sub(1), &mut outside, &mut stack);
    }
    for y in 0..height {
        seed(0, y, &mut outside, &mut stack);
        seed(width.saturating_sub(1), y, &mut outside, &mut stack);
    }
    let steps = connectivity.steps();
    while let Some(i) = stack.pop() {
        let (x, y) = ((i % width) as i64, (i / width) as i64);
        for &(dy, dx) in steps {
            let (nx, ny) = (x + dx, y + dy);
            if nx < 0 || ny < 0 || nx >= width as i64 || ny >= height as i64 {
                continue;
            }
            let n = ny as usize * width + nx as usize;
            if !set[n] && !outside[n] {
                outside[n] = true;
                stack.push(n);
            }
        }
    }
    outside.iter().map(|&o| !o).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(rows: &[&str]) -> (Vec<bool>, usize, usize) {
        let set = rows
            .iter()
            .flat_map(|r| r.chars().map(|c| c == '#'))
            .collect();
        (set, rows[0].len(), rows.len())
    }

    #[test]
    fn diagonal_walls_enclose_a_hole_only_for_a_four_connected_background() {
        let (set, w, h) = parse(&[".....", "..#..", ".#.#.", "..#..", "....."]);
        let four = fill_holes(&set, w, h, Connectivity::Four);
        let eight = fill_holes(&set, w, h, Connectivity::Eight);
        assert!(
            four[2 * w + 2],
            "4-connected background cannot pass diagonal gaps"
        );
        assert!(
            !eight[2 * w + 2],
            "8-connected background leaks through them"
        );
    }

    #[test]
    fn holes_touching_the_border_are_not_holes() {
        let (set, w, h) = parse(&["#.###", "#...#", "#####"]);
        assert_eq!(fill_holes(&set, w, h, Connectivity::Four), set);
    }
}
