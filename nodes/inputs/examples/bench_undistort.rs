//! Undistortion cost at ScanNet++ DSLR size (1752×1168, OPENCV_FISHEYE): choosing the
//! pinhole camera, building the per-pixel map (once per camera) and resampling one RGB
//! frame (once per frame). Compare with OpenCV in the same run:
//!
//!     cargo run --release -p objectsplat-inputs --example bench_undistort
//!     python3 nodes/inputs/benches/undistort_opencv.py     (numpy, opencv-python-headless)
//!
//! Prints the median of 7 runs of each step, in milliseconds.

use objectsplat_core::Image;
use objectsplat_inputs::undistort::{Distortion, Intrinsics, UndistortMap, undistorted_camera};
use std::time::Instant;

fn median_ms(mut f: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..7)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[3]
}

fn main() -> anyhow::Result<()> {
    // A ScanNet++-like DSLR camera (the same numbers as benches/undistort_opencv.py).
    let camera = Intrinsics {
        width: 1752,
        height: 1168,
        fx: 1150.0,
        fy: 1150.0,
        cx: 876.0,
        cy: 584.0,
    };
    let distortion = Distortion::Fisheye {
        k: [-0.03, -0.005, 0.0007, -0.0002],
    };
    let image = Image::from_fn(camera.width, camera.height, 3, |x, y, c| {
        ((x * 3 + y * 7 + c * 50) % 256) as f32 / 255.0
    });
    let mut target = camera;
    let choose = median_ms(|| target = undistorted_camera(&camera, &distortion).unwrap());
    let mut map = UndistortMap::new(camera, &distortion, target);
    let build = median_ms(|| map = UndistortMap::new(camera, &distortion, target));
    let apply = median_ms(|| {
        std::hint::black_box(map.apply(&image).unwrap());
    });
    println!(
        "pinhole camera {}×{} (fx {:.1}, cx {:.2}, cy {:.2})",
        target.width, target.height, target.fx, target.cx, target.cy
    );
    println!(
        "choose camera: {choose:.2} ms; build map: {build:.1} ms; resample one frame: {apply:.1} ms"
    );
    Ok(())
}
