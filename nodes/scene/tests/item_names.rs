//! Which component a `[Model]` item stands for, from its name alone.

use objectsplat_core::ComponentKind;
use objectsplat_scene::scene::parse_item_name;

#[test]
fn item_names_map_to_components() {
    let bg = parse_item_name("background").unwrap();
    assert_eq!(bg.kind, ComponentKind::Background);
    // The holistic baseline's single component (partition with `holistic: true`).
    let whole = parse_item_name("scene").unwrap();
    assert_eq!(whole.kind, ComponentKind::Background);
    assert_eq!(whole.name, "scene");
    let chair = parse_item_name("obj_3_chair").unwrap();
    assert_eq!(chair.kind, ComponentKind::Object);
    assert_eq!(chair.name, "obj_3_chair");
    for bad in ["scenery", "obj_x_cup", "obj_0_cup", "obj_70000_cup", ""] {
        let err = parse_item_name(bad).expect_err(bad);
        assert!(format!("{err:#}").contains(bad), "{err:#}");
    }
}
