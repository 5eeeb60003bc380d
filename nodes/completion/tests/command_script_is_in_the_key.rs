//! The `command` method's output depends on the program it runs: editing the script
//! named in the argv reruns `inpaint_background` through the engine's cache, and the
//! new script's output is what comes out.

mod common;

use objectsplat_completion::nodes::InpaintBackgroundNode;
use objectsplat_runtime::exec::{self, RunOptions, Silent};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::build_plan;
use objectsplat_runtime::report::Status;
use objectsplat_runtime::store::Store;
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Registry};
use std::path::Path;
use std::sync::Arc;

/// Serves a fixture folder as an artifact: one output per port, copied from
/// `<path>/<port>` (collections keep their item sub-folders).
struct Fixture;

/// The fixture node's ports with their types; each has a path param of the same name.
const FIXTURE_PORTS: [(&str, &str); 2] = [("components", "[Component]"), ("frames", "Frames")];

impl Node for Fixture {
    fn spec(&self) -> NodeSpec {
        let mut spec = NodeSpec::new("fixture", "1");
        for (port, ty) in FIXTURE_PORTS {
            spec = spec.output(port, ty, "");
        }
        for (port, _) in FIXTURE_PORTS {
            spec = spec.param(port, ParamType::Path, None, "");
        }
        spec
    }
    fn run(&self, ctx: &mut Context) -> anyhow::Result<Outcome> {
        for (port, _) in FIXTURE_PORTS {
            let from: String = ctx.param(port)?;
            copy_tree(Path::new(&from), &ctx.output(port)?);
        }
        Ok(Outcome::Done)
    }
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_dir() {
            copy_tree(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// A fill script: white holes (it returns the mask), or holes left as they were (it
/// returns the input image).
fn write_script(path: &Path, white: bool) {
    let body = if white {
        "for m in \"$1\"/*_mask.png; do cp \"$m\" \"$2/$(basename \"$m\" _mask.png).png\"; done\n"
    } else {
        "for m in \"$1\"/*_mask.png; do s=$(basename \"$m\" _mask.png); cp \"$1/$s.png\" \"$2/$s.png\"; done\n"
    };
    std::fs::write(path, format!("#!/bin/sh\n{body}")).unwrap();
}

fn run(dir: &Path) -> (Status, Vec<u8>) {
    let mut reg = Registry::new();
    for t in ["Component", "Frames", "Images"] {
        reg.add_type(t, "test");
    }
    reg.add_node(Arc::new(Fixture)).unwrap();
    reg.add_node(Arc::new(InpaintBackgroundNode)).unwrap();
    let graph = GraphSource::read(&dir.join("g.ron")).unwrap();
    let plan = build_plan(&graph, &reg, &[], &[]).unwrap_or_else(|d| panic!("{d}"));
    let options = RunOptions {
        jobs: 1,
        threads_per_job: None,
        out_dir: Some(dir.join("out")),
        observer: Arc::new(Silent),
    };
    let r = exec::run(&plan, &Store::open(&dir.join("cache")).unwrap(), &options).unwrap();
    assert!(r.ok, "{}", r.render_table());
    let fill = common::read_rgb(&dir.join("out/fill/fills/f0.png"));
    (r.node("fill").unwrap().status, fill)
}

#[test]
fn editing_the_script_reruns_the_node() {
    let scene = common::build("table");
    let dir = scene.root.path();
    let script = dir.join("fill.sh");
    write_script(&script, true);
    std::fs::write(
        dir.join("g.ron"),
        format!(
            r#"(nodes: {{
  "src":  (kind: "fixture", params: (components: {:?}, frames: {:?})),
  "fill": (kind: "inpaint_background", inputs: (components: "src.components", frames: "src.frames"),
           params: (method: "command", command: ["sh", {:?}, "{{input}}", "{{output}}"])),
}})"#,
            scene.components.display().to_string(),
            scene.frames.display().to_string(),
            script.display().to_string()
        ),
    )
    .unwrap();
    let (status, white) = run(dir);
    assert_eq!(status, Status::Ran);
    assert_eq!(run(dir).0, Status::Cached);

    write_script(&script, false);
    let (status, copied) = run(dir);
    assert_eq!(status, Status::Ran, "an edited script must rerun the node");
    assert_ne!(white, copied, "the new script's output comes out");
}
