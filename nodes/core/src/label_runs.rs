//! A label plane (a component's OWN/OTHER/IGNORE mask) held as runs of equal
//! labels per row: a mask has a few runs per row, so a 1752×1168 frame takes
//! kilobytes instead of two megabytes, and a component keeps every view's mask
//! in memory at any scale.

use anyhow::{Result, bail};

/// Labels per row as runs `[start, end)`; `ends` and `labels` hold every
/// row's runs, `row_start[y]..row_start[y + 1]` those of row `y`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct LabelRuns {
    width: u32,
    height: u32,
    row_start: Vec<u32>,
    /// Exclusive end column of each run.
    ends: Vec<u16>,
    labels: Vec<u8>,
}

impl LabelRuns {
    /// The runs of a `width`×`height` row-major plane.
    pub fn from_plane(width: u32, height: u32, plane: &[u8]) -> Result<Self> {
        if plane.len() != width as usize * height as usize {
            bail!("a {width}×{height} label plane has {} values", plane.len());
        }
        if width > u16::MAX as u32 {
            bail!(
                "label planes are at most {} pixels wide, not {width}",
                u16::MAX
            );
        }
        let mut runs = LabelRuns {
            width,
            height,
            row_start: Vec::with_capacity(height as usize + 1),
            ends: Vec::new(),
            labels: Vec::new(),
        };
        for row in plane
            .chunks_exact(width.max(1) as usize)
            .take(height as usize)
        {
            runs.row_start.push(runs.ends.len() as u32);
            let mut x = 0;
            while x < row.len() {
                let label = row[x];
                let end = x + row[x..].iter().take_while(|&&l| l == label).count();
                runs.ends.push(end as u16);
                runs.labels.push(label);
                x = end;
            }
        }
        runs.row_start
            .resize(height as usize + 1, runs.ends.len() as u32);
        runs.ends.shrink_to_fit();
        runs.labels.shrink_to_fit();
        Ok(runs)
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// The label of pixel `(x, y)`.
    pub fn get(&self, x: u32, y: u32) -> u8 {
        let (lo, hi) = self.row_span(y);
        let ends = &self.ends[lo..hi];
        // The first run ending after x holds it (x < width: the last run ends at width).
        let k = ends.partition_point(|&end| end as u32 <= x);
        self.labels[lo + k.min(ends.len().saturating_sub(1))]
    }

    /// The label of pixel `p` (row-major index).
    pub fn at(&self, p: usize) -> u8 {
        let w = self.width.max(1) as usize;
        self.get((p % w) as u32, (p / w) as u32)
    }

    fn row_span(&self, y: u32) -> (usize, usize) {
        (
            self.row_start[y as usize] as usize,
            self.row_start[y as usize + 1] as usize,
        )
    }

    /// Row `y`'s runs as `(start, end, label)`.
    pub fn row(&self, y: u32) -> impl Iterator<Item = (u32, u32, u8)> + '_ {
        let (lo, hi) = self.row_span(y);
        (lo..hi).map(move |k| {
            let start = if k == lo { 0 } else { self.ends[k - 1] as u32 };
            (start, self.ends[k] as u32, self.labels[k])
        })
    }

    /// Row `y` from column `x0` to `x1` (exclusive), one label per pixel, into `out`.
    pub fn extend_row(&self, y: u32, x0: u32, x1: u32, out: &mut Vec<u8>) {
        for (start, end, label) in self.row(y) {
            let (a, b) = (start.max(x0), end.min(x1));
            if a < b {
                out.extend(std::iter::repeat_n(label, (b - a) as usize));
            }
        }
    }

    /// The whole plane, row-major.
    pub fn to_plane(&self) -> Vec<u8> {
        let mut plane = Vec::with_capacity(self.width as usize * self.height as usize);
        for y in 0..self.height {
            self.extend_row(y, 0, self.width, &mut plane);
        }
        plane
    }

    /// How many pixels carry `label`.
    pub fn count(&self, label: u8) -> usize {
        (0..self.height)
            .flat_map(|y| self.row(y))
            .filter(|r| r.2 == label)
            .map(|(start, end, _)| (end - start) as usize)
            .sum()
    }

    /// The bounding box `[x0, x1) × [y0, y1)` of the pixels for which `wanted`
    /// holds, or None.
    pub fn bounds(&self, wanted: impl Fn(u8) -> bool) -> Option<[u32; 4]> {
        let mut b: Option<[u32; 4]> = None;
        for y in 0..self.height {
            for (start, end, _) in self.row(y).filter(|r| wanted(r.2)) {
                b = Some(match b {
                    None => [start, y, end, y + 1],
                    Some([x0, y0, x1, _]) => [x0.min(start), y0, x1.max(end), y + 1],
                });
            }
        }
        b
    }

    /// Bytes held (for memory reports).
    pub fn bytes(&self) -> usize {
        self.row_start.len() * 4 + self.ends.len() * 2 + self.labels.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// xorshift: planes with runs of random lengths.
    fn plane(width: u32, height: u32, seed: u64) -> Vec<u8> {
        let mut s = seed;
        let mut label = 0u8;
        (0..width * height)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                if s.is_multiple_of(9) {
                    label = [0, 128, 255][(s >> 8) as usize % 3];
                }
                label
            })
            .collect()
    }

    #[test]
    fn runs_give_back_every_pixel() {
        for (w, h, seed) in [(37, 11, 1), (1, 5, 2), (64, 1, 3), (5, 0, 4), (0, 3, 5)] {
            let p = plane(w, h, seed);
            let runs = LabelRuns::from_plane(w, h, &p).unwrap();
            assert_eq!(runs.to_plane(), p);
            for (i, &label) in p.iter().enumerate() {
                assert_eq!(runs.at(i), label, "pixel {i} of {w}×{h}");
            }
            for wanted in [0u8, 128, 255] {
                assert_eq!(
                    runs.count(wanted),
                    p.iter().filter(|&&l| l == wanted).count()
                );
            }
            let mut middle = Vec::new();
            if w > 4 {
                for y in 0..h {
                    runs.extend_row(y, 2, w - 1, &mut middle);
                }
                let want: Vec<u8> = (0..h as usize)
                    .flat_map(|y| p[y * w as usize + 2..(y + 1) * w as usize - 1].to_vec())
                    .collect();
                assert_eq!(middle, want);
            }
        }
    }

    #[test]
    fn bounds_are_the_box_of_the_wanted_pixels() {
        let (w, h) = (8u32, 6u32);
        let mut p = vec![0u8; (w * h) as usize];
        for (x, y) in [(2, 1), (5, 3), (3, 4)] {
            p[(y * w + x) as usize] = 255;
        }
        let runs = LabelRuns::from_plane(w, h, &p).unwrap();
        assert_eq!(runs.bounds(|l| l == 255), Some([2, 1, 6, 5]));
        assert_eq!(runs.bounds(|l| l == 128), None);
        assert!(LabelRuns::from_plane(w, h, &p[1..]).is_err());
    }
}
