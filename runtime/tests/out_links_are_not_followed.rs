//! Links under `--out` are never written through: a node folder that is a link is
//! refused (the folder it points to is untouched), a port folder that is a link is
//! replaced by a real folder (the link, not its target).

mod common;
use common::*;

const GRAPH: &str = r#"(nodes: { "a": (kind: "const", params: (value: 7)) })"#;

#[test]
fn a_link_at_a_node_folder_is_refused_and_its_target_untouched() {
    let ws = Workspace::new();
    ws.graph(GRAPH);
    let elsewhere = ws.dir.path().join("elsewhere");
    std::fs::create_dir_all(elsewhere.join("out")).unwrap();
    std::fs::write(elsewhere.join("out/value.txt"), "precious").unwrap();
    std::fs::create_dir_all(ws.out()).unwrap();
    std::os::unix::fs::symlink(&elsewhere, ws.out().join("a")).unwrap();

    let src = objectsplat_runtime::graph::GraphSource::read(&ws.dir.path().join("g.ron")).unwrap();
    let plan = objectsplat_runtime::plan::build_plan(&src, &registry(), &[], &[]).unwrap();
    let store = objectsplat_runtime::store::Store::open(&ws.cache()).unwrap();
    let e = objectsplat_runtime::exec::run(
        &plan,
        &store,
        &objectsplat_runtime::exec::RunOptions {
            jobs: 1,
            threads_per_job: None,
            out_dir: Some(ws.out()),
            observer: std::sync::Arc::new(objectsplat_runtime::exec::Silent),
        },
    )
    .expect_err("a link at OUT/a is refused")
    .to_string();
    assert!(e.contains("is a link"), "{e}");
    assert_eq!(
        std::fs::read_to_string(elsewhere.join("out/value.txt")).unwrap(),
        "precious"
    );
}

#[test]
fn a_link_at_a_port_folder_is_replaced_not_followed() {
    let ws = Workspace::new();
    ws.graph(GRAPH);
    let elsewhere = ws.dir.path().join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    std::fs::write(elsewhere.join("value.txt"), "precious").unwrap();
    std::fs::create_dir_all(ws.out().join("a")).unwrap();
    std::os::unix::fs::symlink(&elsewhere, ws.out().join("a/out")).unwrap();

    let r = ws.run(&[]);
    assert!(r.ok, "{}", r.render_table());
    assert!(
        !std::fs::symlink_metadata(ws.out().join("a/out"))
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(ws.num("a", "out"), 7);
    assert_eq!(
        std::fs::read_to_string(elsewhere.join("value.txt")).unwrap(),
        "precious"
    );
}
