//! The Metrics report averages per-image and per-object results and is written as JSON and CSV.
mod common;

use common::image;
use objectsplat_core::artifact::{METRICS_CSV, METRICS_JSON};
use objectsplat_core::{IdMap, ObjectLabels};
use objectsplat_metrics::report::ThresholdMetrics;
use objectsplat_metrics::{
    FScore, MeshFScores, MetricsReport, ObjectFScore, SsimMode, TestImage, assemble_report,
    evaluate_image, psnr, ssim,
};

fn fscore(p: f64, r: f64) -> FScore {
    FScore {
        precision: p,
        recall: r,
        fscore: 2.0 * p * r / (p + r),
        accuracy: Some(0.01),
        completeness: Some(0.02),
        tau: 0.05,
    }
}

#[test]
fn report_averages_images_and_objects_and_round_trips() {
    let a = image("astronaut.png");
    let pairs = [
        ("astronaut_noise.png", a.clone()),
        ("astronaut_blur.png", a.clone()),
    ];
    // Object 4 covers the left half of every frame; object 9 never appears.
    let mut ids = IdMap::new(a.width, a.height);
    for y in 0..a.height {
        for x in 0..a.width / 2 {
            ids.data[(y * a.width + x) as usize] = 4;
        }
    }
    let labels: ObjectLabels = [(4, "chair, red".to_string()), (9, "lamp".to_string())].into();
    let mut images = Vec::new();
    let mut expected_psnr = 0.0;
    for (name, gt) in &pairs {
        let rendered = image(name);
        let t = TestImage {
            name,
            rendered: &rendered,
            ground_truth: gt,
            valid: None,
            objects: Some(&ids),
        };
        let m = evaluate_image(&t, SsimMode::Gs3d, None, &[4, 9]).unwrap();
        assert_eq!(
            m.ssim.unwrap(),
            ssim(&rendered, gt, SsimMode::Gs3d, None).unwrap()
        );
        assert_eq!(m.objects.len(), 1, "object 9 is absent from the frame");
        expected_psnr += psnr(&rendered, gt, None).unwrap() / 2.0;
        images.push(m);
    }
    let object_psnr =
        (images[0].objects[0].psnr.unwrap() + images[1].objects[0].psnr.unwrap()) / 2.0;
    let mesh = MeshFScores {
        scene: fscore(0.8, 0.6),
        objects: vec![ObjectFScore {
            id: 4,
            fscore: Some(fscore(0.5, 0.5)),
            gt_points: 10,
            pred_points: 12,
            thresholds: vec![FScore {
                tau: 0.02,
                ..fscore(0.25, 0.5)
            }],
        }],
    };
    let report = assemble_report(
        images,
        Some(&mesh),
        Some(0.02),
        &labels,
        SsimMode::Gs3d,
        false,
    );
    assert!((report.scene.psnr.unwrap() - expected_psnr).abs() < 1e-12);
    assert_eq!(report.scene.lpips, None);
    assert!(report.lpips_status.starts_with("skipped"));
    assert_eq!(report.scene.fscore, Some(2.0 * 0.8 * 0.6 / 1.4));
    assert_eq!(report.objects[0].images, 2);
    assert!((report.objects[0].metrics.psnr.unwrap() - object_psnr).abs() < 1e-12);
    assert_eq!(report.objects[0].metrics.fscore, Some(0.5));
    assert_eq!(
        (report.objects[1].images, report.objects[1].metrics.psnr),
        (0, None)
    );

    assert_eq!(
        report.objects[0].thresholds,
        [ThresholdMetrics {
            tau: 0.02,
            fscore: Some(2.0 * 0.25 * 0.5 / 0.75),
            precision: Some(0.25),
            recall: Some(0.5),
        }]
    );
    assert!(report.objects[1].thresholds.is_empty());

    let dir = tempfile::tempdir().unwrap();
    report.write(dir.path()).unwrap();
    assert_eq!(MetricsReport::read(dir.path()).unwrap(), report);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join(METRICS_JSON)).unwrap())
            .unwrap();
    for key in [
        "psnr",
        "ssim",
        "lpips",
        "fscore",
        "precision",
        "recall",
        "tau",
        "objects",
        "images",
    ] {
        assert!(json.get(key).is_some(), "metrics.json lacks {key}");
    }
    assert!(json["lpips"].is_null());
    assert_eq!(json["objects"][0]["label"], "chair, red");
    assert_eq!(json["objects"][0]["thresholds"][0]["tau"], 0.02);
    assert_eq!(json["objects"][0]["thresholds"][0]["recall"], 0.5);
    assert!(json["objects"][1].get("thresholds").is_none());
    // Reports written before per-threshold scores existed still read (as none).
    let mut old = json.clone();
    old["objects"][0]
        .as_object_mut()
        .unwrap()
        .remove("thresholds");
    let old_dir = tempfile::tempdir().unwrap();
    std::fs::write(old_dir.path().join(METRICS_JSON), old.to_string()).unwrap();
    let read = MetricsReport::read(old_dir.path()).unwrap();
    assert!(read.objects[0].thresholds.is_empty());
    assert_eq!(read.objects[0].metrics, report.objects[0].metrics);

    let csv = std::fs::read_to_string(dir.path().join(METRICS_CSV)).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(
        lines[0],
        "scope,name,id,label,psnr,ssim,lpips,fscore,precision,recall,accuracy,completeness,tau,normal_consistency,exported_psnr,exported_ssim,background_in_front"
    );
    // Header, scene, two objects, one extra threshold of object 4, two images.
    assert_eq!(lines.len(), 1 + 1 + 2 + 1 + 2);
    assert!(
        lines[4].starts_with(
            "object_tau,\"chair, red\",4,\"chair, red\",,,,0.3333333333333333,0.25,0.5,,,0.02"
        ),
        "{}",
        lines[4]
    );
    assert!(
        lines[2].starts_with("object,\"chair, red\",4,\"chair, red\","),
        "{}",
        lines[2]
    );
}

#[test]
fn infinite_psnr_is_written_as_null() {
    let a = image("coffee.png");
    let t = TestImage {
        name: "same",
        rendered: &a,
        ground_truth: &a,
        valid: None,
        objects: None,
    };
    let m = evaluate_image(&t, SsimMode::Cropped, None, &[]).unwrap();
    let report = assemble_report(
        vec![m],
        None,
        None,
        &ObjectLabels::new(),
        SsimMode::Cropped,
        false,
    );
    let json = serde_json::to_value(&report).unwrap();
    assert!(json["psnr"].is_null());
    assert_eq!(json["ssim"], 1.0);
}
