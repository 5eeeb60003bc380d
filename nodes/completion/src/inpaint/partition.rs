//! Splitting the fill into parts that can run on separate threads.
//!
//! Computing a hole pixel reads cells (values and known-flags) within Chebyshev
//! distance `range + 1` of it: samples within `range`, gradient taps one further.
//! Hole pixels farther apart than that never see each other, so groups of holes
//! separated by more than `range + 1` can be replayed independently, each in
//! global fill order, and give bit-identical results.

use super::march::{FillOrder, dilate_square};

/// Hole pixels split into at most `bins` groups of non-interacting clusters, each
/// list in global fill order, balanced greedily by pixel count (largest first).
pub(crate) fn balanced_bins(
    order: &FillOrder,
    rows: usize,
    range: usize,
    bins: usize,
) -> Vec<Vec<u32>> {
    let stride = order.stride;
    // Squares of half-size h around two pixels touch (8-connectedly) when the pixels
    // are at most 2h + 1 apart, which must cover range + 1.
    let half = range.div_ceil(2);
    let near = dilate_square(|c| order.rank[c] != 0, stride, rows, half);
    let label = label_components(&near, stride, rows);

    let mut sizes = std::collections::HashMap::<u32, usize>::new();
    for &cell in &order.order {
        *sizes.entry(label[cell as usize]).or_default() += 1;
    }
    let mut by_size: Vec<(u32, usize)> = sizes.into_iter().collect();
    by_size.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let mut load = vec![0usize; bins.max(1)];
    let mut bin_of = std::collections::HashMap::<u32, usize>::new();
    for (id, size) in by_size {
        // `load` is non-empty, so a minimum exists.
        let (bin, _) = load
            .iter()
            .enumerate()
            .min_by_key(|(_, l)| **l)
            .expect("at least one bin");
        load[bin] += size;
        bin_of.insert(id, bin);
    }
    let mut out = vec![Vec::new(); load.len()];
    for &cell in &order.order {
        out[bin_of[&label[cell as usize]]].push(cell);
    }
    out.retain(|b| !b.is_empty());
    out
}

/// 8-connected component labels of `set` (0 outside it).
fn label_components(set: &[bool], stride: usize, rows: usize) -> Vec<u32> {
    let mut label = vec![0u32; set.len()];
    let mut next = 0u32;
    let mut stack = Vec::new();
    for start in 0..set.len() {
        if !set[start] || label[start] != 0 {
            continue;
        }
        next += 1;
        label[start] = next;
        stack.push(start);
        while let Some(c) = stack.pop() {
            let (i, j) = ((c / stride) as i64, (c % stride) as i64);
            for di in -1..=1i64 {
                for dj in -1..=1i64 {
                    let (ni, nj) = (i + di, j + dj);
                    if ni < 0 || nj < 0 || ni >= rows as i64 || nj >= stride as i64 {
                        continue;
                    }
                    let n = ni as usize * stride + nj as usize;
                    if set[n] && label[n] == 0 {
                        label[n] = next;
                        stack.push(n);
                    }
                }
            }
        }
    }
    label
}

#[cfg(test)]
mod tests {
    use super::super::march::fill_order;
    use super::*;

    #[test]
    fn holes_farther_apart_than_the_reach_split_and_closer_ones_do_not() {
        let (w, h, range) = (40usize, 5usize, 3usize);
        // Reach is range + 1 = 4; with half-size 2 squares merge up to 5 apart.
        for (gap, expect_split) in [(range + 1, false), (range + 3, true)] {
            let mut mask = vec![0u8; w * h];
            mask[2 * w + 5] = 1;
            mask[2 * w + 5 + gap] = 1;
            let order = fill_order(&mask, w, h, None);
            let bins = balanced_bins(&order, h + 2, range, 2);
            assert_eq!(bins.len() == 2, expect_split, "gap {gap}");
        }
    }
}
