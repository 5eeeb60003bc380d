//! Times the 3D Delaunay tetrahedralization and the full connectivity step
//! against point count. `cargo run --release -p objectsplat-train --example
//! bench_connectivity [-- --quick]`; compare with `benches/delaunay_peer.py`.

use objectsplat_train::connectivity::{ConnectivityOptions, restricted_delaunay};
use objectsplat_train::delaunay::tetrahedralize;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::time::Instant;

/// Points in the unit cube, and on a sphere of radius 1 with 1% radial noise.
fn clouds(n: usize, rng: &mut Pcg64Mcg) -> [(&'static str, Vec<[f64; 3]>); 2] {
    let cube = (0..n)
        .map(|_| [rng.random(), rng.random(), rng.random()])
        .collect();
    let sphere = (0..n)
        .map(|_| {
            loop {
                let p: [f64; 3] = [0, 1, 2].map(|_| rng.random::<f64>() * 2.0 - 1.0);
                let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                if l > 1e-3 && l <= 1.0 {
                    let s = (1.0 + 0.01 * (rng.random::<f64>() * 2.0 - 1.0)) / l;
                    break p.map(|c| c * s);
                }
            }
        })
        .collect();
    [("cube", cube), ("sphere", sphere)]
}

fn best_of(reps: usize, mut f: impl FnMut()) -> f64 {
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let sizes: &[usize] = if quick {
        &[1000, 10_000]
    } else {
        &[1000, 10_000, 50_000, 200_000]
    };
    let mut rng = Pcg64Mcg::seed_from_u64(1);
    println!("| points | cloud | tetrahedralize (s) | tets | connectivity step (s) | faces kept |");
    println!("|---|---|---|---|---|---|");
    for &n in sizes {
        for (name, pts) in clouds(n, &mut rng) {
            let reps = if n <= 10_000 { 3 } else { 1 };
            let mut tets = 0;
            let t_del = best_of(reps, || {
                tets = tetrahedralize(&pts, 0).expect("finite input").tets.len()
            });
            // A soup as after initialization: every third point carries a small
            // triangle (its corners are the next two points pulled close to it).
            let spacing = (1.0 / n as f64).cbrt();
            let mut verts: Vec<[f32; 3]> = pts.iter().map(|p| p.map(|c| c as f32)).collect();
            for i in (0..n - n % 3).step_by(3) {
                for j in 1..3 {
                    let d = [0, 1, 2].map(|k| pts[i + j][k] - pts[i][k]);
                    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-12);
                    verts[i + j] = [0, 1, 2].map(|k| (pts[i][k] + d[k] / l * spacing) as f32);
                }
            }
            let soup: Vec<[u32; 3]> = (0..n as u32 / 3)
                .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
                .collect();
            let mut kept = 0;
            let t_rdt = best_of(reps, || {
                kept = restricted_delaunay(&verts, &soup, ConnectivityOptions::default())
                    .expect("valid soup")
                    .len()
            });
            println!("| {n} | {name} | {t_del:.3} | {tets} | {t_rdt:.3} | {kept} |");
        }
    }
}
