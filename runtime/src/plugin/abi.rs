//! The host's copy of the plugin ABI v1 layout. It must match
//! plugins/sdk/src/abi.rs field for field (tests/plugins.rs loads real plugins
//! built with the SDK, which catches a divergence); a plugin written in another
//! language declares the same structs (docs/plugins.md).

use std::ffi::c_void;

pub const ABI_VERSION: u32 = 1;
pub const ENTRY_SYMBOL: &str = "objectsplat_plugin_entry_v1";

pub const STATUS_OK: i32 = 0;
pub const STATUS_ERROR: i32 = 1;
pub const STATUS_PANIC: i32 = 2;

#[repr(C)]
#[derive(Clone, Copy)]
pub struct StaticStr {
    pub ptr: *const u8,
    pub len: usize,
}

/// Bytes allocated by the plugin; only the plugin's `free` may release them.
#[repr(C)]
pub struct OwnedBuf {
    pub ptr: *mut u8,
    pub len: usize,
    pub cap: usize,
}

#[repr(C)]
pub struct HostV1 {
    pub struct_size: usize,
    pub ctx: *const c_void,
    pub progress:
        unsafe extern "C" fn(ctx: *const c_void, done: u64, total: u64, msg: *const u8, len: usize),
    pub cancelled: unsafe extern "C" fn(ctx: *const c_void) -> u8,
}

/// The fields every ABI version starts with; read before anything else.
#[repr(C)]
pub struct EntryHeader {
    pub abi_version: u32,
    pub struct_size: usize,
}

#[repr(C)]
pub struct EntryV1 {
    pub abi_version: u32,
    pub struct_size: usize,
    pub plugin_build: StaticStr,
    pub sdk_build: StaticStr,
    pub describe: unsafe extern "C" fn(out: *mut OwnedBuf) -> i32,
    pub run: unsafe extern "C" fn(
        request: *const u8,
        len: usize,
        host: *const HostV1,
        out: *mut OwnedBuf,
    ) -> i32,
    pub free: unsafe extern "C" fn(buf: OwnedBuf),
}

pub type EntryFn = unsafe extern "C" fn() -> *const EntryV1;

// SAFETY: an entry table is immutable static data of a library that is never
// unloaded, and the ABI requires its functions to be callable from any thread.
unsafe impl Sync for EntryV1 {}
