//! Scoped worker threads pulling independent jobs from a shared queue.
//!
//! Every job writes only to the slices it owns, so the results do not depend
//! on which thread ran which job: outputs are bitwise identical for any
//! thread count.

use std::sync::Mutex;

/// Runs `work(&mut scratch, job)` for every job of `jobs` on up to `threads`
/// scoped threads; each thread makes its scratch once with `init`. With one
/// thread (or one job) everything runs on the caller's thread, in order.
pub fn run_iter<I, S>(
    threads: usize,
    jobs: I,
    init: impl Fn() -> S + Sync,
    work: impl Fn(&mut S, I::Item) + Sync,
) where
    I: Iterator + Send,
    I::Item: Send,
{
    let (lower, upper) = jobs.size_hint();
    let known = upper.unwrap_or(usize::MAX).max(lower);
    let threads = threads.max(1).min(known.max(1));
    if threads == 1 {
        let mut scratch = init();
        for job in jobs {
            work(&mut scratch, job);
        }
        return;
    }
    let queue = Mutex::new(jobs);
    let next = || {
        // A poisoned lock means another worker panicked; the scope re-raises that panic.
        queue.lock().unwrap_or_else(|p| p.into_inner()).next()
    };
    crossbeam::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|_| {
                let mut scratch = init();
                while let Some(job) = next() {
                    work(&mut scratch, job);
                }
            });
        }
    })
    // Only a panic inside `work` gets here; propagate it unchanged.
    .unwrap_or_else(|e| std::panic::resume_unwind(e));
}

/// [`run_iter`] with per-worker scratch taken from `pool` (grown with `make`
/// to one per worker), so repeated calls reuse the scratch's allocations.
pub fn run_iter_pooled<I, S>(
    threads: usize,
    jobs: I,
    pool: &mut Vec<S>,
    make: impl Fn() -> S,
    work: impl Fn(&mut S, I::Item) + Sync,
) where
    I: Iterator + Send,
    I::Item: Send,
    S: Send,
{
    let workers = threads.max(1);
    while pool.len() < workers {
        pool.push(make());
    }
    let slots = Mutex::new(pool.iter_mut());
    run_iter(
        threads,
        jobs,
        // One slot per worker: `run_iter` starts at most `threads` workers.
        || slots.lock().unwrap_or_else(|p| p.into_inner()).next(),
        |slot, job| {
            if let Some(scratch) = slot.as_deref_mut() {
                work(scratch, job);
            }
        },
    );
}

/// [`run_iter`] over a list of jobs.
pub fn run_jobs<J, S>(
    threads: usize,
    jobs: Vec<J>,
    init: impl Fn() -> S + Sync,
    work: impl Fn(&mut S, J) + Sync,
) where
    J: Send,
{
    run_iter(threads, jobs.into_iter(), init, work);
}

/// Calls `work(first_index, chunk)` for consecutive chunks of `data`.
pub fn for_chunks_mut<T: Send>(
    threads: usize,
    data: &mut [T],
    chunk: usize,
    work: impl Fn(usize, &mut [T]) + Sync,
) {
    let chunk = chunk.max(1);
    let jobs = data
        .chunks_mut(chunk)
        .enumerate()
        .map(|(i, c)| (i * chunk, c));
    run_iter(threads, jobs, || (), |_, (start, c)| work(start, c));
}

/// A chunk size giving each thread several jobs (for load balance) without tiny jobs.
pub fn chunk_size(len: usize, threads: usize, min_chunk: usize) -> usize {
    (len / (threads.max(1) * 8)).max(min_chunk).max(1)
}
