//! `objectsplat check` validates `edit_scene` targets against the scene the edits
//! apply to when that scene is already in the cache (each edit against the scene the
//! edits before it leave), pointing at the target in the graph; when it is not cached
//! it says the targets were not checked and why. Malformed edits (an unknown field)
//! are refused by every plan, with their line and column.

mod common;

use common::registry;
use objectsplat_runtime::Diagnostic;
use objectsplat_runtime::check;
use objectsplat_runtime::exec::{self, RunOptions, Silent};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::build_plan;
use objectsplat_runtime::store::Store;
use std::path::Path;
use std::sync::Arc;

fn graph(dir: &Path, edits: &str) -> (std::path::PathBuf, String) {
    let text = format!(
        r#"(
  nodes: {{
    "loaded": (kind: "load_scene", params: (path: "compose/scene")),
    "edit": (kind: "edit_scene", inputs: (scene: "loaded.scene"),
             params: (edits: {edits})),
  }},
  targets: ["edit"],
)"#
    );
    let path = dir.join("graph.ron");
    std::fs::write(&path, &text).unwrap();
    (path, text)
}

fn headlines(d: &[Diagnostic]) -> Vec<String> {
    d.iter().map(Diagnostic::headline).collect()
}

#[test]
fn targets_are_checked_against_the_cached_scene() {
    let tmp = tempfile::tempdir().unwrap();
    common::composed_scene(tmp.path());
    // The second edit moves the cup the first one removed; the third has a typo.
    let edits = r#"[Remove(target: Label("cup")),
                     Move(target: Label("cup"), by: (1, 0, 0)),
                     Move(target: Label("chiar"), by: (1, 0, 0))]"#;
    let (g, text) = graph(tmp.path(), edits);
    let src = GraphSource::read(&g).unwrap();
    let plan = build_plan(&src, &registry(), &[], &[]).unwrap();
    let store = Store::open(&tmp.path().join("cache")).unwrap();

    // Nothing cached yet: not checked, and the note says what would make it checkable.
    let found = check::with_cached_inputs(&plan, &store, &[]).unwrap();
    assert!(found.errors.is_empty(), "{:?}", headlines(&found.errors));
    assert_eq!(
        found.not_checked,
        [
            "node `edit` (edit_scene): edit targets (ids, labels, member names) not checked: its \
          input `scene` (from `loaded.scene`) is not in the cache yet; they are checked when the \
          node runs, or by `check` once `loaded` has run"
        ]
    );

    // Run up to the scene, then check again.
    let upstream = build_plan(&src, &registry(), &[], &["loaded".to_string()]).unwrap();
    let opts = RunOptions {
        jobs: 1,
        threads_per_job: None,
        out_dir: None,
        observer: Arc::new(Silent),
    };
    assert!(exec::run(&upstream, &store, &opts).unwrap().ok);
    let found = check::with_cached_inputs(&plan, &store, &[]).unwrap();
    assert!(found.not_checked.is_empty(), "{:?}", found.not_checked);
    let line = text
        .lines()
        .position(|l| l.contains("Move(target: Label(\"cup\")"))
        .unwrap();
    // The error points at the edit's `target` field.
    let col = text
        .lines()
        .nth(line)
        .unwrap()
        .find("target: Label(\"cup\")")
        .unwrap()
        + 1;
    let errors = headlines(&found.errors);
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert!(
        errors[0].starts_with(&format!(
            "{}:{}:{col}: node \"edit\" (edit_scene) param `edits[1].target`: no object has label \"cup\"; the scene has: ",
            g.display(),
            line + 1
        )),
        "{errors:?}"
    );
    // With the cup's move gone, the typo is what it finds.
    let edits = r#"[Remove(target: Label("cup")), Move(target: Label("chiar"), by: (1, 0, 0))]"#;
    let (g, _) = graph(tmp.path(), edits);
    let plan = build_plan(&GraphSource::read(&g).unwrap(), &registry(), &[], &[]).unwrap();
    let errors = headlines(
        &check::with_cached_inputs(&plan, &store, &[])
            .unwrap()
            .errors,
    );
    assert!(
        errors.len() == 1
            && errors[0].contains("param `edits[1].target`: no object has label \"chiar\"")
            && errors[0].contains("obj_3_chair (id 3, label \"chair\")"),
        "{errors:?}"
    );
    // Valid targets: nothing to report.
    let (g, _) = graph(
        tmp.path(),
        r#"[Move(target: Label("chair"), by: (1, 0, 0))]"#,
    );
    let plan = build_plan(&GraphSource::read(&g).unwrap(), &registry(), &[], &[]).unwrap();
    let found = check::with_cached_inputs(&plan, &store, &[]).unwrap();
    assert!(found.errors.is_empty() && found.not_checked.is_empty());
}

#[test]
fn an_unknown_field_inside_an_edit_is_refused_with_its_place() {
    let tmp = tempfile::tempdir().unwrap();
    common::composed_scene(tmp.path());
    let (g, text) = graph(tmp.path(), r#"[Move(tagret: Id(3), by: (1, 0, 0))]"#);
    let err = build_plan(&GraphSource::read(&g).unwrap(), &registry(), &[], &[])
        .err()
        .unwrap();
    let line = text.lines().position(|l| l.contains("tagret")).unwrap();
    let col = text.lines().nth(line).unwrap().find("tagret").unwrap() + 1;
    assert_eq!(
        headlines(&err.0),
        [format!(
            "{}:{}:{col}: node \"edit\" (edit_scene) param `edits[0].tagret`: `Move` has no field `tagret`; its fields are target, by",
            g.display(),
            line + 1
        )]
    );
}
