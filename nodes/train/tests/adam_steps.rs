//! Adam updates against hand-computed steps, and the resizable state.

use objectsplat_train::{Adam, LogLinearDecay};

/// First step: m̂ = g and v̂ = g², so every value moves by exactly lr·sign(g).
#[test]
fn first_step_moves_by_the_learning_rate() {
    let mut adam = Adam::new();
    let g = adam.add_group("x", 0.01, 2, 2);
    let mut p = vec![1.0f32, 2.0, 3.0, 4.0];
    adam.step(g, &mut p, &[0.5, -2.0, 1e-3, -7.0]).unwrap();
    let want = [0.99f32, 2.01, 2.99, 4.01];
    for (a, b) in p.iter().zip(want) {
        assert!((a - b).abs() < 1e-6, "{p:?} vs {want:?}");
    }
}

/// Second step with the gradient reversed: m = 0.09 − 0.1 = −0.01, m̂ = −0.01/0.19,
/// v = 0.000999 + 0.001 = 0.001999 = 1 − 0.999², v̂ = 1, so the step is +lr/19.
#[test]
fn second_step_matches_the_hand_computation() {
    let mut adam = Adam::new();
    let g = adam.add_group("x", 0.1, 1, 1);
    let mut p = vec![0.0f32];
    adam.step(g, &mut p, &[1.0]).unwrap();
    assert!((p[0] + 0.1).abs() < 1e-7);
    adam.step(g, &mut p, &[-1.0]).unwrap();
    let want = -0.1 + 0.1 / 19.0;
    assert!((p[0] as f64 - want).abs() < 1e-6, "{} vs {want}", p[0]);
}

/// Groups keep their own learning rates.
#[test]
fn groups_use_their_own_learning_rates() {
    let mut adam = Adam::new();
    let a = adam.add_group("a", 0.5, 1, 1);
    let b = adam.add_group("b", 0.001, 3, 1);
    let mut pa = vec![0.0f32];
    let mut pb = vec![0.0f32; 3];
    adam.step(a, &mut pa, &[3.0]).unwrap();
    adam.step(b, &mut pb, &[3.0, -3.0, 0.0]).unwrap();
    assert!((pa[0] + 0.5).abs() < 1e-6);
    assert!((pb[0] + 0.001).abs() < 1e-7 && (pb[1] - 0.001).abs() < 1e-7);
    assert_eq!(
        pb[2], 0.0,
        "a zero gradient with zero moments does not move"
    );
    adam.set_lr(a, 0.25).unwrap();
    assert_eq!(adam.groups[a].lr, 0.25);
    assert!(adam.set_lr(a, f64::NAN).is_err());
}

/// Removing rows keeps the survivors' moments: the run continues exactly as an
/// optimizer that only ever saw the surviving rows.
#[test]
fn pruned_rows_continue_like_an_optimizer_of_the_survivors() {
    let grads =
        |k: usize| -> Vec<f32> { (0..8).map(|i| ((i * 7 + k * 3) % 5) as f32 - 2.1).collect() };
    let keep = [true, false, true, true, false, false, true, true];
    let mut full = Adam::new();
    let gf = full.add_group("x", 0.05, 2, 4);
    let mut pf: Vec<f32> = (0..8).map(|i| i as f32).collect();
    let mut alone = Adam::new();
    let ga = alone.add_group("x", 0.05, 2, 2);
    // Rows 0 and 2 of four (values 0,1 and 4,5) are the ones kept below.
    let rows_kept = [0usize, 1, 4, 5];
    let mut pa: Vec<f32> = rows_kept.iter().map(|&i| i as f32).collect();
    for k in 0..3 {
        let g = grads(k);
        full.step(gf, &mut pf, &g).unwrap();
        let ga_grads: Vec<f32> = rows_kept.iter().map(|&i| g[i]).collect();
        alone.step(ga, &mut pa, &ga_grads).unwrap();
    }
    let row_keep = [true, false, true, false];
    full.retain_rows(&row_keep).unwrap();
    let mut pf: Vec<f32> = rows_kept.iter().map(|&i| pf[i]).collect();
    assert_eq!(
        full.groups[gf].first_moment(),
        alone.groups[ga].first_moment()
    );
    let g: Vec<f32> = keep.iter().take(4).map(|_| 0.7).collect();
    full.step(gf, &mut pf, &g).unwrap();
    alone.step(ga, &mut pa, &g).unwrap();
    assert_eq!(pf, pa);
    assert!(
        full.retain_rows(&[true]).is_err(),
        "a mask of the wrong length is refused"
    );
}

