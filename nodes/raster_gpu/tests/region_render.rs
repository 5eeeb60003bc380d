//! Footprint regions on the wgpu backend: the rendered region is the CPU
//! backend's (the drawn faces' pixel box ∪ include, grown by the margin and
//! rounded out to whole tiles), pixels inside it are bit-identical to a full
//! wgpu render of the same scene, and the region's outputs and gradients
//! (background included) match the CPU backend's region render within the
//! whole-frame parity tolerances (1e-4 absolute, 1e-3 norm-relative).
mod support;

use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::loss::CROP_MARGIN;
use objectsplat_raster::{CpuBackend, Model, OutputGrads, RenderBackend, RenderSettings};
use support::{
    Rng, Scene, backend, paired_outputs, parity_scenes, relative_difference, small_object_scene,
};

/// The scenes and regions checked: a small object (a fraction of its frame),
/// an include rectangle beyond the faces, a margin reaching the image border,
/// an empty model with an include only, and one with nothing at all.
fn cases() -> Vec<(Scene, Region)> {
    let mut cases = Vec::new();
    let footprint = |include, margin| Region::Footprint { include, margin };
    cases.push((
        small_object_scene(60, 11),
        footprint(PixelRect::default(), CROP_MARGIN),
    ));
    let include = PixelRect {
        x0: 3,
        y0: 70,
        x1: 9,
        y1: 75,
    };
    cases.push((small_object_scene(40, 12), footprint(include, 5)));
    let mut soup = parity_scenes().swap_remove(1);
    soup.name = "random soup, margin 40".into();
    cases.push((soup, footprint(PixelRect::default(), 40)));
    let mut empty = small_object_scene(0, 13);
    empty.name = "no faces, include only".into();
    cases.push((empty, footprint(include, CROP_MARGIN)));
    let mut nothing = small_object_scene(0, 14);
    nothing.name = "no faces, nothing included".into();
    cases.push((nothing, footprint(PixelRect::default(), CROP_MARGIN)));
    cases
}

fn with_region(s: &Scene, region: Region) -> RenderSettings {
    RenderSettings {
        region,
        ..s.settings.clone()
    }
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// The part of a whole-image buffer (`channels` per pixel) that `region` covers.
fn crop(full: &[f32], width: u32, region: PixelRect, channels: usize) -> Vec<f32> {
    let mut out = Vec::new();
    for y in region.y0..region.y1 {
        let row = (y * width) as usize;
        out.extend_from_slice(
            &full[channels * (row + region.x0 as usize)..channels * (row + region.x1 as usize)],
        );
    }
    out
}

#[test]
fn a_footprint_render_is_the_full_render_inside_the_cpu_region() {
    let Some(gpu) = backend() else { return };
    let cpu = CpuBackend::new(2);
    let mut strict_subsets = 0;
    for (s, region) in cases() {
        let settings = with_region(&s, region);
        let (want, _) = s.render_on(&cpu, &settings);
        let (got, _) = s.render_on(&gpu, &settings);
        let (full, _) = s.render_on(&gpu, &s.settings);
        eprintln!(
            "{}: region {:?} ({} of {} pixels)",
            s.name,
            got.region,
            got.region.pixels(),
            s.camera.width * s.camera.height
        );
        assert_eq!(got.region, want.region, "{}: region", s.name);
        assert_eq!(
            full.region,
            PixelRect::full(s.camera.width, s.camera.height)
        );
        if got.region.pixels() < full.region.pixels() {
            strict_subsets += 1;
        }
        let r = got.region;
        let w = s.camera.width;
        for (what, a, b) in [
            ("color", &got.color, crop(&full.color, w, r, 3)),
            ("alpha", &got.alpha, crop(&full.alpha, w, r, 1)),
            ("depth", &got.depth, crop(&full.depth, w, r, 1)),
            (
                "median depth",
                &got.median_depth,
                crop(&full.median_depth, w, r, 1),
            ),
        ] {
            assert_eq!(
                bits(a),
                bits(&b),
                "{}: {what} differs from the full render",
                s.name
            );
        }
        assert_eq!(
            bits(&got.face_max_weight),
            bits(&full.face_max_weight),
            "{}",
            s.name
        );
        assert_eq!(got.face_pixel_count, full.face_pixel_count, "{}", s.name);
    }
    assert!(strict_subsets >= 3, "the cases must crop: {strict_subsets}");
}

#[test]
fn footprint_outputs_and_gradients_match_the_cpu_backend() {
    let Some(gpu) = backend() else { return };
    let cpu = CpuBackend::new(2);
    let mut rng = Rng(31);
    for (s, region) in cases() {
        let settings = with_region(&s, region);
        let (want, cpu_saved) = s.render_on(&cpu, &settings);
        let (got, gpu_saved) = s.render_on(&gpu, &settings);
        for (what, a, b) in paired_outputs(&got, &want) {
            assert_eq!(a.len(), b.len(), "{}: {what}", s.name);
            let d = a
                .iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f32::max);
            assert!(d <= 1e-4, "{}: {what} differs by {d}", s.name);
        }
        assert_eq!(got.face_pixel_count, want.face_pixel_count, "{}", s.name);

        let pixels = got.region.pixels();
        let upstream = support::upstream(&mut rng, pixels);
        let grads = support::every_output(&upstream);
        let want = cpu.backward(&s.model, &cpu_saved, &grads).unwrap();
        let got = gpu.backward(&s.model, &gpu_saved, &grads).unwrap();
        assert_eq!(got.background.len(), pixels * 3, "{}", s.name);
        let sh = |g: &[[[f32; 3]; objectsplat_raster::SH_COEFFS]]| -> Vec<f32> {
            g.iter().flatten().flatten().copied().collect()
        };
        for (what, a, b) in [
            ("vertices", got.vertices.concat(), want.vertices.concat()),
            ("sh", sh(&got.sh), sh(&want.sh)),
            (
                "opacity logits",
                got.opacity_logits.clone(),
                want.opacity_logits.clone(),
            ),
            (
                "background",
                got.background.clone(),
                want.background.clone(),
            ),
        ] {
            let d = relative_difference(&a, &b, 1e-12);
            let zero = b.iter().all(|&x| x == 0.0) && a.iter().all(|&x| x == 0.0);
            assert!(
                d <= 1e-3 || zero,
                "{}: {what} gradient differs by {d:.3e}",
                s.name
            );
        }
    }
}

#[test]
fn a_region_gradient_of_the_wrong_size_is_an_error() {
    let Some(gpu) = backend() else { return };
    let (s, region) = cases().swap_remove(0);
    let (out, saved) = s.render_on(&gpu, &with_region(&s, region));
    let whole = vec![0.1f32; (s.camera.width * s.camera.height * 3) as usize];
    assert!(out.region.pixels() * 3 < whole.len());
    let err = gpu
        .backward(&s.model, &saved, &OutputGrads::color_only(&whole))
        .unwrap_err();
    assert!(format!("{err:#}").contains("dL/dcolor"), "{err:#}");
    let _: &Model<f32> = &s.model;
}
