//! The built-in node catalogue: every artifact type and every built-in stage.

pub mod imaging;
pub mod types;

use objectsplat_runtime::Registry;

/// A registry with every built-in type and node kind.
pub fn builtin_registry() -> Registry {
    let mut reg = Registry::new();
    types::register(&mut reg);
    imaging::register(&mut reg);
    reg
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_builtin_kind_registers() {
        let reg = super::builtin_registry();
        assert!(reg.get("load_image").is_some() && reg.get("save_image").is_some());
    }
}
