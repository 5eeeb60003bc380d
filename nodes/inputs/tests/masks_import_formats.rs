//! Every mask format imports to the id maps and labels computed independently (with numpy)
//! in tests/fixtures/masks/make_fixtures.py, under each overlap policy.

use objectsplat_core::artifact::OBJECTS_JSON;
use objectsplat_core::masks::{IdMap, read_objects};
use objectsplat_inputs::masks_import::{self, MaskFormat, OverlapPolicy};
use serde_json::Value;
use std::path::PathBuf;

mod common;

fn fixture(name: &str) -> PathBuf {
    common::fixture("masks").join(name)
}

fn expected(case: &str) -> Value {
    common::read_json(&fixture("expected.json"))[case].clone()
}

fn run(
    source: &str,
    format: MaskFormat,
    policy: OverlapPolicy,
    case: &str,
) -> masks_import::ImportSummary {
    let out = tempfile::tempdir().unwrap();
    let summary = masks_import::import(
        &fixture(source),
        format,
        policy,
        &fixture("frames"),
        out.path(),
        |_, _| {},
    )
    .unwrap();
    let exp = expected(case);
    for (f, want) in ["f000", "f001", "f002"]
        .iter()
        .zip(exp["maps"].as_array().unwrap())
    {
        let got = IdMap::load(&out.path().join(format!("{f}.png"))).unwrap();
        let want: Vec<u16> = want
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|r| {
                r.as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_u64().unwrap() as u16)
            })
            .collect();
        assert_eq!((got.width, got.height), (16, 12), "{case} {f}");
        assert_eq!(got.data, want, "{case} {f}");
    }
    let labels = read_objects(out.path()).unwrap();
    let want: Vec<(u16, String)> = exp["labels"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.parse().unwrap(), v.as_str().unwrap().to_string()))
        .collect();
    let mut want = want;
    want.sort();
    assert_eq!(labels.into_iter().collect::<Vec<_>>(), want, "{case}");
    summary
}

#[test]
fn coco_rle_json_under_every_policy() {
    for (policy, name) in [
        (OverlapPolicy::LowerId, "lower_id"),
        (OverlapPolicy::SmallerArea, "smaller_area"),
        (OverlapPolicy::HigherScore, "higher_score"),
    ] {
        let s = run(
            "coco_rle",
            MaskFormat::CocoRle,
            policy,
            &format!("coco_rle/{name}"),
        );
        assert!(s.overlapping_pixels > 0);
        let hidden = expected(&format!("coco_rle/{name}"))["hidden"]
            .as_u64()
            .unwrap() as usize;
        assert_eq!(s.hidden_masks, hidden, "{name}");
        assert_eq!(s.objects.len(), 7 - hidden, "{name}");
        assert!(s.objects.iter().all(|o| o.frames_present == 1));
    }
}

#[test]
fn davis_reads_palette_indices_and_drops_void() {
    let s = run("davis", MaskFormat::Davis, OverlapPolicy::LowerId, "davis");
    assert_eq!(s.void_pixels, 6);
    assert_eq!(s.frames_without_masks, ["f002.jpg"]);
    // Object 2 (source index 9) is a circle moving right: same area in both frames.
    let o = &s.objects[1];
    assert_eq!(
        (o.id, o.frames_present, o.area_min, o.area_max),
        (2, 2, o.area_min, o.area_min)
    );
    assert_eq!(o.area_cv, 0.0);
}

#[test]
fn sav_per_object_folders_keep_ids_across_frames() {
    let s = run(
        "sav",
        MaskFormat::PerObjectPng,
        OverlapPolicy::LowerId,
        "sav/lower_id",
    );
    assert_eq!(
        s.objects
            .iter()
            .map(|o| o.frames_present)
            .collect::<Vec<_>>(),
        [3, 3]
    );
}

#[test]
fn amg_png_folders_use_metadata_scores() {
    let s = run(
        "amg",
        MaskFormat::PerObjectPng,
        OverlapPolicy::HigherScore,
        "amg/higher_score",
    );
    assert_eq!(s.frames_without_masks, ["f001.jpg", "f002.jpg"]);
}

#[test]
fn grounded_sam2_tracking_keeps_class_names() {
    let s = run(
        "gsam",
        MaskFormat::GroundedSam2,
        OverlapPolicy::LowerId,
        "gsam",
    );
    let lamp = &s.objects[0];
    assert_eq!((lamp.label.as_str(), lamp.frames_present), ("lamp", 2));
    assert!(s.objects[1].describe(3).starts_with("chair: in 3/3 frames"));
}

#[test]
fn spilling_to_disk_gives_the_same_artifact_as_holding_in_memory() {
    // DAVIS ids first appear out of order (9 before 2), so the maps must be renumbered.
    for (source, format) in [
        ("davis", MaskFormat::Davis),
        ("coco_rle", MaskFormat::CocoRle),
    ] {
        let held = tempfile::tempdir().unwrap();
        let spilled = tempfile::tempdir().unwrap();
        for (out, budget) in [(&held, usize::MAX), (&spilled, 0)] {
            masks_import::import_with_budget(
                &fixture(source),
                format,
                OverlapPolicy::LowerId,
                &fixture("frames"),
                out.path(),
                |_, _| {},
                budget,
            )
            .unwrap();
        }
        for f in ["f000.png", "f001.png", "f002.png", OBJECTS_JSON] {
            let a = std::fs::read(held.path().join(f)).unwrap();
            let b = std::fs::read(spilled.path().join(f)).unwrap();
            assert!(a == b, "{source}: {f} differs");
        }
    }
}
