//! A job's threads are the workers over the jobs running when it asks: an item
//! started beside a short one (an item passed through) gets the worker that one
//! freed once it has finished, instead of keeping half the machine for its whole run.

mod common;
use common::*;
use objectsplat_runtime::{Context, NodeSpec, Outcome, ParamType};

/// Notes the threads it may use when it starts and again after sleeping 100 + `x` × 500 ms.
fn cores(ctx: &mut Context) -> anyhow::Result<Outcome> {
    let x = read_num(ctx.input("x")?)?;
    let start = ctx.threads();
    std::thread::sleep(std::time::Duration::from_millis(
        100 + 500 * x.max(0) as u64,
    ));
    ctx.note("threads", format!("{start} then {}", ctx.threads()));
    write_num(&ctx.output("out")?, x)?;
    Ok(Outcome::Done)
}

#[test]
fn a_long_item_gets_the_worker_a_short_one_freed() {
    let ws = Workspace::new();
    let graph = ws.graph(
        r#"(
  nodes: {
    "s": (kind: "split", params: (values: [0, 1])),
    "c": (kind: "cores", inputs: (x: each("s.items"))),
  },
  targets: ["c"],
)"#,
    );
    let mut reg = registry();
    let spec = NodeSpec::new("cores", "1")
        .input("x", "Num", "")
        .output("out", "Num", "")
        .param("unused", ParamType::int(), Some("0"), "");
    reg.add_node(fn_kind(spec, cores)).unwrap();
    let r = execute(&plan_graph(&graph, &reg, &[], &[]), &ws.cache(), None, 2);
    assert!(r.ok, "{}", r.render_table());
    let c = r.node("c").unwrap();
    let threads =
        |item: &str| c.items.iter().find(|i| i.name == item).unwrap().notes["threads"].clone();
    // Whatever it was given at its start (1 beside item0), item1 asks again
    // 600 ms later, after item0 has finished: both workers are its own.
    assert!(threads("item1").ends_with("then 2"), "{}", threads("item1"));
}
