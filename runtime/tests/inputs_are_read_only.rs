//! A node's inputs are hard links to the cache's blobs, and blobs are read-only: a node
//! (run by anyone but root) cannot change the cache by writing into an input. The copies
//! under OUT are the user's, and writable.
#![cfg(unix)]

mod common;
use common::{execute, fn_kind, plan_graph, registry};
use objectsplat_runtime::{Context, NodeSpec, Outcome};
use std::os::unix::fs::PermissionsExt;
use std::path::Path;

fn mode(path: &Path) -> u32 {
    std::fs::metadata(path).unwrap().permissions().mode() & 0o777
}

/// Writes the permission bits of its input's `value.txt` as its own value.
fn input_mode(ctx: &mut Context) -> anyhow::Result<Outcome> {
    let seen = mode(&ctx.input("x")?.join("value.txt"));
    std::fs::write(ctx.output("out")?.join("value.txt"), seen.to_string())?;
    Ok(Outcome::Done)
}

#[test]
fn inputs_are_read_only_and_out_copies_writable() {
    let ws = tempfile::tempdir().unwrap();
    let graph = ws.path().join("g.ron");
    std::fs::write(
        &graph,
        r#"(nodes: {
            "a": (kind: "const", params: (value: 7)),
            "probe": (kind: "input_mode", inputs: (x: "a.out")),
        })"#,
    )
    .unwrap();
    let mut reg = registry();
    let spec = NodeSpec::new("input_mode", "1")
        .input("x", "Num", "")
        .output("out", "Num", "");
    reg.add_node(fn_kind(spec, input_mode)).unwrap();
    let out = ws.path().join("out");
    let report = execute(
        &plan_graph(&graph, &reg, &[], &[]),
        &ws.path().join("cache"),
        Some(&out),
        1,
    );
    assert!(report.ok, "{}", report.render_table());

    let seen: u32 = std::fs::read_to_string(out.join("probe/out/value.txt"))
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(seen & 0o222, 0, "the input was writable: mode {seen:o}");
    let m = mode(&out.join("probe/out/value.txt"));
    assert_ne!(
        m & 0o200,
        0,
        "the copy under OUT is not writable: mode {m:o}"
    );
    let blobs = ws.path().join("cache/blobs");
    let mut checked = 0;
    for shard in std::fs::read_dir(&blobs).unwrap() {
        for blob in std::fs::read_dir(shard.unwrap().path()).unwrap() {
            let path = blob.unwrap().path();
            assert_eq!(mode(&path) & 0o222, 0, "{} is writable", path.display());
            checked += 1;
        }
    }
    assert_eq!(checked, 2, "one blob per distinct value");
}
