//! The built-in node catalogue: every artifact type and every built-in stage.

pub mod types;

use objectsplat_runtime::Registry;

/// A registry with every built-in type and node kind.
pub fn builtin_registry() -> Registry {
    let mut reg = Registry::new();
    types::register(&mut reg);
    objectsplat_images::register(&mut reg);
    objectsplat_inputs::register(&mut reg);
    objectsplat_synth::register(&mut reg);
    objectsplat_masks::register(&mut reg);
    objectsplat_completion::register(&mut reg);
    objectsplat_command::register(&mut reg);
    objectsplat_report::register(&mut reg);
    objectsplat_scene::register(&mut reg);
    objectsplat_export::register(&mut reg);
    objectsplat_evaluate::register(&mut reg);
    objectsplat_train::register(&mut reg);
    reg
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_builtin_kind_registers() {
        let reg = super::builtin_registry();
        for kind in [
            "load_image",
            "save_image",
            "synthetic_scene",
            "colmap_scene",
            "nerfstudio_scene",
            "scannetpp_scene",
            "colmap_sfm",
            "video_frames",
            "gt_masks",
            "import_masks",
            "partition",
            "inpaint",
            "fill_holes",
            "surface_completion",
            "complete_surfaces",
            "inpaint_background",
            "report",
            "compose",
            "edit_scene",
            "render",
            "evaluate",
            "export_gltf",
            "train",
            "command",
        ] {
            assert!(reg.get(kind).is_some(), "{kind} is not registered");
        }
    }
}
