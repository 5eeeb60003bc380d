//! Duplicating an object (a copy under a new id, moved aside) doubles its triangles in the
//! glTF, as counted by the `gltf` parser on the written file.

mod common;

use objectsplat_export::glb::{build_glb, triangles_per_node};

#[test]
fn duplicated_object_doubles_its_triangles() {
    let objects = common::scene();
    let (before, _) = build_glb(&objects, None).unwrap();
    let counts_before = triangles_per_node(&before).unwrap();

    let mut copy = common::cuboid(
        11,
        "chair",
        [2.0, 0.0, 0.0],
        [2.5, 0.5, 0.9],
        common::CORNER_COLOURS,
    );
    copy.faces = objects[0].faces.clone();
    let mut with_copy = objects.clone();
    with_copy.push(copy);
    let (after, _) = build_glb(&with_copy, None).unwrap();
    let counts_after = triangles_per_node(&after).unwrap();

    let chair = counts_before["obj_3_chair"];
    assert_eq!(chair, 12);
    assert_eq!(
        counts_after["obj_3_chair"] + counts_after["obj_11_chair"],
        2 * chair
    );
    let total = |c: &std::collections::BTreeMap<String, usize>| c.values().sum::<usize>();
    assert_eq!(total(&counts_after), total(&counts_before) + chair);
}
