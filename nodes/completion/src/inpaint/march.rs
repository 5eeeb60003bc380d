//! The fast-marching fill order shared by both inpainting methods.
//!
//! OpenCV fills hole pixels in the order a fast-marching front reaches them, and
//! computes each pixel's value the moment the front first touches it. That order
//! depends only on the mask, never on pixel values, so it is computed once here and
//! then replayed per channel (which is what lets channels run in parallel).
//!
//! Grids are padded by one cell on every side, exactly as OpenCV pads them: padded
//! cell (i, j) is image pixel (i − 1, j − 1); the padding ring is "known" with
//! arrival time 1e6 and is never sampled for colour.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Arrival time of every cell the front has not reached (OpenCV's initial T).
const FAR: f32 = 1.0e6;

/// Cell states during a march (OpenCV's KNOWN / BAND / INSIDE).
const KNOWN: u8 = 0;
const BAND: u8 = 1;
const INSIDE: u8 = 2;

/// The result of marching through one mask.
pub(crate) struct FillOrder {
    /// Padded grid width (image width + 2).
    pub stride: usize,
    /// Padded indices of the hole pixels in the order their values are computed.
    pub order: Vec<u32>,
    /// Per padded cell: 0 for known cells, 1 + position in `order` for hole pixels,
    /// `u32::MAX` for hole pixels the front never reaches (only when the hole covers
    /// the whole image). While the pixel at rank `r` is computed, a cell counts as
    /// known exactly when its rank is below `r`.
    pub rank: Vec<u32>,
    /// Final arrival time per padded cell; for Telea, the outward pre-pass has made
    /// it negative in the ring of known pixels around the hole.
    pub time: Vec<f32>,
}

/// A queue entry: smallest time first, equal times in insertion order (OpenCV's
/// sorted list pops equal keys first-in first-out).
#[derive(Clone, Copy)]
struct Entry {
    time: f32,
    seq: u64,
    cell: u32,
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    // Reversed so that std's max-heap pops the earliest (time, seq).
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .time
            .total_cmp(&self.time)
            .then_with(|| other.seq.cmp(&self.seq))
    }
}

#[derive(Default)]
struct Front {
    heap: BinaryHeap<Entry>,
    next_seq: u64,
}

impl Front {
    fn push(&mut self, cell: usize, time: f32) {
        // Cell indices fit u32: the padded grid size is checked by the caller.
        self.heap.push(Entry {
            time,
            seq: self.next_seq,
            cell: cell as u32,
        });
        self.next_seq += 1;
    }

    fn pop(&mut self) -> Option<usize> {
        self.heap.pop().map(|e| e.cell as usize)
    }
}

/// One Eikonal update from two axis neighbours `a` (vertical) and `b` (horizontal),
/// in double precision like OpenCV's `FastMarching_solve`.
fn solve(a: usize, b: usize, state: &[u8], time: &[f32]) -> f32 {
    let ta = time[a] as f64;
    let tb = time[b] as f64;
    let smaller = if ta > tb { tb } else { ta };
    let sol = match (state[a] != INSIDE, state[b] != INSIDE) {
        (true, true) => {
            if (ta - tb).abs() >= 1.0 {
                1.0 + smaller
            } else {
                (ta + tb + (2.0 - (ta - tb) * (ta - tb)).sqrt()) * 0.5
            }
        }
        (true, false) => 1.0 + ta,
        (false, true) => 1.0 + tb,
        (false, false) => 1.0 + smaller,
    };
    sol as f32
}

fn min4(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let ab = if a > b { b } else { a };
    let cd = if c > d { d } else { c };
    if ab > cd { cd } else { ab }
}

/// The arrival time of `cell` from its four quadrants.
fn arrival(cell: usize, stride: usize, state: &[u8], time: &[f32]) -> f32 {
    let (up, down, left, right) = (cell - stride, cell + stride, cell - 1, cell + 1);
    min4(
        solve(up, left, state, time),
        solve(down, left, state, time),
        solve(up, right, state, time),
        solve(down, right, state, time),
    )
}

