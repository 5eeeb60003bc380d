//! The C-level contract between objectsplat and a plugin library (ABI v1), as the
//! host declares it (`objectsplat-plugin-abi`), plus this SDK's build string.

pub use objectsplat_plugin_abi::abi::*;

/// The SDK half of `sdk_build`.
pub const SDK_BUILD: &str = concat!(
    "objectsplat-plugin-sdk ",
    env!("CARGO_PKG_VERSION"),
    ", ",
    env!("OBJECTSPLAT_SDK_RUSTC")
);
