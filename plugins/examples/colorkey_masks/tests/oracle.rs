//! colorkey_masks against the NumPy oracle (tests/fixtures/make_fixtures.py),
//! called through its exported entry table as the host calls it.

use colorkey_masks::objectsplat_plugin_entry_v1;
use objectsplat_plugin_sdk::core::IdMap;
use objectsplat_plugin_sdk::testing;
use std::path::Path;

const KEYS: &str = r#"[(id: 3, label: "chair", rgb: (200, 30, 30), tolerance: 12), (id: 9, label: "plant", rgb: (30, 180, 60), tolerance: 8)]"#;

fn fixtures() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures"))
}

#[test]
fn id_maps_match_the_numpy_oracle_pixel_for_pixel() {
    let out = tempfile::tempdir().unwrap();
    let response = testing::run(
        objectsplat_plugin_entry_v1(),
        "colorkey_masks",
        &[("frames", &fixtures().join("frames"))],
        &[("masks", out.path())],
        &[("keys", KEYS)],
        out.path(),
    )
    .unwrap()
    .expect("the node succeeds");
    for stem in ["view_a", "view_b"] {
        let got = IdMap::load(&out.path().join(format!("{stem}.png"))).unwrap();
        let want = IdMap::load(&fixtures().join(format!("expected/{stem}.png"))).unwrap();
        assert_eq!(got, want, "{stem}");
        assert!(
            want.data.contains(&3) && want.data.contains(&9) && want.data.contains(&0),
            "fixture covers every case"
        );
    }
    let labels = objectsplat_plugin_sdk::artifacts::read_labels(out.path()).unwrap();
    assert_eq!(
        labels,
        [(3, "chair".to_string()), (9, "plant".to_string())].into()
    );
    assert!(response.notes.iter().any(|(k, _)| k == "pixels_chair"));
}

#[test]
fn duplicate_or_reserved_ids_fail_the_node_with_a_message() {
    let out = tempfile::tempdir().unwrap();
    let run = |keys: &str| {
        testing::run(
            objectsplat_plugin_entry_v1(),
            "colorkey_masks",
            &[("frames", &fixtures().join("frames"))],
            &[("masks", out.path())],
            &[("keys", keys)],
            out.path(),
        )
        .unwrap()
        .expect_err("the node fails")
    };
    let dup = r#"[(id: 3, label: "a", rgb: (1, 2, 3), tolerance: 0), (id: 3, label: "b", rgb: (1, 2, 3), tolerance: 0)]"#;
    let (status, message) = run(dup);
    assert_eq!(status, objectsplat_plugin_sdk::abi::STATUS_ERROR);
    assert_eq!(message, "id 3 appears in two keys");
    let (_, message) = run(r#"[(id: 0, label: "a", rgb: (1, 2, 3), tolerance: 0)]"#);
    assert!(message.contains("id 0 is reserved"), "{message}");
}
