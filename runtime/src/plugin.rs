//! Node kinds from shared libraries (ABI v1; docs/plugins.md), run in child processes.
//!
//! A plugin library exports `objectsplat_plugin_entry_v1`, returning a `#[repr(C)]`
//! table (see [`abi`]). The engine never loads it: a child process ([`child`],
//! started by [`host`] from the engine's own executable) opens the library, checks
//! the table's ABI version and size, and asks it to `describe` itself (JSON); each
//! described node kind becomes a [`PluginNode`] registered with
//! `Origin::Plugin`. Every run is another child making one `run` call, so a library
//! that crashes, aborts, exits or hangs fails its node and nothing else. From then
//! on the engine validates, caches, schedules and reports plugin nodes exactly like
//! built-in ones. A node's code version is the plugin's declared version plus a
//! digest of the library file ([`spec::node_version`]); the child refuses to run a
//! library whose digest changed since it was described.

pub mod child;
pub mod host;
pub mod library;
pub mod node;
pub mod spec;
pub mod wire;

pub use host::set_host_program;
/// The boundary's types, declared once for the host and the SDK.
pub use objectsplat_plugin_abi::{abi, protocol};

use crate::registry::{Origin, Registry};
use node::PluginNode;
use protocol::Description;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// A plugin library as the engine knows it: what its child process reported.
pub struct PluginLibrary {
    /// Canonical path.
    pub path: PathBuf,
    /// `"<plugin crate> <version> (<sdk>, <rustc>)"`.
    pub build: String,
    /// blake3 of the library file, hex.
    pub digest: String,
    pub description: Description,
}

/// Libraries described by this process, by canonical path and digest, so loading
/// the same file twice starts one child.
static DESCRIBED: Mutex<Vec<Arc<PluginLibrary>>> = Mutex::new(Vec::new());

/// How long a library may take to load and describe itself.
const DESCRIBE_TIMEOUT: Duration = Duration::from_secs(60);

/// Loads a plugin library and registers its node kinds, all or none.
///
/// Errors say what is wrong with the library (not a shared library, no entry symbol,
/// ABI mismatch, malformed description, unknown type, kind collision, a crash while
/// loading...) without repeating its path; callers prefix it (the CLI prints
/// `plugin PATH: ...`). Loading the same library into the same registry again
/// changes nothing.
pub fn load(reg: &mut Registry, path: &Path) -> Result<(), String> {
    let library = describe(path)?;
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

/// Describes `path` in a child process (or returns what this process learnt before).
fn describe(path: &Path) -> Result<Arc<PluginLibrary>, String> {
    let (canonical, digest) = library::identify(path)?;
    // A poisoned lock only means another thread panicked while holding it; the list
    // itself is always consistent (entries are pushed whole).
    let known = DESCRIBED
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .iter()
        .find(|l| l.path == canonical && l.digest == digest)
        .cloned();
    if let Some(lib) = known {
        return Ok(lib);
    }
    let reply = host::call(
        &wire::Call::Describe {
            library: canonical.clone(),
        },
        DESCRIBE_TIMEOUT,
        &mut |_, _, _| {},
        &|| false,
    )
    .map_err(|e| format!("loading it failed: its process {e}"))?;
    let (digest, build, text) = match reply {
        wire::Reply::Described {
            digest,
            build,
            description,
        } => (digest, build, description),
        wire::Reply::Refused { message } => return Err(message),
        other => return Err(format!("its process answered describe with {other:?}")),
    };
    let description: Description =
        serde_json::from_str(&text).map_err(|e| format!("its describe text is malformed: {e}"))?;
    let lib = Arc::new(PluginLibrary {
        path: canonical,
        build,
        digest,
        description,
    });
    DESCRIBED
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .push(lib.clone());
    Ok(lib)
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
        // The child's loader, called in this process.
        let e = super::library::open(&text).err().unwrap();
        assert!(
            e.starts_with("not a shared library this system can load"),
            "{e}"
        );
        // Checked by the engine before any child is started.
        let mut reg = crate::Registry::new();
        let e = super::load(&mut reg, &dir.path().join("missing.so")).unwrap_err();
        assert!(e.starts_with("cannot read the file"), "{e}");
        let e = super::load(&mut reg, dir.path()).unwrap_err();
        assert_eq!(e, "is a folder, not a shared library");
    }
}
