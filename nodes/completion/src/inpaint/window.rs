//! The sampling neighbourhood of a hole pixel and OpenCV's edge-tap quirk.
//!
//! OpenCV scans the (2·range+1)² square around a hole pixel in raster order and
//! keeps the cells within Euclidean distance `range`. Here the square is reduced to
//! the disc once (one contiguous span of columns per row, still in raster order, so
//! sums accumulate in OpenCV's order) with the distance-only weight factors
//! precomputed per offset.
//!
//! Gradients at a sample are read through OpenCV's index helpers
//! `km = k−1+(k==1)`, `kp = k−1−(k==rows−2)` (and the same for columns): at the first
//! and last image row or column they read the adjacent row or column instead.
//! [`Taps`] precomputes those reads per padded row or column.

/// Distance-only weight factors of one offset in the disc.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Offset {
    /// Column offset `l − j` as OpenCV's float.
    pub dx: f32,
    /// Row offset `k − i`.
    pub dy: f32,
    /// `|r|²` in float.
    pub len2: f32,
    /// NS distance weight `1 / (|r|⁴ + 1)` in float.
    pub ns_dst: f32,
    /// Telea distance weight `1 / |r|³`, with `|r|·sqrt|r|` in float (1-channel code).
    pub telea_dst_f32: f32,
    /// The same with the product in double (OpenCV's 3-channel code).
    pub telea_dst_f64: f32,
}

/// The disc of radius `range` as row spans.
pub(crate) struct Disc {
    pub range: usize,
    /// For row offset `dy = row − range`: the half-width of its span.
    pub half_width: Vec<usize>,
    /// For each row offset, the index of its first column in `offsets`.
    pub row_start: Vec<usize>,
    pub offsets: Vec<Offset>,
}

impl Disc {
    pub fn new(range: usize) -> Disc {
        let r = range as i64;
        let mut half_width = Vec::with_capacity(2 * range + 1);
        let mut row_start = Vec::with_capacity(2 * range + 1);
        let mut offsets = Vec::new();
        for dy in -r..=r {
            let mut hw = 0i64;
            while (hw + 1) * (hw + 1) + dy * dy <= r * r {
                hw += 1;
            }
            half_width.push(hw as usize);
            row_start.push(offsets.len());
            for dx in -hw..=hw {
                let (fx, fy) = (dx as f32, dy as f32);
                let len2 = fx * fx + fy * fy;
                offsets.push(Offset {
                    dx: fx,
                    dy: fy,
                    len2,
                    ns_dst: 1.0 / (len2 * len2 + 1.0),
                    telea_dst_f32: (1.0 / (len2 * len2.sqrt()) as f64) as f32,
                    telea_dst_f64: (1.0 / (len2 as f64 * (len2 as f64).sqrt())) as f32,
                });
            }
        }
        Disc {
            range,
            half_width,
            row_start,
            offsets,
        }
    }
}

/// The unpadded indices OpenCV reads for the gradient at padded index `k`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tap {
    /// `kp + 1`: the next row (column).
    pub next: usize,
    /// `kp`.
    pub at_p: usize,
    /// `km − 1`: the previous row (column).
    pub prev: usize,
    /// `km`.
    pub at_m: usize,
}

/// Taps for every padded index `1..=len` of an axis of `len` image rows (columns);
/// entry 0 is unused. With `len == 1` OpenCV reads outside the image; those reads
/// are clamped into it here.
pub(crate) fn taps(len: usize) -> Vec<Tap> {
    let last = len as i64 - 1;
    let clamp = |v: i64| v.clamp(0, last.max(0)) as usize;
    let mut out = vec![
        Tap {
            next: 0,
            at_p: 0,
            prev: 0,
            at_m: 0
        };
        len + 2
    ];
    for (k, tap) in out.iter_mut().enumerate().take(len + 1).skip(1) {
        let k = k as i64;
        let km = k - 1 + i64::from(k == 1);
        let kp = k - 1 - i64::from(k == len as i64);
        *tap = Tap {
            next: clamp(kp + 1),
            at_p: clamp(kp),
            prev: clamp(km - 1),
            at_m: clamp(km),
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disc_matches_the_euclidean_test_in_raster_order() {
        for range in 1..=7usize {
            let disc = Disc::new(range);
            let r = range as i64;
            let expected: Vec<(i64, i64)> = (-r..=r)
                .flat_map(|dy| (-r..=r).map(move |dx| (dy, dx)))
                .filter(|(dy, dx)| dx * dx + dy * dy <= r * r)
                .collect();
            let got: Vec<(i64, i64)> = disc
                .offsets
                .iter()
                .map(|o| (o.dy as i64, o.dx as i64))
                .collect();
            assert_eq!(got, expected, "range {range}");
        }
    }

    #[test]
    fn taps_read_the_adjacent_line_at_both_edges() {
        let t = taps(5);
        // First image row (padded 1): km = 1 and kp = 0.
        assert_eq!((t[1].next, t[1].at_p, t[1].prev, t[1].at_m), (1, 0, 0, 1));
        // Interior row (padded 3, image row 2).
        assert_eq!((t[3].next, t[3].at_p, t[3].prev, t[3].at_m), (3, 2, 1, 2));
        // Last image row (padded 5): kp = 3.
        assert_eq!((t[5].next, t[5].at_p, t[5].prev, t[5].at_m), (4, 3, 3, 4));
    }
}
