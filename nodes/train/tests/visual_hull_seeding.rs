//! An object with too few sparse points is seeded on the visual hull of its
//! masks: the seeds lie over the plate (the square |x|, |y| ≤ 0.5 at z = 0 its
//! masks show), carry its colour, and come in the number asked for.

mod common;

use glam::DVec3;
use objectsplat_core::Points;
use objectsplat_train::hull::{initial_points, visual_hull_points};

#[test]
fn seeds_lie_over_the_plate_in_its_colour() {
    let (_dir, data) = common::plate_read(common::W, common::H);
    // One point of its own: the search stays near it, not along the whole column
    // of space the near-vertical views leave undecided.
    let all = common::points();
    let own = data.owned_points(&all, None).unwrap();
    let one = Points {
        positions: own.positions[..1].to_vec(),
        colors: own.colors[..1].to_vec(),
    };
    let (seeds, seeded) = initial_points(&data, &one, one.clone(), 201, 0).unwrap();
    assert_eq!(seeded, 200);
    // Over the whole scene box the hull is a column through the plate.
    let column = visual_hull_points(&data, (DVec3::splat(-2.0), DVec3::splat(2.0)), 200, 0);
    assert!(column.positions.iter().any(|p| p[2].abs() > 1.0));
    for (p, c) in seeds.positions.iter().zip(&seeds.colors) {
        // The cameras look down from z ≈ 2 within 15° of vertical: the hull of a
        // flat square is a slab around it, a little wider where it is thicker.
        assert!(
            p[0].abs() <= 0.6 && p[1].abs() <= 0.6,
            "seed {p:?} off the plate"
        );
        assert!(p[2].abs() <= 0.6, "seed {p:?} far from the plate's plane");
        let red = common::RED.map(|v| (v * 255.0).round() as i32);
        assert!(
            (0..3).all(|k| (c[k] as i32 - red[k]).abs() <= 30),
            "seed colour {c:?} is not the plate's"
        );
    }
}

#[test]
fn only_objects_short_of_points_are_seeded() {
    let (_dir, data) = common::plate_read(common::W, common::H);
    let points = common::points();
    let owned = data.owned_points(&points, None).unwrap();
    let own = owned.positions.len();
    assert!(own > 0);
    let (none_asked, seeded) = initial_points(&data, &points, owned.clone(), 0, 0).unwrap();
    assert_eq!((none_asked.positions.len(), seeded), (own, 0));
    let (topped_up, seeded) = initial_points(&data, &points, owned, own + 50, 0).unwrap();
    assert_eq!(seeded, 50);
    assert_eq!(topped_up.positions.len(), own + 50);
    // With no sparse points at all there is no box to search: a clear error.
    let err = initial_points(&data, &Points::default(), Points::default(), 100, 0).unwrap_err();
    assert!(format!("{err:#}").contains("nothing to initialize from"));
}
