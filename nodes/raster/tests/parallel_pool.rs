//! The worker pool behind every parallel pass: each job runs exactly once
//! for any thread count, passes from several threads at once (one uses the
//! pool, the others their own threads) all complete, and a panicking job
//! reaches the caller, with its own message, without breaking later passes —
//! also when the pool is busy and the pass runs on threads of its own.

use objectsplat_raster::parallel::{run_iter, run_jobs};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU32, Ordering};

fn run_counted(threads: usize, jobs: usize) -> Vec<u32> {
    let counts: Vec<AtomicU32> = (0..jobs).map(|_| AtomicU32::new(0)).collect();
    run_jobs(
        threads,
        (0..jobs).collect(),
        || (),
        |_, j| {
            counts[j].fetch_add(1, Ordering::Relaxed);
        },
    );
    counts.into_iter().map(AtomicU32::into_inner).collect()
}

/// A panic's message, whether it was formatted or not.
fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_default()
}

#[test]
fn every_job_runs_once_for_any_thread_count() {
    for threads in 1..=5 {
        for jobs in [0, 1, 2, 7, 1000] {
            let counts = run_counted(threads, jobs);
            assert!(
                counts.iter().all(|&c| c == 1),
                "{threads} threads, {jobs} jobs: {counts:?}"
            );
        }
    }
}

#[test]
fn concurrent_passes_all_complete() {
    std::thread::scope(|s| {
        let callers: Vec<_> = (0..4)
            .map(|k| {
                s.spawn(move || {
                    for round in 0..50 {
                        let jobs = 20 + (round + k) % 13;
                        let counts = run_counted(2 + k % 2, jobs);
                        assert!(counts.iter().all(|&c| c == 1), "caller {k}, round {round}");
                    }
                })
            })
            .collect();
        for c in callers {
            c.join().expect("a caller's passes complete");
        }
    });
}

#[test]
fn a_panicking_job_reaches_the_caller_and_the_pool_keeps_working() {
    for threads in [2, 3] {
        let outcome = std::panic::catch_unwind(|| {
            run_iter(
                threads,
                0..64,
                || (),
                |_, j| {
                    if j == 37 {
                        panic!("job 37 fails");
                    }
                },
            )
        });
        let text = panic_text(outcome.expect_err("the panic is re-raised").as_ref());
        assert!(text.contains("job 37"), "{text:?}");
        assert!(run_counted(threads, 100).iter().all(|&c| c == 1));
    }
}

#[test]
fn a_panic_in_a_pass_nested_in_a_busy_pool_keeps_its_message() {
    // The outer pass holds the pool, so the inner one runs on threads of its own.
    let seen = Mutex::new(Vec::new());
    run_iter(
        2,
        0..2,
        || (),
        |_, outer| {
            let outcome = std::panic::catch_unwind(|| {
                run_iter(
                    3,
                    0..64,
                    || (),
                    |_, j| {
                        if j == 37 {
                            panic!("job 37 fails in pass {outer}");
                        }
                    },
                )
            });
            let text = outcome.err().map(|p| panic_text(p.as_ref()));
            seen.lock().unwrap().push((outer, text));
        },
    );
    let mut seen = seen.into_inner().unwrap();
    seen.sort();
    assert_eq!(
        seen,
        vec![
            (0, Some("job 37 fails in pass 0".to_string())),
            (1, Some("job 37 fails in pass 1".to_string())),
        ]
    );
}