/// Appended rows start with zero moments; existing rows are untouched.
#[test]
fn appended_rows_start_from_zero_moments() {
    let mut adam = Adam::new();
    let g = adam.add_group("x", 0.01, 3, 2);
    let mut p = vec![0.0f32; 6];
    adam.step(g, &mut p, &[1.0; 6]).unwrap();
    let before = adam.groups[g].first_moment().to_vec();
    adam.append_rows(2);
    let grp = &adam.groups[g];
    assert_eq!(grp.rows(), 4);
    assert_eq!(&grp.first_moment()[..6], &before[..]);
    assert!(grp.first_moment()[6..].iter().all(|&m| m == 0.0));
    assert!(grp.second_moment()[6..].iter().all(|&v| v == 0.0));
    let mut p = vec![0.0f32; 12];
    assert!(
        adam.step(g, &mut p, &[0.0; 11]).is_err(),
        "size mismatch is refused"
    );
    let mut bad = vec![0.0f32; 12];
    bad[3] = f32::NAN;
    assert!(
        adam.step(g, &mut p, &bad).is_err(),
        "NaN gradients are refused"
    );
}

/// 1.5e-3 → 1.5e-5 over the run: the midpoint is the geometric mean.
#[test]
fn position_learning_rate_decays_log_linearly() {
    let d = LogLinearDecay {
        start: 1.5e-3,
        end: 1.5e-5,
        total: 30_000,
    };
    assert!((d.at(0) - 1.5e-3).abs() < 1e-15);
    assert!((d.at(15_000) - 1.5e-4).abs() < 1e-12);
    assert!((d.at(30_000) - 1.5e-5).abs() < 1e-15);
    assert!((d.at(40_000) - 1.5e-5).abs() < 1e-15);
    assert!((d.at(7_500) - 1.5e-3 * 0.01f64.powf(0.25)).abs() < 1e-12);
}

/// Rows shared among threads in blocks update exactly as one thread does (each
/// value's update is its own), for whole rows and for the first columns only,
/// and an overflow is still found.
#[test]
fn several_threads_step_exactly_as_one() {
    // 40 000 rows of 48 values: several blocks of rows, as an SH table of a large model.
    let (width, rows) = (48, 40_000);
    let grads = |k: usize| -> Vec<f32> {
        (0..width * rows)
            .map(|i| ((i * 31 + k * 17) % 97) as f32 / 48.5 - 1.0)
            .collect()
    };
    let run = |threads: usize| {
        let mut adam = Adam::new();
        let g = adam.add_group("sh", 0.01, width, rows);
        adam.set_column_split(g, 3, 0.0005).unwrap();
        let mut p: Vec<f32> = (0..width * rows).map(|i| (i % 13) as f32 * 0.1).collect();
        for (k, active) in [(0, 12), (1, 12), (2, width)] {
            adam.step_columns(g, &mut p, &grads(k), active, threads)
                .unwrap();
        }
        (p, adam)
    };
    let (one, adam_one) = run(1);
    for threads in [2, 3, 8] {
        let (p, adam) = run(threads);
        assert!(p == one, "parameters differ with {threads} threads");
        assert!(adam == adam_one, "moments differ with {threads} threads");
    }
    // Columns past the active ones moved only in the last, full-width step.
    let mut adam = Adam::new();
    let g = adam.add_group("sh", 0.01, width, rows);
    let mut p = vec![0.0f32; width * rows];
    adam.step_columns(g, &mut p, &grads(0), 12, 4).unwrap();
    assert!(p.chunks(width).all(|r| r[12..].iter().all(|&v| v == 0.0)));
    assert!(p.chunks(width).all(|r| r[..12].iter().any(|&v| v != 0.0)));
    // A value that overflows in the last block is reported, whichever thread met it.
    let mut adam = Adam::new();
    let g = adam.add_group("sh", 1e38, width, rows);
    let mut p = vec![0.0f32; width * rows];
    p[width * rows - 1] = f32::MAX;
    let mut g0 = vec![0.0f32; width * rows];
    g0[width * rows - 1] = -1.0;
    let err = adam.step_columns(g, &mut p, &g0, width, 4).unwrap_err();
    assert!(format!("{err:#}").contains("not finite"), "{err:#}");
}

