//! `evaluate` with the `exported` renders scores them beside the trained ones: an
//! exported render that differs from the photo by a known amount inside one object's
//! mask gives known scene and per-object `exported_psnr`; without the input the
//! fields are null.

#[path = "../../scene/tests/common/mod.rs"]
mod common;

use objectsplat_core::artifact::{METRICS_CSV, METRICS_JSON};
use objectsplat_core::masks::{IdMap, write_objects};
use objectsplat_core::{ObjectLabels, Split};
use objectsplat_evaluate::Evaluate;

const W: u32 = 48;
const H: u32 = 40;
/// The offset the exported render carries inside the chair's mask: exactly 10/255.
const OFFSET: u8 = 10;

#[test]
fn exported_psnr_matches_its_analytic_value() {
    let tmp = tempfile::tempdir().unwrap();
    let scene_dir = common::composed_scene(tmp.path());
    let cam = common::front_camera(W, H);
    let frames = common::write_frames_from(tmp.path(), cam, &[("t0", Split::Test)]);
    let renders = common::rendered(&scene_dir, &frames, &tmp.path().join("r"));

    // Ground truth = the render, but brighter by 1/255 everywhere, so the trained
    // render's PSNR is finite (20·log10(255) = 48.13 dB).
    let rendered = image::open(renders.join("t0.png")).unwrap().to_rgb8();
    let mut truth = rendered.clone();
    for c in truth.iter_mut() {
        *c = c.checked_add(1).expect("no saturation in the test image");
    }
    truth.save(frames.join("images/t0.png")).unwrap();
    // The exported render: the render, darker by OFFSET − 1 inside the chair's
    // rectangle, so it misses the truth there by exactly OFFSET and by 1 elsewhere.
    let mut exported_image = rendered.clone();
    let mut ids = IdMap::new(W, H);
    let (x0, x1, y0, y1) = (5u32, 17u32, 8u32, 20u32);
    for y in y0..y1 {
        for x in x0..x1 {
            ids.data[(y * W + x) as usize] = 3;
            for c in exported_image.get_pixel_mut(x, y).0.iter_mut() {
                *c = c
                    .checked_sub(OFFSET - 1)
                    .expect("no saturation in the test image");
            }
        }
    }
    let exported = tmp.path().join("x");
    std::fs::create_dir_all(&exported).unwrap();
    exported_image.save(exported.join("t0.png")).unwrap();
    let masks = tmp.path().join("masks");
    std::fs::create_dir_all(&masks).unwrap();
    ids.save(&masks.join("t0.png")).unwrap();
    let labels: ObjectLabels = [(3, "chair".to_string())].into();
    write_objects(&masks, &labels).unwrap();

    let evaluate = |with_exported: bool, out: &str| {
        let mut inputs = vec![
            ("images", renders.as_path()),
            ("frames", frames.as_path()),
            ("scene", scene_dir.as_path()),
            ("masks", masks.as_path()),
        ];
        if with_exported {
            inputs.push(("exported", exported.as_path()));
        }
        let run = common::run(&Evaluate, &inputs, "()", &tmp.path().join(out));
        run.outputs["metrics"].clone()
    };
    let dir = evaluate(true, "eval");
    let m = common::read_json(&dir.join(METRICS_JSON));
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    let one = 1.0 / 255.0;
    let d = OFFSET as f64 / 255.0;
    let region = ((x1 - x0) * (y1 - y0)) as f64;
    let pixels = (W * H) as f64;
    let mse = (region * d * d + (pixels - region) * one * one) / pixels;
    let close = |a: f64, b: f64| (a - b).abs() < 1e-4;
    assert!(close(f(&m["psnr"]), -20.0 * one.log10()), "{}", m["psnr"]);
    assert!(
        close(f(&m["exported_psnr"]), -10.0 * mse.log10()),
        "{} vs {}",
        m["exported_psnr"],
        -10.0 * mse.log10()
    );
    assert!(f(&m["exported_ssim"]) < f(&m["ssim"]));
    let chair = &m["objects"][0];
    assert_eq!(chair["id"], 3);
    assert!(close(f(&chair["psnr"]), -20.0 * one.log10()));
    assert!(close(f(&chair["exported_psnr"]), -20.0 * d.log10()));
    let csv = std::fs::read_to_string(dir.join(METRICS_CSV)).unwrap();
    assert!(csv.lines().next().unwrap().contains("exported_psnr"));

    // Without the exported renders there is nothing to report.
    let m = common::read_json(&evaluate(false, "plain").join(METRICS_JSON));
    assert!(m["exported_psnr"].is_null() && m["objects"][0]["exported_psnr"].is_null());
}
