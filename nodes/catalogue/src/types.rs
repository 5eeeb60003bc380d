//! The artifact types every built-in node speaks; their names and encodings are declared
//! once in `objectsplat_core::artifact` (the text `objectsplat nodes` prints and plugin
//! authors read).

use objectsplat_core::artifact::TYPES;
use objectsplat_runtime::Registry;

pub fn register(reg: &mut Registry) {
    for t in TYPES {
        reg.add_type(t.name, t.doc);
    }
}
