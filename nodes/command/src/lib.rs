//! External programs as ObjectSplat stages: [`process`] runs one (argv, no shell, a
//! timeout, the tail of its stderr in errors) and [`node`] is the generic `command`
//! stage whose ports, arguments and options a graph declares.

pub mod node;
pub mod process;

pub use node::register;
