//! The calls `export_plugin!` generates, driven through the entry table the way
//! the host drives them: statuses, messages, panics caught, params from RON text.

use objectsplat_plugin_sdk::abi::{ABI_VERSION, STATUS_ERROR, STATUS_PANIC};
use objectsplat_plugin_sdk::prelude::*;
use objectsplat_plugin_sdk::protocol::OutcomeKind;
use objectsplat_plugin_sdk::testing;

fn write_sum(req: &mut Request) -> Result<Outcome> {
    let terms: Vec<f64> = req.param("terms")?;
    let label: Option<String> = req.param("label")?;
    let out = req.output("file")?;
    std::fs::write(
        out.join("sum.txt"),
        format!("{}", terms.iter().sum::<f64>()),
    )
    .context("writing sum")?;
    req.note("label", label.unwrap_or_else(|| "none".into()));
    Ok(Outcome::Done)
}

fn always_fails(_: &mut Request) -> Result<Outcome> {
    Err(anyhow!("the disk is full")).context("writing the output")
}

fn always_panics(_: &mut Request) -> Result<Outcome> {
    panic!("index out of bounds in the plugin")
}

export_plugin!(
    Plugin::new("calls", "3")
        .node(
            NodeDecl::new("write_sum", write_sum)
                .doc("sums numbers")
                .output("file", "File", "sum.txt")
                .param("terms", "list(float)", None, "numbers")
                .param("label", "optional(string)", Some("None"), "a note"),
        )
        .node(NodeDecl::new("always_fails", always_fails).output("file", "File", ""))
        .node(NodeDecl::new("always_panics", always_panics).output("file", "File", ""))
);

#[test]
fn the_entry_table_declares_abi_v1_and_its_own_size() {
    // SAFETY: the entry function returns a pointer to a static table.
    let table = unsafe { &*objectsplat_plugin_entry_v1() };
    assert_eq!(table.abi_version, ABI_VERSION);
    assert_eq!(
        table.struct_size,
        std::mem::size_of::<objectsplat_plugin_sdk::abi::EntryV1>()
    );
}

#[test]
fn describe_lists_every_node_with_ports_params_and_the_code_version() {
    let d = testing::describe(objectsplat_plugin_entry_v1()).unwrap();
    assert_eq!((d.plugin.as_str(), d.version.as_str()), ("calls", "3"));
    let kinds: Vec<&str> = d.nodes.iter().map(|n| n.kind.as_str()).collect();
    assert_eq!(kinds, ["write_sum", "always_fails", "always_panics"]);
    let sum = &d.nodes[0];
    assert_eq!(sum.outputs[0].ty, "File");
    assert_eq!(sum.params[0].ty, "list(float)");
    assert_eq!(sum.params[0].default, None);
    assert_eq!(sum.params[1].default.as_deref(), Some("None"));
}

#[test]
fn a_node_reads_params_from_ron_text_and_writes_its_output() {
    let dir = tempfile::tempdir().unwrap();
    let response = testing::run(
        objectsplat_plugin_entry_v1(),
        "write_sum",
        &[],
        &[("file", dir.path())],
        &[("terms", "[1.5,2.0,-0.25]"), ("label", "\"x\"")],
        dir.path(),
    )
    .unwrap()
    .unwrap();
    assert_eq!(response.outcome, OutcomeKind::Done);
    assert_eq!(
        std::fs::read_to_string(dir.path().join("sum.txt")).unwrap(),
        "3.25"
    );
    assert_eq!(response.notes, vec![("label".to_string(), "x".to_string())]);
}

#[test]
fn errors_and_panics_become_statuses_with_their_messages() {
    let dir = tempfile::tempdir().unwrap();
    let call = |kind: &str, params: &[(&str, &str)]| {
        testing::run(
            objectsplat_plugin_entry_v1(),
            kind,
            &[],
            &[("file", dir.path())],
            params,
            dir.path(),
        )
        .unwrap()
        .unwrap_err()
    };
    assert_eq!(
        call("always_fails", &[]),
        (
            STATUS_ERROR,
            "writing the output: the disk is full".to_string()
        )
    );
    assert_eq!(
        call("always_panics", &[]),
        (
            STATUS_PANIC,
            "index out of bounds in the plugin".to_string()
        )
    );
    let (status, message) = call("write_sum", &[("terms", "[1, \"two\"]"), ("label", "None")]);
    assert_eq!(status, STATUS_ERROR);
    assert!(
        message.starts_with("parameter `terms` = [1, \"two\"]"),
        "{message}"
    );
    let (status, message) = call("no_such_kind", &[]);
    assert_eq!(
        (status, message.as_str()),
        (STATUS_ERROR, "this plugin has no node kind `no_such_kind`")
    );
}
