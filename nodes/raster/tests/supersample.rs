//! Supersampling against independent computations: an `s × s` render
//! box-filtered equals the mean of `s²` one-sample renders whose cameras are
//! shifted by the samples' sub-pixel offsets, and spreading a gradient is the
//! adjoint of the box filter.

mod common;

use common::*;
use objectsplat_core::Camera;
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::supersample::{downsample_into, fine_view, spread_into, validate};
use objectsplat_raster::{CpuBackend, Model, RenderBackend, RenderOutput, RenderSettings};

fn render(model: &Model<f64>, camera: &Camera, settings: &RenderSettings) -> RenderOutput<f64> {
    let pixels = camera.width as usize * camera.height as usize;
    let bg: Vec<f64> = (0..3 * pixels).map(|i| [0.2, 0.5, 0.7][i % 3]).collect();
    CpuBackend::new(2)
        .forward(model, camera, settings, &bg)
        .expect("valid scene")
        .0
}

fn max_difference(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

#[test]
fn a_supersampled_render_is_the_mean_of_shifted_one_sample_renders() {
    for s in [2u32, 4] {
        for seed in 0..3 {
            let (model, camera) = gradient_scene(seed);
            let settings = settings(0.6, 3);
            let (fine_camera, fine_settings) = fine_view(&camera, &settings, s);
            let mut coarse = RenderOutput::default();
            downsample_into(
                1,
                &render(&model, &fine_camera, &fine_settings),
                s,
                &mut coarse,
            )
            .expect("whole blocks");

            // Sample (a, b) of pixel i lies at i + (a + 0.5)/s: a camera whose
            // principal point moves by 0.5 − (a + 0.5)/s puts it at i + 0.5.
            let mut mean = RenderOutput::<f64>::default();
            let mut max_weight = vec![0.0f64; model.face_count()];
            for b in 0..s {
                for a in 0..s {
                    let shift = |k: u32| 0.5 - (k as f64 + 0.5) / s as f64;
                    let shifted = Camera {
                        cx: camera.cx + shift(a),
                        cy: camera.cy + shift(b),
                        ..camera
                    };
                    let out = render(&model, &shifted, &settings);
                    let add = |sum: &mut Vec<f64>, v: &[f64]| {
                        sum.resize(v.len(), 0.0);
                        for (s, x) in sum.iter_mut().zip(v) {
                            *s += x;
                        }
                    };
                    add(&mut mean.color, &out.color);
                    add(&mut mean.alpha, &out.alpha);
                    add(&mut mean.depth, &out.depth);
                    for (m, w) in max_weight.iter_mut().zip(&out.face_max_weight) {
                        *m = m.max(*w);
                    }
                }
            }
            let n = (s * s) as f64;
            for plane in [&mut mean.color, &mut mean.alpha, &mut mean.depth] {
                plane.iter_mut().for_each(|v| *v /= n);
            }
            assert_eq!((coarse.width, coarse.height), (camera.width, camera.height));
            assert_eq!(coarse.region, PixelRect::full(camera.width, camera.height));
            assert!(
                coarse.alpha.iter().any(|&a| a > 0.0 && a < 0.9),
                "the scene has partly covered pixels"
            );
            for (name, got, want) in [
                ("colour", &coarse.color, &mean.color),
                ("alpha", &coarse.alpha, &mean.alpha),
                ("depth", &coarse.depth, &mean.depth),
                ("face max weight", &coarse.face_max_weight, &max_weight),
            ] {
                let d = max_difference(got, want);
                assert!(d < 1e-9, "s = {s}, seed {seed}: {name} differs by {d:e}");
            }
        }
    }
}

#[test]
fn spreading_a_gradient_is_the_adjoint_of_the_box_filter() {
    let mut rng = Rng(11);
    for s in [1u32, 2, 4] {
        // A footprint region of whole 16-sample tiles inside a 96×64 fine image.
        let fine_region = PixelRect {
            x0: 16,
            y0: 32,
            x1: 80,
            y1: 64,
        };
        let samples = fine_region.pixels();
        let fine = RenderOutput::<f64> {
            width: 96,
            height: 64,
            region: fine_region,
            color: (0..3 * samples).map(|_| rng.uniform(-1.0, 1.0)).collect(),
            alpha: (0..samples).map(|_| rng.uniform(0.0, 1.0)).collect(),
            depth: (0..samples).map(|_| rng.uniform(0.0, 5.0)).collect(),
            median_depth: (0..samples).map(|_| rng.uniform(0.0, 5.0)).collect(),
            face_max_weight: vec![0.5],
            face_pixel_count: vec![7],
        };
        let mut coarse = RenderOutput::default();
        downsample_into(1, &fine, s, &mut coarse).expect("whole blocks");
        // Rows spread over threads: the same values, bit for bit.
        let mut on_threads = RenderOutput::default();
        downsample_into(3, &fine, s, &mut on_threads).expect("whole blocks");
        assert_eq!(on_threads, coarse);
        assert_eq!(coarse.region.pixels() * (s * s) as usize, samples);
        assert_eq!(coarse.face_pixel_count, vec![7u32.div_ceil(s * s)]);
        for (channels, coarse_plane, fine_plane) in [
            (3, &coarse.color, &fine.color),
            (1, &coarse.alpha, &fine.alpha),
        ] {
            let g: Vec<f64> = (0..coarse_plane.len())
                .map(|_| rng.uniform(-1.0, 1.0))
                .collect();
            let mut spread = Vec::new();
            spread_into(1, &g, channels, coarse.region, s, &mut spread);
            let mut on_threads = vec![7.0; 3];
            spread_into(3, &g, channels, coarse.region, s, &mut on_threads);
            assert_eq!(on_threads, spread);
            let lhs: f64 = g.iter().zip(coarse_plane.iter()).map(|(a, b)| a * b).sum();
            let rhs: f64 = spread
                .iter()
                .zip(fine_plane.iter())
                .map(|(a, b)| a * b)
                .sum();
            assert!(
                (lhs - rhs).abs() < 1e-9 * lhs.abs().max(1.0),
                "s = {s}: ⟨g, Dx⟩ = {lhs} but ⟨Sg, x⟩ = {rhs}"
            );
        }
    }
}

#[test]
fn factors_and_regions_that_do_not_divide_are_refused() {
    for s in [0u32, 3, 5, 8] {
        let e = validate(s).expect_err("unsupported factor");
        assert!(e.to_string().contains("must be 1, 2 or 4"), "{e}");
    }
    let odd = RenderOutput::<f64> {
        width: 64,
        height: 64,
        region: PixelRect {
            x0: 3,
            y0: 0,
            x1: 64,
            y1: 64,
        },
        ..Default::default()
    };
    let e = downsample_into(1, &odd, 2, &mut RenderOutput::default()).expect_err("odd region");
    assert!(e.to_string().contains("not whole 2×2 blocks"), "{e}");
}

#[test]
fn footprint_regions_scale_with_the_factor() {
    let settings = RenderSettings {
        region: Region::Footprint {
            include: PixelRect {
                x0: 5,
                y0: 6,
                x1: 20,
                y1: 30,
            },
            margin: 4,
        },
        ..Default::default()
    };
    let camera = identity_camera(40, 36, 36.0);
    let (fine, fine_settings) = fine_view(&camera, &settings, 2);
    assert_eq!((fine.width, fine.height), (80, 72));
    assert_eq!((fine.fx, fine.cx), (72.0, camera.cx * 2.0));
    assert_eq!(
        fine_settings.region,
        Region::Footprint {
            include: PixelRect {
                x0: 10,
                y0: 12,
                x1: 40,
                y1: 60,
            },
            margin: 8,
        }
    );
}
