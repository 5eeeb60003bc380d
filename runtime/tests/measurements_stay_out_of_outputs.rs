//! What a node measures about its own run (`Context::measurement`: a clock reading here) is
//! kept with its action record and reported, never written into its outputs: an item
//! evicted from the cache and recomputed measures anew, produces the same bytes, and so
//! stops the stages below it (early cutoff); the items that stayed cached report the
//! measurements of the run that produced them.

mod common;
use common::*;
use objectsplat_runtime::report::{ItemReport, RunReport, Status};
use objectsplat_runtime::store::Store;
use objectsplat_runtime::{NodeSpec, Outcome, Registry};
use std::time::{SystemTime, UNIX_EPOCH};

/// Doubles its input and measures when it ran: the one thing that differs between two
/// runs of the same item.
fn timed_double(ctx: &mut objectsplat_runtime::Context) -> anyhow::Result<Outcome> {
    let x: i64 = std::fs::read_to_string(ctx.input("x")?.join("value.txt"))?
        .trim()
        .parse()?;
    std::fs::write(ctx.output("out")?.join("value.txt"), (2 * x).to_string())?;
    let now = SystemTime::now().duration_since(UNIX_EPOCH)?.as_nanos();
    ctx.measurement(
        "clock",
        serde_json::json!({ "ran_at_ns": now.to_string(), "x": x }),
    )?;
    Ok(Outcome::Done)
}

fn registry() -> Registry {
    let mut reg = common::registry();
    let spec = NodeSpec::new("timed_double", "1")
        .input("x", "Num", "")
        .output("out", "Num", "");
    reg.add_node(fn_kind(spec, timed_double)).unwrap();
    reg
}

const GRAPH: &str = r#"(
  nodes: {
    "s": (kind: "split", params: (values: [1, 2, 3])),
    "timed": (kind: "timed_double", inputs: (x: each("s.items"))),
    "total": (kind: "sum", inputs: (xs: "timed.out")),
    "one": (kind: "const", params: (value: 5)),
    "timed_one": (kind: "timed_double", inputs: (x: "one.out")),
  },
  targets: ["total", "timed_one"],
)"#;

fn run(ws: &Workspace) -> RunReport {
    let plan = plan_graph(&ws.dir.path().join("g.ron"), &registry(), &[], &[]);
    let report = execute(&plan, &ws.cache(), Some(&ws.out()), 2);
    assert!(report.ok, "{}", report.render_table());
    report
}

fn item<'a>(report: &'a RunReport, node: &str, name: &str) -> &'a ItemReport {
    let items = &report.node(node).unwrap().items;
    items.iter().find(|i| i.name == name).unwrap()
}

/// Deletes the action record of `node`'s item `name`, as a cache eviction would: the
/// record is the only thing that makes its key a hit (`actions/<aa>/<key>.json`).
fn evict(ws: &Workspace, node: &str, name: &str) {
    let store = Store::open(&ws.cache()).unwrap();
    let keys = store.head(&ws.dir.path().join("g.ron"), node).unwrap();
    let key = &keys[name];
    let record = ws
        .cache()
        .join("actions")
        .join(&key[..2])
        .join(format!("{key}.json"));
    std::fs::remove_file(&record).unwrap_or_else(|e| panic!("{}: {e}", record.display()));
}

fn clock(item: &ItemReport) -> &serde_json::Value {
    &item.measurements["clock"]
}

#[test]
fn a_recomputed_item_measures_anew_and_stops_the_stages_below_it() {
    let ws = Workspace::new();
    ws.graph(GRAPH);
    let first = run(&ws);
    for (name, x) in [("item0", 1), ("item1", 2), ("item2", 3)] {
        assert_eq!(clock(item(&first, "timed", name))["x"], x, "{name}");
    }
    let single = &first.node("timed_one").unwrap().measurements["clock"];
    assert_eq!(
        single["x"], 5,
        "a node that does not fan out reports its own"
    );
    // Measurements are in the report's JSON, beside the notes.
    let json = serde_json::to_value(&first).unwrap();
    let nodes = json["nodes"].as_array().unwrap();
    let timed = nodes.iter().find(|n| n["id"] == "timed").unwrap();
    assert_eq!(timed["items"][1]["measurements"]["clock"]["x"], 2);
    let outputs = first.node("timed").unwrap().outputs.clone();

    evict(&ws, "timed", "item1");
    let again = run(&ws);
    let (before, after) = (
        item(&first, "timed", "item1"),
        item(&again, "timed", "item1"),
    );
    assert_eq!(after.status, Status::Ran, "the evicted item is recomputed");
    assert_ne!(
        clock(after)["ran_at_ns"],
        clock(before)["ran_at_ns"],
        "the recomputation measured its own run"
    );
    for name in ["item0", "item2"] {
        let (was, now) = (item(&first, "timed", name), item(&again, "timed", name));
        assert_eq!(now.status, Status::Cached, "{name}");
        assert_eq!(
            clock(now),
            clock(was),
            "{name}: the producing run's measurement"
        );
    }
    let timed = again.node("timed").unwrap();
    assert_eq!(timed.status, Status::Ran);
    assert_eq!(timed.outputs, outputs, "the same bytes, so the same digest");
    assert_eq!(
        again.node("total").unwrap().status,
        Status::Cached,
        "early cutoff: the consumer's key did not change"
    );
    assert_eq!(ws.num("total", "out"), 12);
    assert_eq!(
        again.node("timed_one").unwrap().measurements["clock"],
        *single
    );
}