#[test]
fn a_gradient_that_is_not_finite_is_named_wherever_it_is() {
    // The check scans in chunks: a bad value in a later chunk, and in the
    // last value, is named, and nothing moves.
    let (width, rows) = (48, 1000);
    for (i, bad) in [(1000, f32::NAN), (width * rows - 1, f32::INFINITY)] {
        let mut adam = Adam::new();
        let g = adam.add_group("sh", 0.01, width, rows);
        let mut p = vec![0.5f32; width * rows];
        let mut grads = vec![0.25f32; width * rows];
        grads[i] = bad;
        let err = adam.step_columns(g, &mut p, &grads, width, 2).unwrap_err();
        assert!(
            format!("{err:#}").contains(&format!("gradient {i} is {bad}")),
            "{err:#}"
        );
        assert!(p.iter().all(|&v| v == 0.5), "a refused step moved values");
    }
}

/// Renumbered rows continue exactly as the same rows did in their old places:
/// two optimizers, one stepping the rows as given and one the rows reversed
/// from the start, agree after the first is renumbered.
#[test]
fn renumbered_rows_continue_like_an_optimizer_of_that_order() {
    let grads =
        |k: usize| -> Vec<f32> { (0..6).map(|i| ((i * 5 + k * 7) % 9) as f32 - 4.3).collect() };
    // Rows of width 2: row r holds values 2r, 2r + 1.
    let order = [2u32, 0, 1];
    let reorder = |v: &[f32]| -> Vec<f32> {
        order
            .iter()
            .flat_map(|&r| [v[2 * r as usize], v[2 * r as usize + 1]])
            .collect()
    };
    let mut given = Adam::new();
    let g = given.add_group("x", 0.05, 2, 3);
    let mut p: Vec<f32> = (0..6).map(|i| i as f32).collect();
    let mut renumbered = Adam::new();
    let r = renumbered.add_group("x", 0.05, 2, 3);
    let mut q = reorder(&p);
    for k in 0..3 {
        given.step(g, &mut p, &grads(k)).unwrap();
        renumbered.step(r, &mut q, &reorder(&grads(k))).unwrap();
    }
    given.permute_rows(&order).unwrap();
    let mut p = reorder(&p);
    assert_eq!(p, q);
    assert_eq!(
        given.groups[g].second_moment(),
        renumbered.groups[r].second_moment()
    );
    given.step(g, &mut p, &grads(3)).unwrap();
    renumbered.step(r, &mut q, &grads(3)).unwrap();
    assert_eq!(p, q);
    assert!(
        given.permute_rows(&[0, 1]).is_err(),
        "a short order is refused"
    );
    assert!(
        given.permute_rows(&[0, 0, 1]).is_err(),
        "a repeated row is refused"
    );
    assert!(
        given.permute_rows(&[0, 1, 3]).is_err(),
        "a row beyond is refused"
    );
}
