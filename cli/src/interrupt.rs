//! Ctrl-C and SIGTERM for the servers (`serve`, `record`): the first one asks for an orderly
//! stop (the connections closed, the summaries of the logs printed, the capture finished and
//! what it could not place said), a second one ends the process at once, as signals usually do.
//!
//! Before, either signal ended the process where it stood: the protocol errors counted since the
//! last summary (at most a minute's worth) and the notes of a recording still waiting for a step
//! were lost, and `record` never printed what it had recorded.

use std::sync::atomic::{AtomicI32, Ordering};
use std::time::Duration;

/// The signal that asked for the stop; 0 until one came.
static REQUESTED_BY: AtomicI32 = AtomicI32::new(0);

/// How often a waiting server looks for the request: a person pressing Ctrl-C does not notice
/// a tenth of a second.
pub const POLL_INTERVAL: Duration = Duration::from_millis(100);

#[cfg(unix)]
extern "C" fn on_signal(signal: libc::c_int) {
    // Only async-signal-safe work here: an atomic store, and the default disposition back so
    // that a second signal of the same kind ends the process.
    REQUESTED_BY.store(signal, Ordering::SeqCst);
    // SAFETY: `signal` with SIG_DFL is async-signal-safe (POSIX lists it).
    unsafe {
        libc::signal(signal, libc::SIG_DFL);
    }
}

/// Catches SIGINT and SIGTERM from now on (on Unix; elsewhere they keep ending the process).
pub fn install() {
    #[cfg(unix)]
    for signal in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: `on_signal` does only async-signal-safe work (above).
        unsafe {
            libc::signal(signal, on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t);
        }
    }
}

/// The name of the signal that asked for a stop, if one did.
pub fn requested() -> Option<&'static str> {
    match REQUESTED_BY.load(Ordering::SeqCst) {
        0 => None,
        #[cfg(unix)]
        libc::SIGINT => Some("SIGINT"),
        #[cfg(unix)]
        libc::SIGTERM => Some("SIGTERM"),
        _ => Some("a signal"),
    }
}

/// Waits until a stop is asked for, or `done` says the work ended by itself; returns the
/// signal's name in the first case.
pub fn wait_for_stop(mut done: impl FnMut() -> bool) -> Option<&'static str> {
    loop {
        if let Some(signal) = requested() {
            return Some(signal);
        }
        if done() {
            return None;
        }
        std::thread::sleep(POLL_INTERVAL);
    }
}
