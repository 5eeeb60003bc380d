//! The GPU radix sort equals a stable CPU sort by key (ties keep input order).
mod support;

use objectsplat_raster_gpu::scan::GpuScan;
use objectsplat_raster_gpu::sort::{GpuSort, key_bits};
use support::{Rng, context};

fn cpu_stable_sort(keys: &[u32], values: &[u32], bits: u32) -> (Vec<u32>, Vec<u32>) {
    let mask = if bits >= 32 {
        u32::MAX
    } else {
        (1u32 << bits) - 1
    };
    let mut pairs: Vec<(u32, u32)> = keys.iter().copied().zip(values.iter().copied()).collect();
    pairs.sort_by_key(|&(k, _)| k & mask);
    pairs.into_iter().unzip()
}

#[test]
fn radix_sort_is_stable_and_matches_cpu() {
    let Some(ctx) = context() else { return };
    let scan = GpuScan::new(&ctx);
    let sort = GpuSort::new(&ctx);
    let mut rng = Rng(42);
    for &n in &[0usize, 1, 2, 127, 2047, 2048, 2049, 5000, 100_003] {
        // Values are the input positions, so stability is visible in the output.
        let values: Vec<u32> = (0..n as u32).collect();
        let cases: Vec<(&str, Vec<u32>, u32)> = vec![
            (
                "random 32-bit",
                (0..n).map(|_| rng.next_u32()).collect(),
                32,
            ),
            (
                "random 13-bit",
                (0..n).map(|_| rng.next_u32() % 5000).collect(),
                key_bits(4999),
            ),
            (
                "few distinct (ties)",
                (0..n).map(|_| rng.next_u32() % 3).collect(),
                2,
            ),
            ("all equal", vec![7; n], 3),
            ("sorted", (0..n as u32).collect(), 32),
            ("reverse", (0..n as u32).rev().collect(), key_bits(n as u32)),
            (
                "odd pass count",
                (0..n).map(|_| rng.next_u32() % 4096).collect(),
                12,
            ),
        ];
        for (name, keys, bits) in cases {
            let got = sort.sort_pairs(&ctx, &scan, &keys, &values, bits).unwrap();
            assert_eq!(
                got,
                cpu_stable_sort(&keys, &values, bits),
                "{name}, n = {n}"
            );
        }
    }
}

#[test]
fn key_bits_counts_the_highest_set_bit() {
    assert_eq!(key_bits(0), 0);
    assert_eq!(key_bits(1), 1);
    assert_eq!(key_bits(15), 4);
    assert_eq!(key_bits(16), 5);
    assert_eq!(key_bits(u32::MAX), 32);
}
