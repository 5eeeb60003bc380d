//! Opening a plugin library: the dlopen, the entry symbol, the ABI checks and the
//! `describe` call. Only plugin child processes (the `child` module) open libraries;
//! the engine never maps plugin code. Libraries are never unloaded (unloading Rust
//! cdylibs is unsound in general), so each canonical path is opened once per process.

use super::abi::{
    ABI_VERSION, ENTRY_SYMBOL, EntryFn, EntryHeader, EntryV1, OwnedBuf, STATUS_OK, STATUS_PANIC,
    StaticStr,
};
use super::protocol::Description;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// A plugin library that passed every check.
pub struct LoadedLibrary {
    /// Canonical path.
    pub path: PathBuf,
    pub entry: &'static EntryV1,
    /// `"<plugin crate> <version> (<sdk>, <rustc>)"`.
    pub build: String,
    /// blake3 of the library file, hex.
    pub digest: String,
    pub description: Description,
    /// The describe text as the library answered it (checked by parsing `description`).
    pub description_json: String,
}

static LOADED: Mutex<Vec<Arc<LoadedLibrary>>> = Mutex::new(Vec::new());

/// The canonical path of a library file and the digest of its bytes: what identifies a
/// build, so a changed file is never taken for one already described or opened.
pub fn identify(path: &Path) -> Result<(PathBuf, String), String> {
    let meta = std::fs::metadata(path).map_err(|e| format!("cannot read the file: {e}"))?;
    if meta.is_dir() {
        return Err("is a folder, not a shared library".into());
    }
    let canonical = path
        .canonicalize()
        .map_err(|e| format!("cannot resolve the path: {e}"))?;
    let bytes = std::fs::read(&canonical).map_err(|e| format!("cannot read the file: {e}"))?;
    let digest = blake3::hash(&bytes).to_hex().to_string();
    Ok((canonical, digest))
}

/// Opens `path` (or returns the copy this process already opened).
pub fn open(path: &Path) -> Result<Arc<LoadedLibrary>, String> {
    let (canonical, digest) = identify(path)?;
    // A poisoned lock only means another thread panicked while holding it; the
    // list itself is always in a consistent state (entries are pushed whole).
    let mut loaded = LOADED.lock().unwrap_or_else(|p| p.into_inner());
    if let Some(lib) = loaded.iter().find(|l| l.path == canonical) {
        if lib.digest != digest {
            return Err("the file changed since this process loaded it (libraries are never reloaded); start a new process to use the new build".into());
        }
        return Ok(lib.clone());
    }
    let lib = Arc::new(open_new(&canonical, digest)?);
    loaded.push(lib.clone());
    Ok(lib)
}

fn open_new(path: &Path, digest: String) -> Result<LoadedLibrary, String> {
    // SAFETY: loading a library runs its initialisers; plugins are trusted code by
    // design (docs/plugins.md), like the objectsplat binary itself.
    let library = unsafe { libloading::Library::new(path) }
        .map_err(|e| format!("not a shared library this system can load: {e}"))?;
    // Never unloaded: the entry table and every function it points to stay valid.
    let library: &'static libloading::Library = Box::leak(Box::new(library));
    // SAFETY: the symbol's type is the ABI's entry signature; a library that exports
    // the name with another signature violates the ABI and cannot be detected.
    let entry_fn: EntryFn = unsafe { library.get::<EntryFn>(ENTRY_SYMBOL.as_bytes()) }
        .map(|s| *s)
        .map_err(|_| format!("not an ObjectSplat plugin: no `{ENTRY_SYMBOL}` symbol"))?;
    // SAFETY: calling the entry function is the ABI's first step; it takes no arguments.
    let table = unsafe { entry_fn() };
    // SAFETY: the table pointer comes from the plugin's static data (checked for null inside).
    let entry = unsafe { check_table(table) }?;
    let build = format!(
        "{} ({})",
        read_static(entry.plugin_build, "plugin_build")?,
        read_static(entry.sdk_build, "sdk_build")?
    );
    let description_json = describe(entry)?;
    let description = serde_json::from_str(&description_json)
        .map_err(|e| format!("its describe text is malformed: {e}"))?;
    Ok(LoadedLibrary {
        path: path.to_path_buf(),
        entry,
        build,
        digest,
        description,
        description_json,
    })
}

/// Checks the version and size fields before touching anything else of the table.
///
/// # Safety
/// `table` must be null or point to at least an [`EntryHeader`] of static data.
pub(crate) unsafe fn check_table(table: *const EntryV1) -> Result<&'static EntryV1, String> {
    if table.is_null() {
        return Err(format!("`{ENTRY_SYMBOL}` returned no entry table"));
    }
    // SAFETY: every ABI version's table starts with the header (caller's guarantee).
    let header = unsafe { &*(table as *const EntryHeader) };
    if header.abi_version != ABI_VERSION {
        return Err(format!(
            "built for ABI v{}, this objectsplat speaks v{ABI_VERSION}; rebuild the plugin against a matching objectsplat-plugin-sdk",
            header.abi_version
        ));
    }
    let needed = std::mem::size_of::<EntryV1>();
    if header.struct_size < needed {
        return Err(format!(
            "its ABI v{ABI_VERSION} entry table is {} bytes, expected at least {needed}; the plugin's SDK does not match its declared ABI",
            header.struct_size
        ));
    }
    // SAFETY: version and size say the table holds a whole EntryV1.
    Ok(unsafe { &*table })
}

/// Longest build string accepted; anything longer means a corrupt table.
const MAX_BUILD_TEXT: usize = 4096;

fn read_static(s: StaticStr, field: &str) -> Result<String, String> {
    if s.ptr.is_null() || s.len > MAX_BUILD_TEXT {
        return Err(format!("entry table field `{field}` is not a valid string"));
    }
    // SAFETY: the ABI says ptr/len describe static UTF-8 data in the library.
    let bytes = unsafe { std::slice::from_raw_parts(s.ptr, s.len) };
    std::str::from_utf8(bytes)
        .map(str::to_string)
        .map_err(|_| format!("entry table field `{field}` is not UTF-8"))
}

/// Copies a buffer the plugin filled and returns it to the plugin's `free`.
pub(crate) fn take(entry: &EntryV1, buf: OwnedBuf) -> Vec<u8> {
    let bytes = if buf.ptr.is_null() {
        Vec::new()
    } else {
        // SAFETY: the plugin filled ptr/len with bytes it owns until we call free.
        unsafe { std::slice::from_raw_parts(buf.ptr, buf.len) }.to_vec()
    };
    // SAFETY: the buffer came from this plugin and is released exactly once.
    unsafe { (entry.free)(buf) };
    bytes
}

fn describe(entry: &EntryV1) -> Result<String, String> {
    let mut out = OwnedBuf {
        ptr: std::ptr::null_mut(),
        len: 0,
        cap: 0,
    };
    // SAFETY: `out` is a valid slot for the plugin to fill.
    let status = unsafe { (entry.describe)(&mut out) };
    let bytes = take(entry, out);
    match status {
        STATUS_OK => {}
        STATUS_PANIC => {
            return Err(format!(
                "`describe` panicked: {}",
                String::from_utf8_lossy(&bytes)
            ));
        }
        _ => {
            return Err(format!(
                "`describe` failed: {}",
                String::from_utf8_lossy(&bytes)
            ));
        }
    }
    String::from_utf8(bytes).map_err(|_| "its describe text is not UTF-8".to_string())
}
