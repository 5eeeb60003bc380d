//! Scoped worker threads pulling independent jobs from a shared queue.
//!
//! Every job writes only to the slices it owns, so the results do not depend
//! on which thread ran which job: outputs are bitwise identical for any
//! thread count.

use std::sync::Mutex;

/// Runs `work(&mut scratch, job)` for every job on up to `threads` scoped
/// threads; each thread makes its scratch once with `init`.
pub fn run_jobs<J, S>(
    threads: usize,
    jobs: Vec<J>,
    init: impl Fn() -> S + Sync,
    work: impl Fn(&mut S, J) + Sync,
) where
    J: Send,
{
    let threads = threads.max(1).min(jobs.len().max(1));
    if threads == 1 {
        let mut scratch = init();
        for job in jobs {
            work(&mut scratch, job);
        }
        return;
    }
    let queue = Mutex::new(jobs.into_iter());
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

/// Calls `work(first_index, chunk)` for consecutive chunks of `data`.
pub fn for_chunks_mut<T: Send>(
    threads: usize,
    data: &mut [T],
    chunk: usize,
    work: impl Fn(usize, &mut [T]) + Sync,
) {
    let chunk = chunk.max(1);
    let jobs: Vec<(usize, &mut [T])> = data
        .chunks_mut(chunk)
        .enumerate()
        .map(|(i, c)| (i * chunk, c))
        .collect();
    run_jobs(threads, jobs, || (), |_, (start, c)| work(start, c));
}

/// A chunk size giving each thread several jobs (for load balance) without tiny jobs.
pub fn chunk_size(len: usize, threads: usize, min_chunk: usize) -> usize {
    (len / (threads.max(1) * 8)).max(min_chunk).max(1)
}
