//! Mass corruption: when every blob of an output is damaged, one pass finds all
//! of it and the next recomputes all of it; a blob that exists but fails
//! verification is overwritten, never kept because it exists.

mod common;
use common::*;

const ITEMS: usize = 60;

fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            v.extend(walk(&p));
        } else {
            v.push(p);
        }
    }
    v
}

#[test]
fn every_corrupt_blob_of_an_output_is_repaired_in_one_rerun() {
    let ws = Workspace::new();
    let values: Vec<String> = (0..ITEMS).map(|v| (1000 + v).to_string()).collect();
    ws.graph(&format!(
        r#"(nodes: {{ "src": (kind: "split", params: (values: [{}])) }})"#,
        values.join(", ")
    ));
    assert!(ws.run(&[]).ok);
    let blobs = walk(&ws.cache().join("blobs"));
    assert_eq!(blobs.len(), ITEMS, "one blob per distinct value");
    for blob in &blobs {
        std::fs::write(blob, "garbage").unwrap();
    }

    let r = ws.run(&[]);
    assert!(r.ok, "{}", r.render_table());
    // One warning for the pass that found the damage: every corrupt blob at once.
    assert_eq!(r.warnings.len(), 1, "{:?}", r.warnings);
    assert!(
        r.warnings[0].contains(&format!("{ITEMS} entries are damaged")),
        "{}",
        r.warnings[0]
    );
    assert_eq!(ran(&r), ["src"]);
    for (i, v) in values.iter().enumerate() {
        let path = ws.out().join(format!("src/items/item{i}/value.txt"));
        assert_eq!(&std::fs::read_to_string(path).unwrap(), v);
    }
    // The cache is whole again.
    let r = ws.run(&[]);
    assert!(
        r.warnings.is_empty() && ran(&r).is_empty(),
        "{:?}",
        r.warnings
    );
}

#[test]
fn a_rerun_overwrites_a_corrupt_blob_it_finds_in_place() {
    // The action record is damaged too, so the producer reruns before anything reads
    // the blob: the rerun must replace the blob rather than trust that it exists.
    let ws = Workspace::new();
    ws.graph(r#"(nodes: { "a": (kind: "const", params: (value: 41)), "b": (kind: "add", inputs: (a: "a.out"), params: (offset: 1)) })"#);
    assert!(ws.run(&[]).ok);
    for blob in walk(&ws.cache().join("blobs")) {
        std::fs::write(&blob, "garbage").unwrap();
    }
    for rec in walk(&ws.cache().join("actions")) {
        std::fs::write(&rec, "not a record").unwrap();
    }
    let r = ws.run(&[]);
    assert!(r.ok, "{}", r.render_table());
    assert_eq!(ran(&r), ["a", "b"]);
    assert_eq!(ws.num("b", "out"), 42);
    // The two records were found corrupt; the blob never was: `a`'s rerun replaced it
    // before `b` read it, so no second pass was needed.
    assert_eq!(r.warnings.len(), 2, "{:?}", r.warnings);
    assert!(
        r.warnings.iter().all(|w| w.contains("action record")),
        "{:?}",
        r.warnings
    );
    let r = ws.run(&[]);
    assert!(
        r.warnings.is_empty() && ran(&r).is_empty(),
        "{:?}",
        r.warnings
    );
}
