//! Turning a plugin's description into engine node specs, refusing anything the
//! engine cannot represent with a message that names the entry.

use super::protocol::{Description, NodeDescription, PortDescription};
use crate::node::{NodeSpec, PortSpec, TypeRef};
use crate::params::{ParamSpec, ParamType};

/// Hex digits of the library digest kept in node versions.
const DIGEST_CHARS: usize = 12;

/// The param the engine adds to every plugin node kind: seconds before the run's
/// child process is killed. It is not sent to the plugin.
pub const TIMEOUT_PARAM: &str = "plugin_timeout_s";

/// One hour: generous for an image stage, and a hung plugin still ends.
const DEFAULT_TIMEOUT_S: &str = "3600.0";

/// The code version the engine records for a plugin node: the plugin's declared
/// version plus a digest of the library file. The declared version is what authors
/// bump on purpose; the digest makes any rebuilt library a new version too, so a
/// forgotten bump can never serve stale cached results.
pub fn node_version(declared: &str, library_digest: &str) -> String {
    let short: String = library_digest.chars().take(DIGEST_CHARS).collect();
    format!("{declared}+lib.{short}")
}

/// Node specs for every kind of the description (types are checked later, against
/// the registry the plugin is loaded into).
pub fn node_specs(desc: &Description, library_digest: &str) -> Result<Vec<NodeSpec>, String> {
    if desc.plugin.trim().is_empty() {
        return Err("its description has an empty `plugin` name".into());
    }
    if desc.version.trim().is_empty() {
        return Err(format!(
            "plugin `{}` declares an empty code `version`",
            desc.plugin
        ));
    }
    if desc.nodes.is_empty() {
        return Err(format!("plugin `{}` declares no node kinds", desc.plugin));
    }
    let version = node_version(&desc.version, library_digest);
    desc.nodes.iter().map(|n| node_spec(n, &version)).collect()
}

fn node_spec(n: &NodeDescription, version: &str) -> Result<NodeSpec, String> {
    let port = |p: &PortDescription, side: &str| -> Result<PortSpec, String> {
        let ty = TypeRef::parse(&p.ty)
            .map_err(|e| format!("node `{}` {side} `{}`: {e}", n.kind, p.name))?;
        Ok(PortSpec {
            name: p.name.clone(),
            ty,
            optional: p.optional,
            doc: p.doc.clone(),
        })
    };
    let mut spec = NodeSpec::new(&n.kind, version).doc(&n.doc);
    spec.inputs = n
        .inputs
        .iter()
        .map(|p| port(p, "input"))
        .collect::<Result<_, _>>()?;
    spec.outputs = n
        .outputs
        .iter()
        .map(|p| port(p, "output"))
        .collect::<Result<_, _>>()?;
    if spec.outputs.iter().any(|p| p.optional) {
        return Err(format!("node `{}`: outputs cannot be optional", n.kind));
    }
    if n.params.iter().any(|p| p.name == TIMEOUT_PARAM) {
        return Err(format!(
            "node `{}`: param `{TIMEOUT_PARAM}` is the host's (the run's time limit); rename it",
            n.kind
        ));
    }
    spec.params = n
        .params
        .iter()
        .map(|p| {
            let ty = ParamType::parse(&p.ty)
                .map_err(|e| format!("node `{}` param `{}`: {e}", n.kind, p.name))?;
            Ok(ParamSpec {
                name: p.name.clone(),
                ty,
                default: p.default.clone(),
                doc: p.doc.clone(),
            })
        })
        .collect::<Result<_, String>>()?;
    spec.params.push(ParamSpec {
        name: TIMEOUT_PARAM.into(),
        ty: ParamType::float_range(0.001, 1.0e9),
        default: Some(DEFAULT_TIMEOUT_S.into()),
        doc:
            "seconds before the run's process is killed (the host's limit, not sent to the plugin)"
                .into(),
    });
    Ok(spec)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn description(json: &str) -> Description {
        serde_json::from_str(json).expect("test JSON is well formed")
    }

    #[test]
    fn declared_version_and_library_digest_both_enter_the_node_version() {
        let d = description(
            r#"{"plugin":"p","version":"7","nodes":[{"kind":"k","outputs":[{"name":"image","type":"Image"}],
                "params":[{"name":"r","type":"float(0..1)","default":"0.5"}]}]}"#,
        );
        let specs = node_specs(&d, "0123456789abcdef0123").unwrap();
        assert_eq!(specs[0].version, "7+lib.0123456789ab");
        assert_ne!(
            specs[0].version,
            node_specs(&d, "fedcba9876543210").unwrap()[0].version
        );
        assert_eq!(specs[0].params[0].ty, ParamType::float_range(0.0, 1.0));
        assert_eq!(specs[0].outputs[0].ty, TypeRef::One("Image".into()));
    }

    #[test]
    fn bad_entries_are_refused_by_name() {
        let bad_port = description(
            r#"{"plugin":"p","version":"1","nodes":[{"kind":"k","outputs":[{"name":"o","type":"[Image"}]}]}"#,
        );
        let e = node_specs(&bad_port, "00").unwrap_err();
        assert!(e.contains("node `k` output `o`"), "{e}");
        let bad_param = description(
            r#"{"plugin":"p","version":"1","nodes":[{"kind":"k","outputs":[],"params":[{"name":"x","type":"floaty"}]}]}"#,
        );
        let e = node_specs(&bad_param, "00").unwrap_err();
        assert!(
            e.contains("node `k` param `x`") && e.contains("unknown param type"),
            "{e}"
        );
        let no_nodes = description(r#"{"plugin":"p","version":"1","nodes":[]}"#);
        assert!(
            node_specs(&no_nodes, "00")
                .unwrap_err()
                .contains("declares no node kinds")
        );
        let no_version = description(r#"{"plugin":"p","version":" ","nodes":[]}"#);
        assert!(
            node_specs(&no_version, "00")
                .unwrap_err()
                .contains("empty code `version`")
        );
    }
}