/// Neighbours in OpenCV's visiting order: up, left, down, right.
fn neighbours(cell: usize, stride: usize) -> [usize; 4] {
    [cell - stride, cell - 1, cell + stride, cell + 1]
}

/// Marches `state` from the cells already in `front`: each popped cell becomes
/// `settled`, each INSIDE neighbour gets its arrival time and joins the front.
/// `visit` sees every newly reached cell in order.
fn march(
    front: &mut Front,
    state: &mut [u8],
    time: &mut [f32],
    stride: usize,
    settled: u8,
    mut visit: impl FnMut(usize),
) {
    while let Some(cell) = front.pop() {
        state[cell] = settled;
        for nb in neighbours(cell, stride) {
            // Padding cells are never INSIDE, so the neighbour's own neighbours exist.
            if state[nb] == INSIDE {
                let t = arrival(nb, stride, state, time);
                time[nb] = t;
                state[nb] = BAND;
                front.push(nb, t);
                visit(nb);
            }
        }
    }
}

/// Computes the fill order for `mask` (`width`×`height`, non-zero = hole).
/// `outward_range` = Some(range) runs Telea's outward pre-pass first, which
/// assigns negative times to known pixels within `range` (Chebyshev) of the hole.
pub(crate) fn fill_order(
    mask: &[u8],
    width: usize,
    height: usize,
    outward_range: Option<usize>,
) -> FillOrder {
    let stride = width + 2;
    let rows = height + 2;
    let cells = stride * rows;
    let mut state = vec![KNOWN; cells];
    let mut time = vec![FAR; cells];
    for y in 0..height {
        for x in 0..width {
            if mask[y * width + x] != 0 {
                state[(y + 1) * stride + x + 1] = INSIDE;
            }
        }
    }

    // The starting band: image pixels outside the hole with a 4-neighbour in it,
    // queued at time 0 in raster order.
    let mut band = Vec::new();
    for i in 1..rows - 1 {
        for j in 1..stride - 1 {
            let c = i * stride + j;
            if state[c] != INSIDE && neighbours(c, stride).iter().any(|&n| state[n] == INSIDE) {
                band.push(c);
            }
        }
    }
    for &c in &band {
        time[c] = 0.0;
    }

    if let Some(range) = outward_range {
        outward_pass(&state, &mut time, &band, width, height, range);
    }

    let mut front = Front::default();
    for &c in &band {
        front.push(c, 0.0);
    }
    let mut rank = vec![0u32; cells];
    let mut order = Vec::new();
    march(&mut front, &mut state, &mut time, stride, KNOWN, |cell| {
        order.push(cell as u32);
        // At most width*height hole pixels, checked to fit u32 by the caller.
        rank[cell] = order.len() as u32;
    });
    for (r, s) in rank.iter_mut().zip(&state) {
        if *s == INSIDE {
            *r = u32::MAX;
        }
    }
    FillOrder {
        stride,
        order,
        rank,
        time,
    }
}

/// Telea's pre-pass: march outward from the band through the known pixels within
/// `range` of the hole (the hole itself counts as known, at time 1e6), then negate
/// the times of every cell it settled, the band included.
fn outward_pass(
    hole_state: &[u8],
    time: &mut [f32],
    band: &[usize],
    width: usize,
    height: usize,
    range: usize,
) {
    let stride = width + 2;
    let rows = height + 2;
    let near = dilate_square(|c| hole_state[c] == INSIDE, stride, rows, range);
    let mut state = vec![KNOWN; stride * rows];
    let mut in_band = vec![false; stride * rows];
    for &c in band {
        in_band[c] = true;
    }
    for i in 1..rows - 1 {
        for j in 1..stride - 1 {
            let c = i * stride + j;
            if near[c] && hole_state[c] != INSIDE && !in_band[c] {
                state[c] = INSIDE;
            }
        }
    }
    let mut front = Front::default();
    for &c in band {
        front.push(c, 0.0);
    }
    // Settled cells are marked with a value that is neither KNOWN nor INSIDE so
    // they can be found (and negated) afterwards.
    const SETTLED: u8 = 3;
    march(&mut front, &mut state, time, stride, SETTLED, |_| {});
    for (s, t) in state.iter().zip(time.iter_mut()) {
        if *s == SETTLED {
            *t = -*t;
        }
    }
}

