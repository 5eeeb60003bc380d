//! The schedule equals the reference at 30k iterations and scales to small budgets.

use objectsplat_train::Schedule;
use serde_json::json;

/// Each (iteration, SH degree) pair holds in `s`.
fn assert_sh_degrees(s: &Schedule, expected: &[(u64, u32)]) {
    for &(iteration, degree) in expected {
        assert_eq!(s.sh_degree(iteration), degree, "iteration {iteration}");
    }
}

#[test]
fn reference_budget_gives_the_reference_numbers() {
    let s = Schedule::scaled(30_000);
    assert_sh_degrees(&s, &[(999, 0), (1000, 1), (3000, 3), (29_999, 3)]);
    assert!((s.sigma(0) - 1.0).abs() < 1e-15);
    assert!((s.sigma(30_000) - 1e-4).abs() < 1e-15);
    assert!((s.sigma(15_000) - (1.0 + 1e-4) / 2.0).abs() < 1e-12);
    assert_eq!(s.floor_update(4999), None);
    assert_eq!(s.floor_update(5000), Some(0.1));
    assert_eq!(s.floor_update(5250), None);
    let m = s.floor_update(14_500).unwrap();
    assert!((m - (0.1 + 0.8999 * 9500.0 / 19000.0)).abs() < 1e-12);
    assert!((s.floor_update(24_000).unwrap() - 0.9999).abs() < 1e-12);
    assert!((s.floor_update(29_500).unwrap() - 0.9999).abs() < 1e-12);
    // Paused for 1000 iterations after the connectivity step at 11001 (11500 falls inside).
    assert_eq!(s.connectivity_at, 11_001);
    assert_eq!(s.floor_update(11_500), None);
    assert!(s.floor_update(12_500).is_some());
    assert_eq!(s.prune_at(3500), None);
    assert_eq!(s.prune_at(4000), Some(0.235));
    assert_eq!(s.prune_at(4200), None);
    assert_eq!(s.prune_at(5000), Some(0.235));
    assert!((s.prune_at(6000).unwrap() - 0.255).abs() < 1e-12);
    assert!((s.prune_at(10_500).unwrap() - (0.235 + 0.11)).abs() < 1e-12);
    assert_eq!(
        s.prune_at(11_500),
        None,
        "no pruning after the connectivity step"
    );
    let densify: Vec<u64> = (0..30_000).filter(|&i| s.densify_at(i)).collect();
    let want: Vec<u64> = (2..=19).map(|k| k * 500).collect();
    assert_eq!(densify, want, "1000, 1500, …, 9500");
    assert_eq!(s.densify_count(1000), 230);
    let s = s.for_footprint(short_footprint()).unwrap();
    assert!((s.lr_vertices(0) - 1.5e-3).abs() < 1e-15);
    assert!((s.lr_vertices(30_000) - 1.5e-5).abs() < 1e-15);
    assert_eq!(s.final_prune_threshold, 0.5);
}

/// The pixel footprint (world units per pixel) at which the short budget's
/// vertex step is 4e-3 world units: where the world-unit rates were measured.
fn short_footprint() -> f64 {
    4e-3 / Schedule::scaled(3000).vertex_step_start_px
}

/// Short budgets get larger vertex learning rates: 4e-3 → 4e-4 at 3000 iterations and
/// below (at the footprint they were measured at), the reference's at 30k,
/// log-interpolated in between.
#[test]
fn vertex_learning_rates_follow_the_budget() {
    let world = |budget: u64| {
        let s = Schedule::scaled(budget)
            .for_footprint(short_footprint())
            .unwrap();
        (s.lr_vertices_start, s.lr_vertices_end)
    };
    for budget in [200, 1000, 3000] {
        let (start, end) = world(budget);
        assert!((start - 4e-3).abs() < 1e-15, "{budget}");
        assert!((end - 4e-4).abs() < 1e-15, "{budget}");
    }
    let (start, end) = world(9487); // √(3000 · 30000): half-way in log budget
    assert!((start - (4e-3f64 * 1.5e-3).sqrt()).abs() < 1e-4 * 4e-3);
    assert!((end - (4e-4f64 * 1.5e-5).sqrt()).abs() < 1e-4 * 4e-4);
    let (start, end) = world(100_000);
    assert!((start - 1.5e-3).abs() < 1e-15 && (end - 1.5e-5).abs() < 1e-15);
}

