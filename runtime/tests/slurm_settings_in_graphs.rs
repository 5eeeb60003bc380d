//! The `slurm: (...)` fields of a graph and of its nodes: read into the plan, merged
//! graph < command line < node, never part of a cache key, and every mistake reported
//! with file:line:column.

mod common;
use objectsplat_runtime::exec::{Executor, Local};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::{Plan, build_plan};
use objectsplat_runtime::slurm::{SlurmConfig, SlurmSettings};

fn plan(text: &str) -> Result<Plan, Vec<String>> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("g.ron");
    std::fs::write(&path, text).unwrap();
    let src = GraphSource::read(&path).unwrap();
    build_plan(&src, &common::registry(), &[], &[]).map_err(|d| {
        d.0.iter()
            .map(|e| e.headline().replace(&path.display().to_string(), "g.ron"))
            .collect()
    })
}

#[test]
fn settings_merge_from_graph_command_line_and_node() {
    let p = plan(
        r#"(
  nodes: {
    "a": (kind: "const", params: (value: 1), slurm: (cpus: 4, gres: "gpu:1", args: ["--qos=high"])),
    "b": (kind: "add", inputs: (a: "a.out")),
    "c": (kind: "add", inputs: (a: "a.out"), slurm: (local: true)),
  },
  slurm: (partition: "cpu", cpus: 1, time: "10", args: ["--account=lab"]),
)"#,
    )
    .unwrap();
    let mut cfg = SlurmConfig::new(vec!["objectsplat".into(), "run-action".into()]);
    cfg.settings = SlurmSettings {
        partition: Some("gpu".into()),
        time: Some("30".into()),
        ..Default::default()
    };
    let slurm = cfg;
    let node = |id: &str| &p.nodes[p.index(id).unwrap()];
    let a = slurm.settings_for(&p, node("a")).expect("a asks for Slurm");
    assert!(slurm.takes(&p, node("a")));
    assert_eq!(
        a.sbatch_args(),
        [
            "--partition=gpu",
            "--time=30",
            "--cpus-per-task=4",
            "--gres=gpu:1",
            "--account=lab",
            "--qos=high"
        ]
    );
    // No `slurm` field and no fan-out: stays local; `local: true` too.
    assert!(slurm.settings_for(&p, node("b")).is_none());
    assert!(!slurm.takes(&p, node("b")));
    assert!(slurm.settings_for(&p, node("c")).is_none());
    assert!(!slurm.takes(&p, node("c")));
    // The local executor sends nothing anywhere.
    assert!(!Local.takes(&p, node("a")));
}

#[test]
fn mistakes_name_the_place_and_what_was_expected() {
    let e = plan(
        r#"(
  nodes: {
    "a": (kind: "const", slurm: (cpu: 4)),
    "b": (kind: "const", slurm: (cpus: 0, args: ["qos=high"], gres: 1)),
  },
  slurm: (local: true),
)"#,
    )
    .err()
    .expect("the graph has mistakes");
    let expect = [
        "g.ron:3:34: node \"a\": slurm has no option `cpu`; did you mean `cpus`?",
        "g.ron:4:40: node \"b\": slurm.cpus must be a whole number ≥ 1, found an integer",
        "g.ron:4:50: node \"b\": slurm.args: \"qos=high\" is not an sbatch option",
        "g.ron:4:69: node \"b\": slurm.gres must be a string, found an integer",
        "g.ron:6:11: `slurm.local` belongs on a node",
    ];
    for x in expect {
        assert!(
            e.iter().any(|m| m.starts_with(x)),
            "no error starting {x:?} in {e:#?}"
        );
    }
    assert_eq!(e.len(), expect.len(), "{e:#?}");
}
