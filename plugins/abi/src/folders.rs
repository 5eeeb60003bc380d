//! The folders a running node reads and writes, with the accessors a node calls on
//! them: one declaration for the engine's `Context` (built-in nodes) and the SDK's
//! `Request` (plugins), so a node moved between the two sees the same answers and the
//! same errors.

use anyhow::{Result, anyhow, bail};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// An input as the node sees it.
#[derive(Debug, Clone, PartialEq)]
pub enum InputValue {
    /// One artifact: its folder.
    One(PathBuf),
    /// A collection: a folder with one sub-folder per item, plus the items in order.
    Items {
        dir: PathBuf,
        items: Vec<(String, PathBuf)>,
    },
}

/// A node run's wired inputs and the empty folders its outputs go into, by port name.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PortFolders {
    pub inputs: BTreeMap<String, InputValue>,
    pub outputs: BTreeMap<String, PathBuf>,
}

impl PortFolders {
    /// The folder of a single-artifact input (or of the item, under fan-out).
    pub fn input(&self, port: &str) -> Result<&Path> {
        match self.inputs.get(port) {
            Some(InputValue::One(p)) => Ok(p),
            Some(InputValue::Items { .. }) => {
                bail!("input `{port}` is a collection; use input_items")
            }
            None => bail!("input `{port}` is not connected"),
        }
    }

    /// `None` when an optional input is not wired; a collection's folder otherwise.
    pub fn input_opt(&self, port: &str) -> Option<&Path> {
        match self.inputs.get(port) {
            Some(InputValue::One(p)) => Some(p),
            Some(InputValue::Items { dir, .. }) => Some(dir),
            None => None,
        }
    }

    /// The items of a collection input, in order: (item name, folder).
    pub fn input_items(&self, port: &str) -> Result<&[(String, PathBuf)]> {
        match self.inputs.get(port) {
            Some(InputValue::Items { items, .. }) => Ok(items),
            Some(InputValue::One(_)) => bail!("input `{port}` is a single artifact; use input"),
            None => bail!("input `{port}` is not connected"),
        }
    }

    /// The empty folder to write an output into. For a collection output (`[T]`),
    /// write one sub-folder per item, named by the item.
    pub fn output(&self, port: &str) -> Result<PathBuf> {
        self.outputs
            .get(port)
            .cloned()
            .ok_or_else(|| anyhow!("node has no output `{port}`"))
    }

    /// Checks that `output` may be made the very same artifact as `input`.
    pub fn check_forward(&self, input: &str, output: &str) -> Result<()> {
        if !self.inputs.contains_key(input) {
            bail!("cannot forward: input `{input}` is not connected");
        }
        if !self.outputs.contains_key(output) {
            bail!("cannot forward: no output `{output}`");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folders() -> PortFolders {
        let mut f = PortFolders::default();
        f.inputs.insert("one".into(), InputValue::One("a".into()));
        f.inputs.insert(
            "many".into(),
            InputValue::Items {
                dir: "m".into(),
                items: vec![("x".into(), "m/x".into())],
            },
        );
        f.outputs.insert("out".into(), "o".into());
        f
    }

    #[test]
    fn each_accessor_answers_its_kind_of_port_and_names_the_wrong_one() {
        let f = folders();
        assert_eq!(f.input("one").unwrap(), Path::new("a"));
        assert_eq!(f.input_items("many").unwrap()[0].0, "x");
        assert_eq!(f.input_opt("many"), Some(Path::new("m")));
        assert_eq!(f.input_opt("absent"), None);
        assert_eq!(f.output("out").unwrap(), PathBuf::from("o"));
        let e = |r: Result<()>| r.unwrap_err().to_string();
        assert!(e(f.input("many").map(drop)).contains("use input_items"));
        assert!(e(f.input_items("one").map(drop)).contains("use input"));
        assert!(e(f.input("absent").map(drop)).contains("not connected"));
        assert!(e(f.output("in").map(drop)).contains("no output `in`"));
        assert!(f.check_forward("one", "out").is_ok());
        assert!(e(f.check_forward("absent", "out")).contains("not connected"));
        assert!(e(f.check_forward("one", "absent")).contains("no output"));
    }
}
