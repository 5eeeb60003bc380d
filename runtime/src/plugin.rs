//! Loading node kinds from shared libraries (ABI v1; docs/plugins.md).
//!
//! A plugin library exports `objectsplat_plugin_entry_v1`, returning a `#[repr(C)]`
//! table (see [`abi`]). Loading checks the table's ABI version and size, asks the
//! plugin to `describe` itself (JSON), turns each described node kind into a
//! [`PluginNode`](node::PluginNode) and registers it with
//! `Origin::Plugin`; from then on the engine validates, caches, schedules and
//! reports plugin nodes exactly like built-in ones. A node's code version is the
//! plugin's declared version plus a digest of the library file ([`spec::node_version`]).

pub mod abi;
pub mod library;
pub mod node;
pub mod protocol;
pub mod spec;

use crate::registry::{Origin, Registry};
use node::PluginNode;
use std::path::Path;
use std::sync::Arc;

/// Loads a plugin library and registers its node kinds, all or none.
///
/// Errors say what is wrong with the library (not a shared library, no entry symbol,
/// ABI mismatch, malformed description, unknown type, kind collision...) without
/// repeating its path; callers prefix it (the CLI prints `plugin PATH: ...`).
/// Loading the same library into the same registry again changes nothing.
pub fn load(reg: &mut Registry, path: &Path) -> Result<(), String> {
    let library = library::open(path)?;
    let specs = spec::node_specs(&library.description, &library.digest)?;
    let origin = Origin::Plugin {
        path: library.path.display().to_string(),
        build: library.build.clone(),
    };
    if specs
        .iter()
        .all(|s| reg.get(&s.kind).is_some_and(|r| r.origin == origin))
    {
        return Ok(());
    }
    // Register into a copy so a refusal halfway leaves the registry untouched.
    let mut trial = reg.clone();
    for spec in specs {
        let node = Arc::new(PluginNode {
            spec,
            library: library.clone(),
        });
        trial
            .add_node_from(node, origin.clone())
            .map_err(|e| format!("plugin `{}`: {e}", library.description.plugin))?;
    }
    *reg = trial;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::abi::{ABI_VERSION, EntryV1, OwnedBuf, StaticStr};
    use super::library::check_table;

    unsafe extern "C" fn describe(_: *mut OwnedBuf) -> i32 {
        1
    }
    unsafe extern "C" fn run(
        _: *const u8,
        _: usize,
        _: *const super::abi::HostV1,
        _: *mut OwnedBuf,
    ) -> i32 {
        1
    }
    unsafe extern "C" fn free(_: OwnedBuf) {}

    fn table(abi_version: u32, struct_size: usize) -> EntryV1 {
        let empty = StaticStr {
            ptr: "".as_ptr(),
            len: 0,
        };
        EntryV1 {
            abi_version,
            struct_size,
            plugin_build: empty,
            sdk_build: empty,
            describe,
            run,
            free,
        }
    }

    #[test]
    fn entry_tables_are_checked_for_version_then_size() {
        let newer = Box::leak(Box::new(table(2, 8)));
        // SAFETY: the table is a leaked, valid EntryV1.
        let e = unsafe { check_table(newer) }.err().unwrap();
        assert_eq!(
            e,
            "built for ABI v2, this objectsplat speaks v1; rebuild the plugin against a matching objectsplat-plugin-sdk"
        );
        let truncated = Box::leak(Box::new(table(ABI_VERSION, 16)));
        // SAFETY: as above.
        let e = unsafe { check_table(truncated) }.err().unwrap();
        assert!(e.contains("entry table is 16 bytes"), "{e}");
        let larger = Box::leak(Box::new(table(
            ABI_VERSION,
            std::mem::size_of::<EntryV1>() + 8,
        )));
        // SAFETY: as above; a larger declared size is a newer SDK of the same ABI.
        assert!(unsafe { check_table(larger) }.is_ok());
        // SAFETY: null is allowed.
        assert!(
            unsafe { check_table(std::ptr::null()) }
                .err()
                .unwrap()
                .contains("returned no entry table")
        );
    }

    #[test]
    fn files_that_are_not_plugins_are_refused_with_the_reason() {
        let dir = tempfile::tempdir().unwrap();
        let text = dir.path().join("notes.so");
        std::fs::write(&text, "just text").unwrap();
        let mut reg = crate::Registry::new();
        let e = super::load(&mut reg, &text).unwrap_err();
        assert!(
            e.starts_with("not a shared library this system can load"),
            "{e}"
        );
        let e = super::load(&mut reg, &dir.path().join("missing.so")).unwrap_err();
        assert!(e.starts_with("cannot read the file"), "{e}");
        let e = super::load(&mut reg, dir.path()).unwrap_err();
        assert_eq!(e, "is a folder, not a shared library");
    }
}