/// Cells within Chebyshev distance `range` of a cell in `set` (a square dilation of
/// a `stride × rows` grid), via a summed-area table so the cost does not grow with
/// `range`.
pub(crate) fn dilate_square(
    set: impl Fn(usize) -> bool,
    stride: usize,
    rows: usize,
    range: usize,
) -> Vec<bool> {
    let sw = stride + 1;
    let mut sum = vec![0u32; sw * (rows + 1)];
    for i in 0..rows {
        let mut row_sum = 0u32;
        for j in 0..stride {
            row_sum += u32::from(set(i * stride + j));
            sum[(i + 1) * sw + j + 1] = sum[i * sw + j + 1] + row_sum;
        }
    }
    let mut out = vec![false; stride * rows];
    for i in 0..rows {
        let (i0, i1) = (i.saturating_sub(range), (i + range + 1).min(rows));
        for j in 0..stride {
            let (j0, j1) = (j.saturating_sub(range), (j + range + 1).min(stride));
            let total =
                sum[i1 * sw + j1] + sum[i0 * sw + j0] - sum[i0 * sw + j1] - sum[i1 * sw + j0];
            out[i * stride + j] = total > 0;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_hole_pixel_is_reached_at_time_one_and_a_half_sqrt2_rule() {
        // One hole pixel surrounded by a band at time 0: both axis neighbours known
        // with |a−b| < 1 gives (0 + 0 + sqrt(2)) / 2.
        let mut mask = vec![0u8; 25];
        mask[12] = 255;
        let order = fill_order(&mask, 5, 5, None);
        assert_eq!(order.order.len(), 1);
        let cell = order.order[0] as usize;
        assert_eq!(cell, 3 * 7 + 3);
        assert_eq!(order.time[cell], (2.0f64.sqrt() * 0.5) as f32);
    }

    #[test]
    fn equal_times_leave_in_raster_order_of_their_band_parents() {
        // A horizontal 1×3 hole: the band above is popped first (raster order), and
        // its pops reach the hole pixels left to right.
        let mut mask = vec![0u8; 5 * 3];
        mask[5 + 1..5 + 4].fill(1);
        let order = fill_order(&mask, 5, 3, None);
        let cols: Vec<usize> = order.order.iter().map(|&c| c as usize % 7 - 1).collect();
        assert_eq!(cols, vec![1, 2, 3]);
    }

    #[test]
    fn whole_image_hole_is_never_reached() {
        let mask = vec![1u8; 6];
        let order = fill_order(&mask, 3, 2, Some(2));
        assert!(order.order.is_empty());
        assert!(order.rank.iter().filter(|&&r| r == u32::MAX).count() == 6);
    }

    #[test]
    fn outward_pass_makes_the_ring_negative_and_leaves_far_pixels_alone() {
        let mut mask = vec![0u8; 11 * 11];
        mask[5 * 11 + 5] = 1;
        let order = fill_order(&mask, 11, 11, Some(2));
        let at = |x: usize, y: usize| order.time[(y + 1) * 13 + x + 1];
        assert!(
            at(5, 3) < 0.0 && at(3, 5) < 0.0,
            "ring within range is negative"
        );
        assert_eq!(at(0, 0), FAR, "pixels beyond range keep the initial time");
        assert!(
            at(5, 4) == 0.0 && at(5, 4).is_sign_negative(),
            "band is negated zero"
        );
    }
}
