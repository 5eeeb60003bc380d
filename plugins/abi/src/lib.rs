//! The plugin boundary, declared once: the engine (`objectsplat-runtime`) loads
//! plugins through these types and the SDK (`objectsplat-plugin-sdk`) exports
//! them, so the two cannot drift apart. A plugin written in another language
//! declares the same structs and messages (docs/plugins.md).

pub mod abi;
pub mod folders;
pub mod protocol;