/// The rates are a step in pixels: a component twice as far away (or seen at
/// half the resolution) gets twice the world-unit rate; rates given in world
/// units are kept as given; a footprint that is not a positive number is refused.
#[test]
fn vertex_learning_rates_scale_with_the_pixel_footprint() {
    let s = Schedule::scaled(3000);
    let near = s.for_footprint(0.01).unwrap();
    let far = s.for_footprint(0.02).unwrap();
    assert!((far.lr_vertices_start - 2.0 * near.lr_vertices_start).abs() < 1e-15);
    assert!((far.lr_vertices_end - 2.0 * near.lr_vertices_end).abs() < 1e-15);
    assert!((near.lr_vertices_start - s.vertex_step_start_px * 0.01).abs() < 1e-15);
    let given = Schedule::new(
        3000,
        json!({"lr_vertices_start": 1e-3}).as_object().unwrap(),
    )
    .unwrap()
    .for_footprint(0.02)
    .unwrap();
    assert_eq!(given.lr_vertices_start, 1e-3);
    assert!((given.lr_vertices_end - far.lr_vertices_end).abs() < 1e-15);
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(s.for_footprint(bad).is_err(), "{bad}");
    }
}

#[test]
fn six_hundred_iterations_scale_every_iteration_count() {
    let s = Schedule::scaled(600);
    // Scale 1/50: 1000 → 20, 500 → 10, 5000 → 100, 19000 → 380, 11000 → 220.
    assert_sh_degrees(&s, &[(19, 0), (20, 1), (60, 3)]);
    assert_eq!(s.floor_update(99), None);
    assert_eq!(s.floor_update(100), Some(0.1));
    assert_eq!(s.floor_update(105), None);
    assert!((s.floor_update(480).unwrap() - 0.9999).abs() < 1e-12);
    assert_eq!(s.connectivity_at, 221);
    assert_eq!(s.prune_at(80), Some(0.235));
    assert!((s.prune_at(120).unwrap() - 0.255).abs() < 1e-12);
    assert_eq!(s.prune_at(230), None);
    let densify: Vec<u64> = (0..600).filter(|&i| s.densify_at(i)).collect();
    let want: Vec<u64> = (2..=19).map(|k| k * 10).collect();
    assert_eq!(densify, want);
    assert!((s.sigma(600) - 1e-4).abs() < 1e-15);
    let s = s.for_footprint(short_footprint()).unwrap();
    // Half-way through the run the rate is the geometric mean of its ends (4e-3, 4e-4).
    assert!((s.lr_vertices(300) - (4e-3f64 * 4e-4).sqrt()).abs() < 1e-12);
}

#[test]
fn tiny_budgets_keep_periods_positive() {
    let s = Schedule::scaled(10);
    assert!(s.sh_degree_every >= 1 && s.floor_every >= 1 && s.prune_every >= 1);
    s.validate().unwrap();
}

#[test]
fn overrides_replace_named_fields_and_reject_unknown_ones() {
    let o = json!({"densify_growth": 0.5, "sigma_end": 0.01});
    let s = Schedule::new(600, o.as_object().unwrap()).unwrap();
    assert_eq!(s.densify_growth, 0.5);
    assert_eq!(s.sigma_end, 0.01);
    assert_eq!(
        s.connectivity_at, 221,
        "other fields keep their scaled values"
    );
    let bad = json!({"no_such_setting": 1});
    let err = Schedule::new(600, bad.as_object().unwrap()).unwrap_err();
    assert!(format!("{err:#}").contains("no_such_setting"));
    let neg = json!({"lr_opacity": -1.0});
    assert!(Schedule::new(600, neg.as_object().unwrap()).is_err());
    let floor = json!({"floor_base": 0.5, "floor_gain": 0.6});
    assert!(Schedule::new(600, floor.as_object().unwrap()).is_err());
}
