//! A fan-out node's notes are each item's own, named by the item, in the report, the
//! JSON and the table; the node-level notes are a single run's only.

mod common;
use common::*;

#[test]
fn each_item_keeps_its_own_notes() {
    let ws = Workspace::new();
    ws.graph(
        r#"(
  nodes: {
    "s": (kind: "split", params: (values: [1, 2, 3])),
    "d": (kind: "double", inputs: (x: each("s.items"))),
    "one": (kind: "const", params: (value: 5)),
    "solo": (kind: "double", inputs: (x: "one.out")),
  },
  targets: ["d", "solo"],
)"#,
    );
    let r = ws.run(&[]);
    let d = r.node("d").unwrap();
    let notes: Vec<(String, String)> = d
        .items
        .iter()
        .map(|i| (i.name.clone(), i.notes["doubled"].clone()))
        .collect();
    assert_eq!(
        notes,
        [
            ("item0".to_string(), "1 → 2".to_string()),
            ("item1".to_string(), "2 → 4".to_string()),
            ("item2".to_string(), "3 → 6".to_string()),
        ]
    );
    assert!(d.notes.is_empty(), "{:?}", d.notes);
    assert_eq!(r.node("solo").unwrap().notes["doubled"], "5 → 10");

    let json = serde_json::to_value(&r).unwrap();
    let d_json = json["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|n| n["id"] == "d")
        .unwrap();
    assert_eq!(d_json["items"][1]["notes"]["doubled"], "2 → 4");

    let table = r.render_table();
    for line in [
        "[item0] doubled: 1 → 2",
        "[item2] doubled: 3 → 6",
        "doubled: 5 → 10",
    ] {
        assert!(table.contains(line), "{line} missing from\n{table}");
    }
    // A cached rerun shows the same notes per item.
    let again = ws.run(&[]);
    let d2 = again.node("d").unwrap();
    assert_eq!(d2.items[2].notes["doubled"], "3 → 6");
}
