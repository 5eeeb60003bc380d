//! `viewer` writes index.html (self-contained: no external reference), the same scene.glb
//! as `export_gltf`, and viewer.json with every member's full-precision placement, the
//! scene's edit record and a starting camera from the first frame, looking at the objects.
//! (The page itself is exercised in a browser by the workspace's `viewer_*` tests.)

// The composed scenes these tests export are built as the scene crate's tests build them.
#[path = "../../scene/tests/common/mod.rs"]
mod common;

use objectsplat_core::Split;
use objectsplat_core::artifact::{PAGE_HTML, SCENE_GLB};
use objectsplat_export::nodes::{ExportGltf, Viewer};
use objectsplat_export::viewer::{ViewerScene, read_viewer};
use objectsplat_scene::load_scene;

#[test]
fn viewer_folder_holds_page_glb_and_scene_description() {
    let (tmp, _, edited) = common::composed_and_edited(
        "[Move(target: Id(3), by: (0.25, 0, 0)), Duplicate(target: Label(\"cup\"), offset: (0, 0, 0.5))]",
    );
    let camera = common::front_camera(64, 48);
    let frames = common::write_frames_from(tmp.path(), camera, &[("f0", Split::Train)]);
    let run = common::run(
        &Viewer,
        &[("scene", &edited), ("frames", &frames)],
        "(title: \"a <test> scene\")",
        &tmp.path().join("v"),
    );
    let dir = &run.outputs["file"];
    let page = std::fs::read_to_string(dir.join(PAGE_HTML)).unwrap();
    for external in ["http:", "https:", "src=", "href=\"http", "@import", "url("] {
        assert!(!page.contains(external), "the page refers to {external}");
    }
    assert!(page.contains("<title>a &lt;test&gt; scene</title>"));
    // One script of code; the data blocks cannot end early.
    assert_eq!(page.matches("<script>").count(), 1);
    assert_eq!(page.matches("</script>").count(), 3);

    let exported = common::run(
        &ExportGltf,
        &[("scene", &edited)],
        "()",
        &tmp.path().join("x"),
    );
    let (glb, view): (Vec<u8>, ViewerScene) = read_viewer(dir).unwrap();
    assert_eq!(
        glb,
        std::fs::read(exported.outputs["file"].join(SCENE_GLB)).unwrap()
    );

    let scene = load_scene(&edited).unwrap();
    assert_eq!(view.title, "a <test> scene");
    assert_eq!(view.edits, scene.edits);
    assert_eq!(view.edits.len(), 2);
    let members: Vec<_> = view
        .members
        .iter()
        .map(|m| (m.name.clone(), m.id, m.label.clone(), m.placement))
        .collect();
    let want: Vec<_> = scene
        .objects
        .iter()
        .map(|o| {
            (
                o.entry.name.clone(),
                o.entry.id,
                o.entry.label.clone(),
                o.placement(),
            )
        })
        .collect();
    assert_eq!(members, want);
    assert!(members.iter().any(|m| m.0 == "obj_6_cup"));

    // Starts at the frame's camera, looking at the centre of the objects' world bounds:
    // x ∈ [−0.85 + 0.25, 0.8], y ∈ [0, 0.5], z ∈ [−0.25, 0.75] (the cup copy lifted 0.5).
    let start = view.camera.unwrap();
    assert_eq!(start.eye, camera.center().to_array());
    let target = [(-0.6 + 0.8) / 2.0, 0.25, 0.25];
    for (got, want) in start.target.iter().zip(target) {
        assert!((got - want).abs() < 1e-6, "{:?}", start.target);
    }
    // fx = fy = width: the vertical field of view is 2·atan(48 / 128).
    assert!((start.fov_y_degrees - 2.0 * (48.0f64 / 128.0).atan().to_degrees()).abs() < 1e-9);
}
