//! Worker threads pulling independent jobs from a shared queue.
//!
//! Every job writes only to the slices it owns, so the results do not depend
//! on which thread ran which job: outputs are bitwise identical for any
//! thread count.
//!
//! The workers are kept between calls (a process-wide pool): a training step runs a
//! few dozen parallel passes, and starting threads for each cost ~0.1 ms a
//! pass on a busy 2-core machine, as much as a small object's whole pass.

use std::any::Any;
use std::sync::{Condvar, Mutex, MutexGuard, OnceLock, TryLockError};

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
        // A poisoned lock means another worker panicked; that panic is re-raised below.
        queue.lock().unwrap_or_else(|p| p.into_inner()).next()
    };
    let worker = || {
        let mut scratch = init();
        while let Some(job) = next() {
            work(&mut scratch, job);
        }
    };
    if pool::run(threads, &worker) {
        return;
    }
    // The pool is busy (another thread's pass, or a pass inside a job): threads of our own.
    let first_panic = std::thread::scope(|scope| {
        let helpers: Vec<_> = (1..threads).map(|_| scope.spawn(worker)).collect();
        let own = std::panic::catch_unwind(std::panic::AssertUnwindSafe(worker)).err();
        // Every helper is joined here, so none panics unobserved (which would make
        // the scope raise its own message instead of the job's).
        let helpers: Vec<_> = helpers.into_iter().filter_map(|h| h.join().err()).collect();
        own.into_iter().chain(helpers).next()
    });
    // Re-raise the job's own panic payload, as the pool path does.
    if let Some(p) = first_panic {
        std::panic::resume_unwind(p);
    }
}

/// Threads started once and reused by every parallel pass.
mod pool {
    use super::*;

    /// A pass's body as the workers see it: called once per participating thread.
    type Task = &'static (dyn Fn() + Sync);

    #[derive(Default)]
    struct State {
        /// The current pass, while workers may still pick it up or run it.
        task: Option<Task>,
        /// Workers still to join the current pass.
        wanted: usize,
        /// Workers running it now.
        running: usize,
        /// The first panic of a worker in the current pass.
        panic: Option<Box<dyn Any + Send>>,
        /// Workers started so far.
        workers: usize,
    }

    #[derive(Default)]
    struct Pool {
        /// Held by the one caller using the pool; others fall back to their own threads.
        caller: Mutex<()>,
        state: Mutex<State>,
        wake: Condvar,
        finished: Condvar,
    }

    fn lock(m: &Mutex<State>) -> MutexGuard<'_, State> {
        // The state is only changed by the code below, which does not panic
        // while holding the lock (tasks run unlocked, inside catch_unwind).
        m.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn shared() -> &'static Pool {
        static POOL: OnceLock<Pool> = OnceLock::new();
        POOL.get_or_init(Pool::default)
    }

    fn serve(pool: &'static Pool) {
        loop {
            let task = {
                let mut st = lock(&pool.state);
                while st.wanted == 0 {
                    st = pool.wake.wait(st).unwrap_or_else(|p| p.into_inner());
                }
                st.wanted -= 1;
                st.running += 1;
                // `wanted > 0` only while a task is set.
                st.task.expect("a pass to join")
            };
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(task));
            let mut st = lock(&pool.state);
            st.running -= 1;
            if let Err(p) = outcome {
                st.panic.get_or_insert(p);
            }
            if st.running == 0 && st.wanted == 0 {
                pool.finished.notify_all();
            }
        }
    }

    /// Runs `task` on the calling thread and on `threads − 1` pool workers,
    /// returning when every call has returned (re-raising a panic of any).
    /// False, without running anything, when another caller holds the pool.
    pub fn run(threads: usize, task: &(dyn Fn() + Sync)) -> bool {
        let pool = shared();
        let _turn = match pool.caller.try_lock() {
            Ok(turn) => turn,
            // A pass that panicked poisons nothing the next one relies on.
            Err(TryLockError::Poisoned(p)) => p.into_inner(),
            Err(TryLockError::WouldBlock) => return false,
        };
        let helpers = threads.saturating_sub(1);
        {
            let mut st = lock(&pool.state);
            // SAFETY: the reference is only used by workers that joined this
            // pass, and this function returns (or unwinds) only after every
            // one of them has returned from it and no worker can still join
            // (`wanted` is reset below before the wait ends), so it never
            // outlives `task`.
            st.task = Some(unsafe { std::mem::transmute::<&(dyn Fn() + Sync), Task>(task) });
            st.wanted = helpers;
            st.panic = None;
            while st.workers < helpers {
                st.workers += 1;
                std::thread::Builder::new()
                    .name("objectsplat-raster".into())
                    .spawn(move || serve(pool))
                    .inspect_err(|_| {
                        // Without the thread, nobody would join: run short-handed.
                        st.wanted -= 1;
                        st.workers -= 1;
                    })
                    .ok();
            }
            pool.wake.notify_all();
        }
        let own = std::panic::catch_unwind(std::panic::AssertUnwindSafe(task));
        let mut st = lock(&pool.state);
        // Workers that have not woken yet find nothing left to do: stop waiting for them.
        st.wanted = 0;
        while st.running > 0 {
            st = pool.finished.wait(st).unwrap_or_else(|p| p.into_inner());
        }
        st.task = None;
        let panic = st.panic.take();
        drop(st);
        if let Err(p) = own {
            std::panic::resume_unwind(p);
        }
        if let Some(p) = panic {
            std::panic::resume_unwind(p);
        }
        true
    }
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
