//! The GPU exclusive prefix sum equals a sequential CPU scan.
mod support;

use objectsplat_raster_gpu::scan::GpuScan;
use support::{Rng, context};

fn cpu_exclusive_scan(values: &[u32]) -> Vec<u32> {
    let mut sum = 0u32;
    values
        .iter()
        .map(|&v| {
            let before = sum;
            sum = sum.wrapping_add(v);
            before
        })
        .collect()
}

#[test]
fn prefix_sum_matches_cpu_on_random_and_adversarial_inputs() {
    let Some(ctx) = context() else { return };
    let scan = GpuScan::new(&ctx);
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    // Sizes around the 1024-element block and the recursion boundary (1024 blocks).
    let sizes = [
        0usize,
        1,
        2,
        255,
        1023,
        1024,
        1025,
        4097,
        70_001,
        1024 * 1024 + 3,
    ];
    for &n in &sizes {
        let cases: Vec<(&str, Vec<u32>)> = vec![
            ("random", (0..n).map(|_| rng.next_u32() % 1000).collect()),
            ("all ones", vec![1; n]),
            ("zeros", vec![0; n]),
            ("wrapping", (0..n).map(|_| rng.next_u32()).collect()),
        ];
        for (name, values) in cases {
            let got = scan.exclusive_scan(&ctx, &values).unwrap();
            assert_eq!(got, cpu_exclusive_scan(&values), "{name}, n = {n}");
        }
    }
}
