//! A node's ports as one Rust type: [`node_ports!`](crate::node_ports) declares a struct
//! whose fields are the ports, and from the same lines the spec's ports
//! ([`NodePorts::declare`]) and the folders `run` gets ([`NodePorts::read`]), so a port
//! cannot be declared under one name and read under another.

use crate::{Context, NodeSpec};
use std::path::PathBuf;

/// The ports of a node kind; implemented by [`node_ports!`](crate::node_ports).
pub trait NodePorts: Sized {
    /// Adds every input and output (name, type, doc) to `spec`, in declaration order.
    fn declare(spec: NodeSpec) -> NodeSpec;
    /// The folders of one run: inputs as the engine laid them out, outputs empty.
    fn read(ctx: &Context) -> anyhow::Result<Self>;
}

/// What [`NodePorts::read`] returns (named here so that a macro user needs no `anyhow`).
pub type ReadResult<T> = anyhow::Result<T>;

/// The items of a collection input, in order: (item name, folder).
pub type Items = Vec<(String, PathBuf)>;

/// Declares a node's ports once, as a struct that implements [`NodePorts`]:
///
/// ```
/// use objectsplat_runtime::{NodeSpec, TypeRef, node_ports};
///
/// node_ports! {
///     /// What `blend` reads and writes.
///     struct BlendPorts {
///         /// the picture in front
///         front: input "Image",
///         /// pictures behind it, in order
///         behind: items "Image",
///         /// where the two may differ
///         mask: optional "Mask",
///         /// the blended picture
///         image: output "Image",
///     }
/// }
///
/// let spec = NodeSpec::new("blend", "1").ports::<BlendPorts>();
/// assert_eq!(spec.inputs[1].name, "behind");
/// assert_eq!(spec.inputs[1].ty, TypeRef::List("Image".into()));
/// assert!(spec.inputs[2].optional);
/// assert_eq!(spec.outputs[0].doc, "the blended picture");
/// // `run` gets `front: PathBuf`, `behind: Items`, `mask: Option<PathBuf>`, `image: PathBuf`
/// // from `ctx.ports_as::<BlendPorts>()?`.
/// ```
///
/// Each field is `name: KIND "Type"`; its doc comment is the port's doc. An input and an
/// output may share a port name: `name_out: output "Type" as "name"` names the output
/// `name` and its field `name_out`. The kind says what the field holds:
///
/// | kind             | declares             | field                    |
/// |------------------|----------------------|--------------------------|
/// | `input`          | input `T`            | `PathBuf`                |
/// | `optional`       | optional input `T`   | `Option<PathBuf>`        |
/// | `items`          | input `[T]`          | [`Items`]                |
/// | `optional_items` | optional input `[T]` | `Option<Items>`          |
/// | `output`         | output `T` or `[T]`  | `PathBuf` (empty folder) |
///
/// Under fan-out an `input` port receives one item of a collection; the node sees the
/// item's folder and [`Context::item`] names it.
#[macro_export]
macro_rules! node_ports {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $(
                $(#[doc = $doc:literal])*
                $field:ident : $kind:ident $ty:literal $(as $port:literal)?
            ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone)]
        $vis struct $name {
            $(
                $(#[doc = $doc])*
                pub $field: $crate::node_ports!(@field $kind),
            )*
        }

        impl $crate::ports::NodePorts for $name {
            fn declare(spec: $crate::NodeSpec) -> $crate::NodeSpec {
                $(
                    let spec = $crate::node_ports!(
                        @declare spec,
                        $kind,
                        $crate::node_ports!(@name $field $($port)?),
                        $ty,
                        &$crate::params::doc_text(&[$($doc),*])
                    );
                )*
                spec
            }

            fn read(ctx: &$crate::Context) -> $crate::ports::ReadResult<Self> {
                Ok($name {
                    $( $field: $crate::node_ports!(@read $kind ctx $crate::node_ports!(@name $field $($port)?)), )*
                })
            }
        }
    };

    (@name $field:ident) => { stringify!($field) };
    (@name $field:ident $port:literal) => { $port };

    (@field input) => { ::std::path::PathBuf };
    (@field optional) => { ::std::option::Option<::std::path::PathBuf> };
    (@field items) => { $crate::ports::Items };
    (@field optional_items) => { ::std::option::Option<$crate::ports::Items> };
    (@field output) => { ::std::path::PathBuf };

    // Each kind declares itself through the NodeSpec builder method that fits it.
    (@declare $spec:ident, input, $port:expr, $ty:literal, $doc:expr) => {
        $spec.input($port, $ty, $doc)
    };
    (@declare $spec:ident, optional, $port:expr, $ty:literal, $doc:expr) => {
        $spec.optional_input($port, $ty, $doc)
    };
    (@declare $spec:ident, items, $port:expr, $ty:literal, $doc:expr) => {
        $spec.input($port, concat!("[", $ty, "]"), $doc)
    };
    (@declare $spec:ident, optional_items, $port:expr, $ty:literal, $doc:expr) => {
        $spec.optional_input($port, concat!("[", $ty, "]"), $doc)
    };
    (@declare $spec:ident, output, $port:expr, $ty:literal, $doc:expr) => {
        $spec.output($port, $ty, $doc)
    };

    (@read input $ctx:ident $port:expr) => { $ctx.input($port)?.to_path_buf() };
    (@read optional $ctx:ident $port:expr) => { $ctx.input_opt($port).map(::std::path::Path::to_path_buf) };
    (@read items $ctx:ident $port:expr) => { $ctx.input_items($port)?.to_vec() };
    (@read optional_items $ctx:ident $port:expr) => {
        match $ctx.input_opt($port) {
            Some(_) => Some($ctx.input_items($port)?.to_vec()),
            None => None,
        }
    };
    (@read output $ctx:ident $port:expr) => { $ctx.output($port)? };
}
