//! The C-level contract between objectsplat and a plugin library (ABI v1).
//!
//! A plugin exports one symbol, [`ENTRY_SYMBOL`], an `extern "C" fn() -> *const EntryV1`.
//! The table it returns starts with `abi_version` and `struct_size`; the host reads
//! those two fields first and touches nothing else unless the version matches and the
//! table is at least as large as the host's `EntryV1` (new fields are only ever
//! appended, so a larger table from a newer SDK of the same ABI version is fine).
//!
//! Only bytes cross the boundary: UTF-8 JSON text (the description, run requests and
//! responses), UTF-8 messages and file paths inside that JSON. A buffer the plugin
//! hands out ([`OwnedBuf`]) is released by calling the plugin's own `free`; a buffer
//! the host passes in is borrowed for the duration of the call only.
//!
//! The host and the SDK both use these declarations; any incompatible change bumps
//! [`ABI_VERSION`].

use std::ffi::c_void;

/// The ABI this SDK speaks.
pub const ABI_VERSION: u32 = 1;

/// The name of the exported entry function.
pub const ENTRY_SYMBOL: &str = "objectsplat_plugin_entry_v1";

/// The call succeeded; the output buffer holds the JSON answer.
pub const STATUS_OK: i32 = 0;
/// The node (or describe) returned an error; the output buffer holds the message.
pub const STATUS_ERROR: i32 = 1;
/// The plugin panicked; the output buffer holds the panic message.
pub const STATUS_PANIC: i32 = 2;

/// A borrowed, immutable UTF-8 string with static lifetime (inside the entry table).
#[repr(C)]
#[derive(Clone, Copy)]
pub struct StaticStr {
    pub ptr: *const u8,
    pub len: usize,
}

impl StaticStr {
    pub const fn new(text: &'static str) -> StaticStr {
        StaticStr {
            ptr: text.as_ptr(),
            len: text.len(),
        }
    }
}

/// Bytes allocated by the plugin and handed to the host, which must give them back
/// through the entry table's `free` (never free them with its own allocator).
#[repr(C)]
pub struct OwnedBuf {
    pub ptr: *mut u8,
    pub len: usize,
    pub cap: usize,
}

impl OwnedBuf {
    pub const fn empty() -> OwnedBuf {
        OwnedBuf {
            ptr: std::ptr::null_mut(),
            len: 0,
            cap: 0,
        }
    }

    /// Leaks `bytes` into a buffer that [`OwnedBuf::reclaim`] turns back into a `Vec`.
    pub fn from_vec(bytes: Vec<u8>) -> OwnedBuf {
        let mut bytes = std::mem::ManuallyDrop::new(bytes);
        OwnedBuf {
            ptr: bytes.as_mut_ptr(),
            len: bytes.len(),
            cap: bytes.capacity(),
        }
    }

    /// # Safety
    /// `self` must come from [`OwnedBuf::from_vec`] in this same library and not have
    /// been reclaimed before.
    pub unsafe fn reclaim(self) -> Vec<u8> {
        if self.ptr.is_null() {
            return Vec::new();
        }
        // SAFETY: the caller guarantees ptr/len/cap came from a leaked Vec<u8> of this allocator.
        unsafe { Vec::from_raw_parts(self.ptr, self.len, self.cap) }
    }
}

/// Services the host offers to a running node. Valid only during the `run` call it
/// was passed to; both callbacks may be called from any thread during that call.
#[repr(C)]
pub struct HostV1 {
    /// `size_of::<HostV1>()` as the host built it; fields beyond it must not be read.
    pub struct_size: usize,
    pub ctx: *const c_void,
    /// Reports progress: `done` of `total` steps, with a UTF-8 message.
    pub progress:
        unsafe extern "C" fn(ctx: *const c_void, done: u64, total: u64, msg: *const u8, len: usize),
    /// Non-zero once the run was interrupted; long loops should return an error.
    pub cancelled: unsafe extern "C" fn(ctx: *const c_void) -> u8,
}

/// `describe(out)`: writes the plugin's description (JSON) into `out`.
pub type DescribeFn = unsafe extern "C" fn(out: *mut OwnedBuf) -> i32;
/// `run(request, len, host, out)`: runs one node; `request` is UTF-8 JSON.
pub type RunFn = unsafe extern "C" fn(
    request: *const u8,
    len: usize,
    host: *const HostV1,
    out: *mut OwnedBuf,
) -> i32;
/// `free(buf)`: releases a buffer this plugin allocated.
pub type FreeFn = unsafe extern "C" fn(buf: OwnedBuf);

/// The fields every ABI version's entry table starts with; the host reads them
/// before anything else.
#[repr(C)]
pub struct EntryHeader {
    pub abi_version: u32,
    pub struct_size: usize,
}

/// The entry table, ABI v1. Field order is fixed; fields are only appended.
#[repr(C)]
pub struct EntryV1 {
    pub abi_version: u32,
    /// `size_of::<EntryV1>()` as the plugin was built.
    pub struct_size: usize,
    /// The plugin crate and version, e.g. `colorkey_masks 0.1.0`.
    pub plugin_build: StaticStr,
    /// The SDK and compiler it was built with, e.g. `objectsplat-plugin-sdk 0.1.0, rustc 1.95.0`.
    pub sdk_build: StaticStr,
    pub describe: DescribeFn,
    pub run: RunFn,
    pub free: FreeFn,
}

// SAFETY: the table is immutable and its pointers point at 'static string data.
unsafe impl Sync for EntryV1 {}

/// The entry function's signature.
pub type EntryFn = unsafe extern "C" fn() -> *const EntryV1;
