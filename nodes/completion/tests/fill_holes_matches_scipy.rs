//! `fill_holes` against `scipy.ndimage.binary_fill_holes` (fixtures from
//! tests/fixtures/make_fixtures.py: random masks and the horse silhouette, both
//! connectivities), and a property test against SciPy's own definition written out
//! naively: iterate a constrained dilation from a border marker until it stops.

use objectsplat_completion::fill_holes::{Connectivity, fill_holes};
use proptest::prelude::*;
use std::path::{Path, PathBuf};

mod common;

fn fixtures() -> PathBuf {
    common::fixture("fill_holes")
}

fn load(path: &Path) -> (Vec<bool>, usize, usize) {
    let img = image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_luma8();
    let (w, h) = (img.width() as usize, img.height() as usize);
    (img.into_raw().into_iter().map(|v| v != 0).collect(), w, h)
}

#[derive(serde::Deserialize)]
struct Manifest {
    masks: Vec<String>,
}

#[test]
fn random_masks_and_horse_match_scipy_exactly() {
    let root = fixtures();
    let manifest: Manifest = common::read_json(&root.join("manifest.json"));
    assert!(manifest.masks.contains(&"horse".to_string()));
    let mut changed_pixels = 0usize;
    for name in &manifest.masks {
        let (set, w, h) = load(&root.join(format!("{name}.png")));
        for (n, connectivity) in [(4, Connectivity::Four), (8, Connectivity::Eight)] {
            let (expected, ew, eh) = load(&root.join(format!("{name}_filled_{n}.png")));
            assert_eq!((ew, eh), (w, h));
            let got = fill_holes(&set, w, h, connectivity);
            let wrong = got.iter().zip(&expected).filter(|(a, b)| a != b).count();
            assert_eq!(
                wrong, 0,
                "{name}, connectivity {n}: {wrong} pixels differ from scipy"
            );
            changed_pixels += got.iter().zip(&set).filter(|(a, b)| a != b).count();
        }
    }
    // The fixtures must actually contain holes, or the comparison proves little.
    assert!(
        changed_pixels > 100,
        "only {changed_pixels} pixels filled across all fixtures"
    );
}

/// SciPy's definition: `~binary_dilation(zeros, structure, iterations=-1,
/// mask=~input, border_value=1)`, iterated literally.
fn reference(set: &[bool], w: usize, h: usize, connectivity: Connectivity) -> Vec<bool> {
    let mut reached = vec![false; set.len()];
    let diagonal = connectivity == Connectivity::Eight;
    loop {
        let mut next = reached.clone();
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let i = (y * w as i64 + x) as usize;
                if set[i] || reached[i] {
                    continue;
                }
                let mut hit = false;
                for dy in -1..=1i64 {
                    for dx in -1..=1i64 {
                        if (dx, dy) == (0, 0) || (!diagonal && dx != 0 && dy != 0) {
                            continue;
                        }
                        let (nx, ny) = (x + dx, y + dy);
                        let outside = nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64;
                        hit |= outside || reached[(ny * w as i64 + nx) as usize];
                    }
                }
                next[i] = hit;
            }
        }
        if next == reached {
            return reached.iter().map(|r| !r).collect();
        }
        reached = next;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    #[test]
    fn agrees_with_the_iterated_dilation_definition(
        (w, h, bits) in (1usize..14, 1usize..14).prop_flat_map(|(w, h)| {
            (Just(w), Just(h), proptest::collection::vec(proptest::bool::weighted(0.55), w * h))
        }),
        eight in any::<bool>(),
    ) {
        let connectivity = if eight { Connectivity::Eight } else { Connectivity::Four };
        prop_assert_eq!(fill_holes(&bits, w, h, connectivity), reference(&bits, w, h, connectivity));
    }
}
