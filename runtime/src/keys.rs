//! Cache keys. The key of a run = blake3(kind, code version, canonical params with input
//! paths replaced by their content fingerprint [+ the fingerprint of the files the node
//! reads] [+ the versions of the programs it starts], input digests, fan-out item).
//! Because input digests are themselves derived from upstream keys' outputs, a key
//! is a Merkle hash of everything upstream; because they are digests of *outputs*,
//! a rerun that reproduces the same bytes leaves its consumers' keys unchanged
//! (early cutoff). docs/engine.md, "Cache key".

use crate::plan::Plan;
use crate::store::{Digest, Store};
use anyhow::{Context as _, Result};
use std::collections::BTreeMap;

/// Separates the params from the fingerprint of the files a node reads
/// ([`crate::Node::reads`]) in a key's params text.
const READS_SEPARATOR: &str = " + ";

/// Separates the rest of a key's params text from the versions of the programs a
/// node starts ([`crate::Node::tool_versions`], a JSON list), which come last.
const TOOLS_SEPARATOR: &str = " + tools: ";

/// The params text of node `i`'s key: canonical params, then the fingerprint of the
/// files it reads and the versions of the programs it starts, where it has them.
pub(crate) fn params_key(plan: &Plan, i: usize) -> Result<String> {
    let n = &plan.nodes[i];
    let mut params = n.params.clone();
    for (name, path) in &n.input_paths {
        let fp =
            Store::fingerprint(path).with_context(|| format!("node `{}` param `{name}`", n.id))?;
        params.values.insert(name.clone(), crate::Value::Str(fp));
    }
    let reads = n
        .reg
        .node
        .reads(&n.params)
        .with_context(|| format!("node `{}`: listing the files it reads", n.id))?;
    let mut key = params.canonical();
    if !reads.is_empty() {
        let fp = Store::fingerprint_reads(&reads)
            .with_context(|| format!("node `{}`: fingerprinting the files it reads", n.id))?;
        key = format!("{key}{READS_SEPARATOR}{fp}");
    }
    let tools = n.reg.node.tool_versions(&n.params);
    if !tools.is_empty() {
        key = format!("{key}{TOOLS_SEPARATOR}{}", serde_json::Value::from(tools));
    }
    Ok(key)
}

/// The key of one run of a node (or of one fan-out item).
pub(crate) fn compute_key(
    kind: &str,
    version: &str,
    params: &str,
    inputs: &BTreeMap<String, Digest>,
    item: Option<&(String, Digest)>,
) -> String {
    let mut h = blake3::Hasher::new();
    h.update(b"objectsplat-key-v1\0");
    for part in [kind, version, params] {
        h.update(part.as_bytes());
        h.update(b"\0");
    }
    for (port, d) in inputs {
        h.update(format!("{port}={d}\0").as_bytes());
    }
    if let Some((name, d)) = item {
        h.update(format!("item:{name}={d}\0").as_bytes());
    }
    h.finalize().to_hex().to_string()
}

/// A key's params text split back into (params, files-read fingerprint, program
/// versions), empty where absent. Each suffix is recognised by its form, from the end,
/// so a param value holding a separator (`"a + b"`) stays in the params.
pub(crate) fn split_params_text(text: &str) -> (&str, &str, &str) {
    let (rest, tools) = match text.rsplit_once(TOOLS_SEPARATOR) {
        Some((rest, tools))
            if serde_json::from_str::<Vec<String>>(tools).is_ok_and(|t| !t.is_empty()) =>
        {
            (rest, tools)
        }
        _ => (text, ""),
    };
    let (params, reads) = match rest.rsplit_once(READS_SEPARATOR) {
        Some((params, reads)) if is_reads_fingerprint(reads) => (params, reads),
        _ => (rest, ""),
    };
    (params, reads, tools)
}

/// `reads:` and a blake3 hex digest, as [`Store::fingerprint_reads`] writes it.
fn is_reads_fingerprint(text: &str) -> bool {
    text.strip_prefix("reads:")
        .is_some_and(|hex| hex.len() == 64 && hex.bytes().all(|b| b.is_ascii_hexdigit()))
}

#[cfg(test)]
mod tests {
    use super::split_params_text;

    #[test]
    fn separators_inside_param_values_stay_in_the_params() {
        let reads = format!("reads:{}", "ab".repeat(32));
        let params = r#"(label: "a + b", note: " + tools: [\"x\"]")"#;
        assert_eq!(split_params_text(params), (params, "", ""));
        let with_reads = format!("{params} + {reads}");
        assert_eq!(split_params_text(&with_reads), (params, reads.as_str(), ""));
        let all = format!(r#"{params} + {reads} + tools: ["colmap 3.8"]"#);
        assert_eq!(
            split_params_text(&all),
            (params, reads.as_str(), r#"["colmap 3.8"]"#)
        );
        let tools_only = format!(r#"{params} + tools: ["ffmpeg 5"]"#);
        assert_eq!(
            split_params_text(&tools_only),
            (params, "", r#"["ffmpeg 5"]"#)
        );
    }
}
