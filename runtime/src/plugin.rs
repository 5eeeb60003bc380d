//! Loading node kinds from shared libraries (being written; see issue "Dynamic plugins").

use crate::registry::Registry;
use std::path::Path;

/// Loads a plugin library and registers its node kinds.
pub fn load(_reg: &mut Registry, path: &Path) -> Result<(), String> {
    Err(format!(
        "{}: this build cannot load plugins yet",
        path.display()
    ))
}
