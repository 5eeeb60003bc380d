//! `objectsplat explain`: why each needed node would (re)run, from the cache alone —
//! a key with no record is diffed against the key the node last ran with.

use crate::job::cached;
use crate::keys::{compute_key, params_key, split_params_text};
use crate::plan::Plan;
use crate::store::{ActionRecord, Digest, Manifest, Store, short};
use anyhow::{Result, anyhow};
use std::collections::BTreeMap;

/// Why each needed node would (re)run, without running anything.
pub fn explain(plan: &Plan, store: &Store, target: &str) -> Result<String> {
    let t = plan
        .index(target)
        .ok_or_else(|| anyhow!("no node `{target}` in {}", plan.source.path.display()))?;
    let mut sub = plan.clone();
    sub.targets = vec![t];
    let mut known: BTreeMap<usize, Option<BTreeMap<String, Digest>>> = BTreeMap::new();
    let mut lines = Vec::new();
    for i in sub.needed() {
        let node = &plan.nodes[i];
        let mut inputs = BTreeMap::new();
        let mut unknown_up = None;
        for inp in &node.inputs {
            match known
                .get(&inp.from)
                .cloned()
                .flatten()
                .and_then(|o| o.get(&inp.from_port).cloned())
            {
                Some(d) => {
                    inputs.insert(inp.port.clone(), d);
                }
                None => unknown_up = Some(plan.nodes[inp.from].id.clone()),
            }
        }
        if let Some(up) = unknown_up {
            lines.push(format!(
                "{}: will run if `{up}` produces new outputs (its inputs are not cached yet)",
                node.id
            ));
            known.insert(i, None);
            continue;
        }
        let pk = params_key(plan, i)?;
        let spec = &node.reg.spec;
        let each = node.inputs.iter().find(|x| x.each);
        let items: Vec<Option<(String, Digest)>> = match each {
            None => vec![None],
            Some(e) => match store
                .manifest(&inputs.remove(&e.port).unwrap_or_default())
                .ok()
                .flatten()
            {
                Some(Manifest::Collection { items, .. }) => items.into_iter().map(Some).collect(),
                _ => vec![],
            },
        };
        let head = store.head(&plan.source.path, &node.id).unwrap_or_default();
        let mut hits = 0;
        let mut reasons = Vec::new();
        let mut outputs: Option<BTreeMap<String, Vec<(String, Digest)>>> = Some(BTreeMap::new());
        for item in &items {
            let key = compute_key(&spec.kind, &spec.version, &pk, &inputs, item.as_ref());
            let name = item.as_ref().map(|(n, _)| n.clone()).unwrap_or_default();
            match cached(store, &key).ok().flatten() {
                Some(rec) => {
                    hits += 1;
                    if let Some(o) = outputs.as_mut() {
                        for (p, d) in rec.outputs {
                            o.entry(p).or_default().push((name.clone(), d));
                        }
                    }
                }
                None => {
                    outputs = None;
                    let why = match head.get(&name).and_then(|k| store.action(k).ok().flatten()) {
                        None => "it has never run with this graph".to_string(),
                        Some(prev) => diff_reason(&prev, spec, &pk, &inputs),
                    };
                    reasons.push(if name.is_empty() {
                        why
                    } else {
                        format!("item `{name}`: {why}")
                    });
                }
            }
        }
        if reasons.is_empty() {
            lines.push(format!(
                "{}: cached ({} run{})",
                node.id,
                hits.max(1),
                if hits == 1 { "" } else { "s" }
            ));
            let outs = outputs.unwrap_or_default();
            let resolved: BTreeMap<String, Digest> = if each.is_some() {
                outs.into_iter()
                    .filter_map(|(p, items)| {
                        let ty = node.outputs.get(&p)?.element().to_string();
                        store
                            .put_manifest(&Manifest::Collection { ty, items })
                            .ok()
                            .map(|d| (p, d))
                    })
                    .collect()
            } else {
                outs.into_iter()
                    .filter_map(|(p, mut v)| v.pop().map(|(_, d)| (p, d)))
                    .collect()
            };
            known.insert(i, Some(resolved));
        } else {
            lines.push(format!("{}: will run — {}", node.id, reasons.join("; ")));
            known.insert(i, None);
        }
    }
    Ok(lines.join("\n"))
}

/// `iterations: 600 → 300; schedule.patience: 300 → 200` between two keys' params
/// texts; a path param's content fingerprint reads as "its content changed".
fn params_diff(was: &str, now: &str) -> String {
    let parse = |t: &str| crate::syntax::parse(t).map(|v| v.to_value());
    let (Ok(a), Ok(b)) = (parse(was), parse(now)) else {
        // Keys written by an older version may not parse: show both texts.
        return format!("was {was}, now {now}");
    };
    let fingerprint = |line: &str| line.contains("\"file:") || line.contains("\"dir:");
    a.diff(&b, "")
        .into_iter()
        .map(|line| match line.split_once(": ") {
            Some((path, _)) if fingerprint(&line) => {
                format!("{path}: the file or folder it names changed")
            }
            _ => line,
        })
        .collect::<Vec<_>>()
        .join("; ")
}

fn diff_reason(
    prev: &ActionRecord,
    spec: &crate::NodeSpec,
    params: &str,
    inputs: &BTreeMap<String, Digest>,
) -> String {
    let mut why = Vec::new();
    if prev.version != spec.version {
        why.push(format!(
            "code version changed ({} → {})",
            prev.version, spec.version
        ));
    }
    let (prev_params, prev_reads, prev_tools) = split_params_text(&prev.params);
    let (now_params, now_reads, now_tools) = split_params_text(params);
    if prev_params != now_params {
        why.push(format!(
            "params changed: {}",
            params_diff(prev_params, now_params)
        ));
    }
    if prev_reads != now_reads {
        why.push("a file it reads changed (an image, a script, a folder beside its inputs)".into());
    }
    if prev_tools != now_tools {
        let shown = |t: &str| {
            if t.is_empty() {
                "none".to_string()
            } else {
                t.to_string()
            }
        };
        why.push(format!(
            "a program it starts changed ({} → {})",
            shown(prev_tools),
            shown(now_tools)
        ));
    }
    for (port, d) in inputs {
        match prev.inputs.get(port) {
            Some(p) if p == d => {}
            Some(p) => why.push(format!(
                "input `{port}` changed ({} → {})",
                short(p),
                short(d)
            )),
            None => why.push(format!("input `{port}` is new")),
        }
    }
    if why.is_empty() {
        "its cached outputs are missing or were corrupt".into()
    } else {
        why.join(", ")
    }
}
