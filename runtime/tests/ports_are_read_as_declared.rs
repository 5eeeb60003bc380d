//! A node whose ports are a `node_ports!` struct gets, in `run`, the very folders the
//! engine laid out under the declared names: single inputs, collections, optional inputs
//! (wired or not) and empty output folders, an output named like an input included.

use objectsplat_runtime::testing::run_node;
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, node_ports};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

node_ports! {
    struct ProbePorts {
        /// a single artifact
        base: input "Image",
        /// a collection
        layers: items "Image",
        /// a single artifact that may be missing
        mask: optional "Mask",
        /// a collection that may be missing
        extras: optional_items "Image",
        /// where the result goes
        image: output "Image",
        /// an output named like an input
        base_out: output "Image" as "base",
    }
}

/// Records what `run` was given.
#[derive(Default)]
struct Probe {
    seen: Mutex<Option<ProbePorts>>,
}

impl Node for Probe {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("probe", "1").ports::<ProbePorts>()
    }
    fn run(&self, ctx: &mut Context) -> anyhow::Result<Outcome> {
        let ports: ProbePorts = ctx.ports_as()?;
        std::fs::write(ports.image.join("written"), b"ok")?;
        std::fs::write(ports.base_out.join("written"), b"base")?;
        *self.seen.lock().unwrap() = Some(ports);
        Ok(Outcome::Done)
    }
}

fn folder(root: &Path, rel: &str) -> PathBuf {
    let dir = root.join(rel);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn the_spec_lists_the_declared_ports() {
    let spec = Probe::default().spec();
    let inputs: Vec<(String, String, bool)> = spec
        .inputs
        .iter()
        .map(|p| (p.name.clone(), p.ty.to_string(), p.optional))
        .collect();
    let expected = [
        ("base", "Image", false),
        ("layers", "[Image]", false),
        ("mask", "Mask", true),
        ("extras", "[Image]", true),
    ]
    .map(|(n, t, o)| (n.to_string(), t.to_string(), o));
    assert_eq!(inputs, expected);
    let outputs: Vec<(&str, &str)> = spec
        .outputs
        .iter()
        .map(|p| (p.name.as_str(), p.doc.as_str()))
        .collect();
    assert_eq!(
        outputs,
        [
            ("image", "where the result goes"),
            ("base", "an output named like an input")
        ]
    );
}

#[test]
fn run_gets_each_port_under_its_declared_name() {
    let tmp = tempfile::tempdir().unwrap();
    let base = folder(tmp.path(), "base");
    let layers = folder(tmp.path(), "layers");
    folder(&layers, "b_top");
    folder(&layers, "a_bottom");
    let mask = folder(tmp.path(), "mask");
    let probe = Probe::default();
    let out = tmp.path().join("out");
    let inputs = [
        ("base", base.as_path()),
        ("layers", layers.as_path()),
        ("mask", mask.as_path()),
    ];
    let run = run_node(&probe, &inputs, "()", &out, None).unwrap();

    let seen = probe.seen.lock().unwrap().take().expect("run was called");
    assert_eq!(seen.base, base);
    let names: Vec<&str> = seen.layers.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["a_bottom", "b_top"]);
    assert_eq!(seen.layers[0].1, layers.join("a_bottom"));
    assert_eq!(seen.mask.as_deref(), Some(mask.as_path()));
    assert!(
        seen.extras.is_none(),
        "an unwired optional collection is None"
    );
    assert_eq!(seen.image, run.outputs["image"]);
    assert_eq!(seen.base_out, run.outputs["base"]);
    assert_eq!(
        std::fs::read(run.outputs["base"].join("written")).unwrap(),
        b"base"
    );
}

#[test]
fn a_missing_required_input_is_an_error_naming_the_port() {
    let tmp = tempfile::tempdir().unwrap();
    let layers = folder(tmp.path(), "layers");
    let probe = Probe::default();
    let err = run_node(
        &probe,
        &[("layers", &layers)],
        "()",
        &tmp.path().join("out"),
        None,
    )
    .err()
    .expect("`base` is not wired");
    assert!(format!("{err:#}").contains("`base`"), "{err:#}");
}
