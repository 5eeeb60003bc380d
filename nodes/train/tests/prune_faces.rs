//! Pruning removes faces, then unreferenced vertices, and renumbers the rest.

use objectsplat_raster::Model;
use objectsplat_raster::model::SH_COEFFS;
use objectsplat_train::densify::prune_faces;

#[test]
fn pruning_drops_unreferenced_vertices_and_remaps_faces() {
    let mut m = Model::<f32>::empty();
    m.vertices = (0..6).map(|i| [i as f32, (i * i) as f32, 0.5]).collect();
    m.sh = (0..6)
        .map(|i| {
            let mut s = [[0.0f32; 3]; SH_COEFFS];
            s[0][0] = i as f32;
            s
        })
        .collect();
    m.opacity_logits = (0..6).map(|i| i as f32 * 0.1).collect();
    m.faces = vec![[0, 1, 2], [2, 3, 4], [3, 4, 5]];
    let edit = prune_faces(&mut m, &[false, true, false]).unwrap();
    assert_eq!(edit.keep, vec![false, false, true, true, true, false]);
    assert_eq!(m.faces, vec![[0, 1, 2]]);
    assert_eq!(
        m.vertices,
        vec![[2.0, 4.0, 0.5], [3.0, 9.0, 0.5], [4.0, 16.0, 0.5]]
    );
    assert_eq!(
        m.sh.iter().map(|s| s[0][0]).collect::<Vec<_>>(),
        vec![2.0, 3.0, 4.0]
    );
    assert_eq!(m.opacity_logits, vec![0.2, 0.3, 0.4]);
    m.validate().unwrap();
    assert!(
        prune_faces(&mut m, &[true, true]).is_err(),
        "mask length is checked"
    );
    prune_faces(&mut m, &[false]).unwrap();
    assert!(m.vertices.is_empty() && m.faces.is_empty());
}
