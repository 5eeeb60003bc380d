//! The `viewer` page draws a member's view-dependent colour (its SH bands) as the
//! project's renderer does from the same camera — a turned object included, whose
//! bands turn with it — not only the DC colour: a screenshot in headless Chromium
//! matches `render_view` of the scene to a few 8-bit steps on all but its edge pixels,
//! while the same scene drawn without its bands does not.

mod support;

use objectsplat_core::artifact::PAGE_HTML;
use objectsplat_raster::{Model, SH_COEFFS};
use objectsplat_scene::render::{Backdrop, render_view};
use support::chromium::{Browser, numbers};

const WIDTH: u32 = 900;
const HEIGHT: u32 = 600;
/// The page's backdrop colour (viewer.js `BACKDROP`).
const BACKDROP: [f32; 3] = [0.16, 0.17, 0.19];

/// Bands 1–3 of every vertex from a fixed sequence, strong enough to tint by ±0.2.
fn with_bands(model: &mut Model<f32>, salt: u32) {
    model.sh_degree = 3;
    let mut state = 0x9e37_79b9u32 ^ salt;
    for rows in &mut model.sh {
        for row in rows.iter_mut().take(SH_COEFFS).skip(1) {
            for c in row.iter_mut() {
                // xorshift: deterministic, no dependency.
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                *c = (state as f32 / u32::MAX as f32 - 0.5) * 0.4;
            }
        }
    }
}

/// Per-pixel largest channel difference (in 8-bit steps) between two RGB images.
fn differences(a: &[f32], b: &[f32]) -> Vec<f32> {
    a.chunks(3)
        .zip(b.chunks(3))
        .map(|(p, q)| {
            (0..3)
                .map(|k| (p[k] - q[k]).abs() * 255.0)
                .fold(0.0f32, f32::max)
        })
        .collect()
}

fn quantile(values: &[f32], q: f64) -> f32 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f32::total_cmp);
    sorted[((sorted.len() - 1) as f64 * q) as usize]
}

#[test]
fn viewer_draws_the_sh_bands_as_the_renderer_does() {
    let Some(mut browser) = Browser::launch("viewer_draws_the_sh_bands_as_the_renderer_does")
    else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let mut scene = support::small_scene::scene();
    for (k, member) in scene.objects.iter_mut().enumerate() {
        with_bands(&mut member.model, k as u32);
    }
    let scene = support::viewer_page::edited(
        scene,
        &[
            "Rotate(target: Id(7), axis: (1, 0.5, 0), degrees: 70)",
            "Move(target: Id(7), by: (0.1, -0.2, 0.3))",
        ],
    );
    let (dir, start) = support::viewer_page::viewer_of(&scene, tmp.path());

    let mut page = browser.open(&dir.join(PAGE_HTML), WIDTH, HEIGHT);
    page.eval("window.objectsplat.ready");
    let rect: [f64; 4] = numbers(&page.eval(
        "(() => { const r = document.querySelector('.osv-canvas').getBoundingClientRect(); return [r.x, r.y, r.width, r.height]; })()",
    ));
    let shot = page.screenshot(rect);
    let errors = page.errors();
    assert!(errors.is_empty(), "console errors: {errors:#?}");
    let (w, h) = shot.dimensions();
    let camera = support::viewer_page::page_camera(&start, w, h);
    let page_rgb: Vec<f32> = shot
        .pixels()
        .flat_map(|p| [0, 1, 2].map(|k| p.0[k] as f32 / 255.0))
        .collect();
    let render = |model: &Model<f32>| {
        render_view(
            model,
            &camera,
            &Backdrop::Uniform(BACKDROP),
            &objectsplat_raster::CpuBackend::new(2),
            1,
        )
        .unwrap()
        .to_rgb()
        .data
    };
    let merged = scene.merged_model().unwrap().model;
    let with_bands = differences(&page_rgb, &render(&merged));
    let mut dc_only = merged.clone();
    dc_only.sh_degree = 0;
    let without_bands = differences(&page_rgb, &render(&dc_only));
    let (median, p95) = (quantile(&with_bands, 0.5), quantile(&with_bands, 0.95));
    let (dc_median, dc_p95) = (
        quantile(&without_bands, 0.5),
        quantile(&without_bands, 0.95),
    );
    eprintln!(
        "page vs render, 8-bit steps: median {median}, 95th percentile {p95}; without the bands {dc_median}, {dc_p95}"
    );
    // Edges (rasterization rules, the renderer's per-tile depth order) and the
    // backdrop are a few per cent of the pixels; everywhere else the colours agree.
    assert!(median <= 1.0 && p95 <= 4.0, "median {median}, p95 {p95}");
    assert!(
        dc_p95 >= 10.0,
        "the bands must show: without them the page would match to p95 {dc_p95}"
    );
}
