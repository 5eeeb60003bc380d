//! Ctrl-C (SIGINT) and SIGTERM while Slurm jobs are out: the first one asks the run
//! to cancel its jobs and stop; a second one ends the process at once, as usual.
//!
//! Without this a Ctrl-C would end the coordinator and leave its jobs queued on the
//! cluster, computing for nobody.

use std::sync::atomic::{AtomicUsize, Ordering};

static SIGNALS: AtomicUsize = AtomicUsize::new(0);

/// True once a SIGINT or SIGTERM arrived since [`Guard::install`].
pub fn interrupted() -> bool {
    SIGNALS.load(Ordering::SeqCst) > 0
}

/// Handlers installed for the life of the guard; the previous ones come back on drop.
pub struct Guard {
    #[cfg(unix)]
    previous: Vec<(libc::c_int, libc::sighandler_t)>,
}

#[cfg(unix)]
extern "C" fn on_signal(sig: libc::c_int) {
    if SIGNALS.fetch_add(1, Ordering::SeqCst) == 0 {
        let msg = b"\ninterrupted: cancelling this run's Slurm jobs (again to quit at once)\n";
        // SAFETY: write(2) is async-signal-safe; the buffer is static.
        unsafe { libc::write(2, msg.as_ptr().cast(), msg.len()) };
    } else {
        // SAFETY: signal and raise are async-signal-safe; the default action ends the
        // process the way the signal always would.
        unsafe {
            libc::signal(sig, libc::SIG_DFL);
            libc::raise(sig);
        }
    }
}

impl Guard {
    pub fn install() -> Guard {
        SIGNALS.store(0, Ordering::SeqCst);
        #[cfg(unix)]
        {
            let mut previous = Vec::new();
            for sig in [libc::SIGINT, libc::SIGTERM] {
                let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
                // SAFETY: installs a handler that only touches an atomic and calls
                // async-signal-safe functions.
                let old = unsafe { libc::signal(sig, handler) };
                previous.push((sig, old));
            }
            Guard { previous }
        }
        #[cfg(not(unix))]
        Guard {}
    }
}

impl Drop for Guard {
    fn drop(&mut self) {
        #[cfg(unix)]
        for &(sig, old) in &self.previous {
            if old != libc::SIG_ERR {
                // SAFETY: restores the handler that was there before install.
                unsafe { libc::signal(sig, old) };
            }
        }
    }
}
